// Geometry shared by both devices: triangles, analytic spheres, the surface
// interaction, and robust ray offsets.
#pragma once

#include "luz/math/vec.h"

namespace luz {

struct Sphere {
  Vec3 center;
  float radius = 1.f;
  uint32_t material = 0;
  int32_t emitter = -1;
  bool flip_normals = false;
};

// Which primitive a ray hit: triangles first, then spheres.
enum class PrimKind : uint32_t { Triangle, Sphere };

struct Hit {
  float t = kInfinity;
  uint32_t prim = 0;
  PrimKind kind = PrimKind::Triangle;
  float u = 0.f, v = 0.f;  // barycentrics of vertices 1 and 2 (triangles)
};

struct Interaction {
  Vec3 p;       // position
  Vec3 ng;      // geometric normal (the side that emits, for emitters)
  Vec3 ns;      // shading normal, on the same side as ng
  uint32_t material = 0;
  int32_t emitter = -1;
};

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
  Vec3 r;
  for (int i = 0; i < 3; ++i) {
    int32_t of = int32_t(kIntScale * n[i]);
    uint32_t bits = float_bits(p[i]);
    float pi = bits_float(uint32_t(int32_t(bits) + (p[i] < 0.f ? -of : of)));
    r[i] = fabsf(p[i]) < kOrigin ? p[i] + kFloatScale * n[i] : pi;
  }
  return r;
}

// Ray-sphere intersection, numerically careful form (Haines et al., "Precision
// Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7). d must be
// unit length. Returns the nearest t in (0, tmax), or a negative value.
LUZ_INLINE float intersect_sphere(Vec3 center, float radius, Vec3 o, Vec3 d, float tmax) {
  Vec3 f = o - center;
  float b = -dot(f, d);
  Vec3 l = f + b * d;
  float disc = radius * radius - dot(l, l);
  if (disc < 0.f) return -1.f;
  float c = dot(f, f) - radius * radius;
  float q = b + copysignf(sqrtf(disc), b);
  float t0 = c / q, t1 = q;
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
