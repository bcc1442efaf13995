// What a light BVH knows of a light or a group of lights (Conty Estevez and
// Kulla 2018, "Importance Sampling of Many Lights with Adaptive Tree
// Splitting"; pbrt-v4's LightBounds): where they are (a box), how strongly
// they emit (phi), and toward where (a cone of normals of axis w and half
// angle θo, each normal's emission spread θe around it).
#pragma once

#include <cmath>

#include "luz/math/vec.h"

namespace luz {

struct LightBounds {
  Vec3 lo, hi;  // world-space box
  Vec3 w;       // unit axis of the normals' cone
  // A bound on the radiant intensity (W/sr) toward any direction the lights
  // emit into: I for point and spot lights, L·A for planar ones (their
  // intensity along the normal), L·πr² for spheres. Sums over a group.
  float phi = 0.f;
  float cos_theta_o = 1.f;  // the normals' cone
  float cos_theta_e = 0.f;  // emission around each normal (0: a hemisphere)
  bool two_sided = false;

  // An estimate of the irradiance the lights give at p, on a surface of
  // normal n (zero: no surface, a direction-free point), that is 0 only where
  // no light inside emits toward p or none is above the surface: pbrt-v4's
  // LightBounds::Importance, term by term.
  LUZ_INLINE float importance(Vec3 p, Vec3 n) const {
    const Vec3 pc = (lo + hi) * 0.5f, d = p - pc;
    const float dc2 = length_squared(d);
    // The distance, clamped as pbrt does so that points inside the box are
    // not infinitely important; 0 only at a point light itself (no light
    // comes from there).
    const float d2 = max(dc2, 0.5f * length(hi - lo));
    if (!(d2 > 0.f)) return 0.f;
    const Vec3 wi = dc2 > 0.f ? d * (1.f / sqrtf(dc2)) : Vec3{};  // from the lights toward p
    float cos_w = dot(w, wi);
    if (two_sided) cos_w = fabsf(cos_w);
    const float sin_w = safe_sqrt(1.f - cos_w * cos_w);
    // The cone of directions the box subtends from p (its bounding sphere;
    // every direction from inside it).
    const float r2 = 0.25f * length_squared(hi - lo);
    const float cos_b = dc2 < r2 ? -1.f : safe_sqrt(1.f - r2 / dc2);
    const float sin_b = safe_sqrt(1.f - cos_b * cos_b);
    // θ' = max(0, θw - θo - θb), by cosines of clamped differences.
    const float sin_o = safe_sqrt(1.f - cos_theta_o * cos_theta_o);
    const float cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, cos_theta_o);
    const float sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, cos_theta_o);
    const float cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
    if (cos_p <= cos_theta_e) return 0.f;
    float imp = phi * cos_p / d2;
    if (n.x != 0.f || n.y != 0.f || n.z != 0.f) {
      // θi: the light's direction against the surface normal, less θb.
      const float cos_i = fabsf(dot(wi, n)), sin_i = safe_sqrt(1.f - cos_i * cos_i);
      imp *= cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
    }
    return max(imp, 0.f);
  }

  // cos(max(0, a - b)) and sin(max(0, a - b)) from the angles' sines and cosines.
  LUZ_INLINE static float cos_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 1.f : cos_a * cos_b + sin_a * sin_b;
  }
  LUZ_INLINE static float sin_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 0.f : sin_a * cos_b - cos_a * sin_b;
  }
};

// The smallest cone pbrt-v4's DirectionCone Union finds around two cones
// (axes unit, cos θ = -1: every direction).
inline void cone_union(Vec3 wa, float cos_a, Vec3 wb, float cos_b, Vec3& w, float& cos_o) {
  const double theta_a = std::acos(std::fmin(std::fmax(double(cos_a), -1.0), 1.0));
  const double theta_b = std::acos(std::fmin(std::fmax(double(cos_b), -1.0), 1.0));
  const double theta_d = std::acos(std::fmin(std::fmax(double(dot(wa, wb)), -1.0), 1.0));
  if (std::fmin(theta_d + theta_b, M_PI) <= theta_a) {
    w = wa;
    cos_o = cos_a;
    return;
  }
  if (std::fmin(theta_d + theta_a, M_PI) <= theta_b) {
    w = wb;
    cos_o = cos_b;
    return;
  }
  const double theta_o = 0.5 * (theta_a + theta_d + theta_b);
  const Vec3 k = cross(wa, wb);
  const float lk = length(k);
  if (theta_o >= M_PI || !(lk > 0.f)) {
    w = wa;
    cos_o = -1.f;
    return;
  }
  // wa rotated by θo - θa toward wb, about k (Rodrigues; k ⟂ wa).
  const double theta_r = theta_o - theta_a;
  const Vec3 axis = k / lk;
  w = normalize(wa * float(std::cos(theta_r)) + cross(axis, wa) * float(std::sin(theta_r)));
  cos_o = float(std::cos(theta_o));
}

// The bounds of two groups together (pbrt-v4's Union of LightBounds). A group
// with no power adds nothing.
inline LightBounds bounds_union(const LightBounds& a, const LightBounds& b) {
  if (!(a.phi > 0.f)) return b;
  if (!(b.phi > 0.f)) return a;
  LightBounds u;
  u.lo = vmin(a.lo, b.lo);
  u.hi = vmax(a.hi, b.hi);
  u.phi = a.phi + b.phi;
  cone_union(a.w, a.cos_theta_o, b.w, b.cos_theta_o, u.w, u.cos_theta_o);
  u.cos_theta_e = std::fmin(a.cos_theta_e, b.cos_theta_e);
  u.two_sided = a.two_sided || b.two_sided;
  return u;
}

}  // namespace luz
