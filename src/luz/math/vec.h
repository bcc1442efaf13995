// Small vectors for host and device. RGB colours are Vec3 as well.
#pragma once

#include <cmath>

#include "luz/core/common.h"

namespace luz {

struct Vec2 {
  float x = 0, y = 0;
};

struct Vec3 {
  float x = 0, y = 0, z = 0;
  LUZ_INLINE float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  LUZ_INLINE float& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
};

using Color = Vec3;

LUZ_INLINE Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
LUZ_INLINE Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
LUZ_INLINE Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
LUZ_INLINE Vec3 operator*(Vec3 a, Vec3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
LUZ_INLINE Vec3 operator*(Vec3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
LUZ_INLINE Vec3 operator*(float s, Vec3 a) { return {a.x * s, a.y * s, a.z * s}; }
LUZ_INLINE Vec3 operator/(Vec3 a, float s) { return a * (1.f / s); }
LUZ_INLINE Vec3& operator+=(Vec3& a, Vec3 b) { return a = a + b; }
LUZ_INLINE Vec3& operator*=(Vec3& a, Vec3 b) { return a = a * b; }
LUZ_INLINE Vec3& operator*=(Vec3& a, float s) { return a = a * s; }

LUZ_INLINE float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
LUZ_INLINE Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
LUZ_INLINE float length_squared(Vec3 a) { return dot(a, a); }
LUZ_INLINE float length(Vec3 a) { return sqrtf(dot(a, a)); }
LUZ_INLINE Vec3 normalize(Vec3 a) { return a * (1.f / length(a)); }
LUZ_INLINE float max_component(Vec3 a) { return max(a.x, max(a.y, a.z)); }
// The largest magnitude of a coordinate.
LUZ_INLINE float max_abs(Vec3 a) { return max(fabsf(a.x), max(fabsf(a.y), fabsf(a.z))); }
LUZ_INLINE float average(Vec3 a) { return (a.x + a.y + a.z) * (1.f / 3.f); }
// Rec. 709 luminance: what a float parameter reads from a colour texture
// (Mitsuba's eval_1 of an RGB bitmap).
LUZ_INLINE float luminance(Color c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
LUZ_INLINE bool is_black(Vec3 a) { return a.x == 0.f && a.y == 0.f && a.z == 0.f; }
LUZ_INLINE bool is_finite(Vec3 a) { return is_finite(a.x) && is_finite(a.y) && is_finite(a.z); }
LUZ_INLINE Vec3 vmin(Vec3 a, Vec3 b) { return {min(a.x, b.x), min(a.y, b.y), min(a.z, b.z)}; }
LUZ_INLINE Vec3 vmax(Vec3 a, Vec3 b) { return {max(a.x, b.x), max(a.y, b.y), max(a.z, b.z)}; }
// Mirror of v about n (both unit; v points away from the surface).
LUZ_INLINE Vec3 reflect(Vec3 v, Vec3 n) { return 2.f * dot(v, n) * n - v; }

// Orthonormal frame around a unit normal (Duff et al. 2017, "Building an
// orthonormal basis, revisited").
struct Frame {
  Vec3 s, t, n;

  LUZ_FORCE_INLINE static Frame from_normal(Vec3 n) {
    float sign = copysignf(1.f, n.z);
    float a = -1.f / (sign + n.z);
    float b = n.x * n.y * a;
    Frame f;
    f.s = {1.f + sign * n.x * n.x * a, sign * b, -sign * n.x};
    f.t = {b, sign + n.y * n.y * a, -n.y};
    f.n = n;
    return f;
  }
  // s along `tangent` made orthogonal to the unit n (Gram-Schmidt), t = n × s:
  // Mitsuba's shading frame from dp/du. Any frame if tangent lies along n.
  LUZ_INLINE static Frame from_normal_tangent(Vec3 n, Vec3 tangent) {
    const Vec3 s = tangent - n * dot(n, tangent);
    const float l2 = dot(s, s);
    if (!(l2 > 1e-12f * dot(tangent, tangent))) return from_normal(n);
    Frame f;
    f.s = s * (1.f / sqrtf(l2));
    f.t = cross(n, f.s);
    f.n = n;
    return f;
  }
  LUZ_FORCE_INLINE Vec3 to_local(Vec3 v) const { return {dot(v, s), dot(v, t), dot(v, n)}; }
  LUZ_FORCE_INLINE Vec3 to_world(Vec3 v) const { return s * v.x + t * v.y + n * v.z; }
};

struct Ray {
  Vec3 o, d;
  float tmax = kInfinity;
};

}  // namespace luz
