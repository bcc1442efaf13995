// Geometry shared by both devices: triangles, analytic spheres, the surface
// interaction, and robust ray offsets.
#pragma once

#include "luz/geometry/instance.h"
#include "luz/math/vec.h"

namespace luz {

struct Sphere {
  Vec3 center;
  float radius = 1.f;
  uint32_t material = 0;
  int32_t emitter = -1;
  bool flip_normals = false;
  uint8_t zero_[3] = {};  // not padding: checkpoints hash a sphere's bytes (render/checkpoint.cpp)
  // The object frame in which its texture coordinates are spherical angles
  // (sphere_uv): to_world's rotation, orthonormal; left-handed when to_world
  // mirrors.
  Frame frame{{1.f, 0.f, 0.f}, {0.f, 1.f, 0.f}, {0.f, 0.f, 1.f}};
};

// Texture coordinates of a sphere's point at the object-space direction l
// from its centre (any length): Mitsuba 3's sphere, uv = (φ / 2π, θ / π)
// with φ = atan2(y, x) in [0, 2π) and θ from +z. pbrt-v4's full sphere has
// v = 1 - θ / π, which is this v once its loader flips v as for every pbrt
// shape (texture.h's convention: v = 0 at the image's top).
LUZ_INLINE Vec2 sphere_uv(Vec3 l) {
  float phi = atan2f(l.y, l.x);
  if (phi < 0.f) phi += 2.f * kPi;
  const float len = length(l);
  const float cos_theta = len > 0.f ? fminf(fmaxf(l.z / len, -1.f), 1.f) : 1.f;
  return {phi * kInv2Pi, acosf(cos_theta) * kInvPi};
}

// The uv of world point p on sphere s.
LUZ_INLINE Vec2 sphere_uv(const Sphere& s, Vec3 p) { return sphere_uv(s.frame.to_local(p - s.center)); }

// dp/du and dp/dv (world space) at the object-space unit direction l on a
// sphere of the given frame and radius, from sphere_uv's parametrisation
// (Mitsuba 3's Sphere::compute_surface_interaction): dp/du = 2π r (-y, x, 0),
// dp/dv = π r (z cos φ, z sin φ, -sin θ). At a pole dp/du vanishes and
// dp/dv takes its limit along φ = 0, the φ sphere_uv gives there.
LUZ_INLINE void sphere_dp_duv(const Frame& frame, float radius, Vec3 l, Vec3& dpdu, Vec3& dpdv) {
  const float rho = sqrtf(l.x * l.x + l.y * l.y);
  const float cos_phi = rho > 0.f ? l.x / rho : 1.f, sin_phi = rho > 0.f ? l.y / rho : 0.f;
  dpdu = frame.to_world({-l.y, l.x, 0.f}) * (2.f * kPi * radius);
  dpdv = frame.to_world({l.z * cos_phi, l.z * sin_phi, -rho}) * (kPi * radius);
}

// Which primitive a ray hit: triangles first, then spheres.
enum class PrimKind : uint32_t { Triangle, Sphere };

struct Hit {
  float t = kInfinity;
  uint32_t prim = 0;
  PrimKind kind = PrimKind::Triangle;
  float u = 0.f, v = 0.f;  // barycentrics of vertices 1 and 2 (triangles)
  uint32_t inst = kNoInstance;  // the instance hit, or kNoInstance: world geometry
};

struct Interaction {
  Vec3 p;       // position
  Vec3 ng;      // geometric normal (the side that emits, for emitters)
  Vec3 ns;      // shading normal, on the same side as ng
  uint32_t material = 0;
  int32_t emitter = -1;
};

// A triangle's partial derivatives dp/du and dp/dv from its positions and
// texture coordinates (pbrt-v4's Triangle::InteractionFromIntersection):
// solving [uv0 - uv2, uv1 - uv2] [dp/du; dp/dv] = [p0 - p2; p1 - p2]. For
// degenerate uvs (no parametrisation), an arbitrary frame around ng.
LUZ_INLINE void triangle_dp_duv(Vec3 p0, Vec3 p1, Vec3 p2, Vec2 t0, Vec2 t1, Vec2 t2, Vec3 ng, Vec3& dpdu,
                                Vec3& dpdv) {
  const float du02 = t0.x - t2.x, dv02 = t0.y - t2.y, du12 = t1.x - t2.x, dv12 = t1.y - t2.y;
  const Vec3 dp02 = p0 - p2, dp12 = p1 - p2;
  const float det = du02 * dv12 - dv02 * du12;
  bool degenerate = !(fabsf(det) >= 1e-9f);
  if (!degenerate) {
    const float inv = 1.f / det;
    dpdu = (dp02 * dv12 - dp12 * dv02) * inv;
    dpdv = (dp12 * du02 - dp02 * du12) * inv;
    const Vec3 c = cross(dpdu, dpdv);
    degenerate = !(dot(c, c) > 0.f) || !(dot(c, c) < kInfinity);
  }
  if (degenerate) {
    const Frame f = Frame::from_normal(ng);
    dpdu = f.s;
    dpdv = f.t;
  }
}

LUZ_INLINE uint32_t float_bits(float f) {
  uint32_t u;
  __builtin_memcpy(&u, &f, sizeof u);
  return u;
}
LUZ_INLINE float bits_float(uint32_t u) {
  float f;
  __builtin_memcpy(&f, &u, sizeof f);
  return f;
}

// Wächter & Binder, "A Fast and Robust Method for Avoiding Self-Intersection"
// (Ray Tracing Gems, ch. 6): move p along n by a few ulps of its own
// magnitude (a fixed small step near the origin). No scene-dependent epsilon.
LUZ_INLINE Vec3 offset_ray_origin(Vec3 p, Vec3 n) {
  constexpr float kOrigin = 1.f / 32.f, kFloatScale = 1.f / 65536.f, kIntScale = 256.f;
  // Branch-free: the integer step's sign follows p's sign bit ((of ^ s) - s
  // negates when s = -1), and the near-origin case is a bit-mask select. On
  // the CPU the three axes go through one SSE register (the same operations,
  // the same result).
#if defined(__SSE2__) && !defined(__CUDA_ARCH__)
  const __m128 vp = _mm_setr_ps(p.x, p.y, p.z, 0.f), vn = _mm_setr_ps(n.x, n.y, n.z, 0.f);
  const __m128i of = _mm_cvttps_epi32(_mm_mul_ps(vn, _mm_set1_ps(kIntScale)));
  const __m128i bits = _mm_castps_si128(vp), s = _mm_srai_epi32(bits, 31);
  const __m128 stepped = _mm_castsi128_ps(_mm_add_epi32(bits, _mm_sub_epi32(_mm_xor_si128(of, s), s)));
  const __m128 near = _mm_cmplt_ps(_mm_andnot_ps(_mm_set1_ps(-0.f), vp), _mm_set1_ps(kOrigin));
  const __m128 fine = _mm_add_ps(vp, _mm_mul_ps(vn, _mm_set1_ps(kFloatScale)));
  const __m128 r = _mm_or_ps(_mm_and_ps(near, fine), _mm_andnot_ps(near, stepped));
  alignas(16) float out[4];
  _mm_store_ps(out, r);
  return {out[0], out[1], out[2]};
#else
  Vec3 r;
  for (int i = 0; i < 3; ++i) {
    const int32_t of = int32_t(kIntScale * n[i]);
    const uint32_t bits = float_bits(p[i]);
    const int32_t s = int32_t(bits) >> 31;
    const uint32_t stepped = bits + uint32_t((of ^ s) - s);
    const uint32_t near = 0u - uint32_t(fabsf(p[i]) < kOrigin);
    r[i] = bits_float((float_bits(p[i] + kFloatScale * n[i]) & near) | (stepped & ~near));
  }
  return r;
#endif
}

// Ray-sphere intersection, numerically careful form (Haines et al., "Precision
// Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7), for any
// direction length (shadow rays run from 0 to 1 along the unnormalised
// segment). Returns the nearest t in (0, tmax), or a negative value.
LUZ_INLINE float intersect_sphere(Vec3 center, float radius, Vec3 o, Vec3 d, float tmax) {
  Vec3 f = o - center;
  const float a = dot(d, d);
  float b = -dot(f, d);  // a · (t of the closest approach)
  Vec3 l = f + (b / a) * d;
  float disc = radius * radius - dot(l, l);
  if (disc < 0.f) return -1.f;
  float c = dot(f, f) - radius * radius;
  float q = b + copysignf(sqrtf(a * disc), b);
  float t0 = c / q, t1 = q / a;
  if (t0 > t1) {
    float tmp = t0;
    t0 = t1;
    t1 = tmp;
  }
  if (t0 > 0.f && t0 < tmax) return t0;
  if (t1 > 0.f && t1 < tmax) return t1;
  return -1.f;
}

}  // namespace luz
