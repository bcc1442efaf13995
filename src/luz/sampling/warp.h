// Warps from the unit square to the domains Luz samples, each with its pdf.
// Every one of them is checked by a chi-square test (tests/test_warp.cpp).
#pragma once

#include "luz/math/vec.h"

namespace luz {

// sin and cos of x for |x| ≤ π/4, by the minimax polynomials of Cephes'
// sinf/cosf (S. Moshier) for that interval: within 2 ulp, and inline (no
// libm call, no range reduction). tests/test_warp.cpp compares with libm.
LUZ_FORCE_INLINE Vec2 cos_sin_quarter(float x) {
  float x2 = x * x;
  float s = x + x * x2 * (-1.6666654611e-1f + x2 * (8.3321608736e-3f + x2 * -1.9515295891e-4f));
  float c = 1.f - 0.5f * x2 + x2 * x2 * (4.166664568298827e-2f + x2 * (-1.388731625493765e-3f + x2 * 2.443315711809948e-5f));
  return {c, s};
}

// Shirley & Chiu 1997 concentric map: uniform on the unit disk, low distortion.
// (The seed's x = r1 cos 2πr2, y = r1 sin 2πr2 is not uniform: the radius must be
// sqrt(r1) or this map. tests/test_warp.cpp shows the difference.)
LUZ_FORCE_INLINE Vec2 square_to_uniform_disk(Vec2 u) {
  float a = 2.f * u.x - 1.f, b = 2.f * u.y - 1.f;
  if (a == 0.f && b == 0.f) return {0.f, 0.f};
  // φ = (π/4)(b/a), or π/2 - (π/4)(a/b) (then cos and sin swap places).
  // Written as selects, not branches (the case is a coin toss per sample).
  const float a2 = a * a, b2 = b * b;  // the case: a2 > b2 ("wide")
  float r, t, c, s;
  swap_unless_lt(b2, a2, a, b, r, t);
  const Vec2 cs = cos_sin_quarter((kPi / 4.f) * (t / r));
  swap_unless_lt(b2, a2, cs.x, cs.y, c, s);
  return {r * c, r * s};
}
LUZ_INLINE float uniform_disk_pdf(Vec2 p) { return (p.x * p.x + p.y * p.y <= 1.f) ? kInvPi : 0.f; }

// Cosine-weighted hemisphere by lifting the uniform disk (Malley's method).
LUZ_FORCE_INLINE Vec3 square_to_cosine_hemisphere(Vec2 u) {
  Vec2 d = square_to_uniform_disk(u);
  float z = safe_sqrt(1.f - d.x * d.x - d.y * d.y);
  return {d.x, d.y, z};
}
LUZ_INLINE float cosine_hemisphere_pdf(Vec3 w) { return w.z > 0.f ? w.z * kInvPi : 0.f; }

LUZ_INLINE Vec3 square_to_uniform_sphere(Vec2 u) {
  float z = 1.f - 2.f * u.x;
  float r = safe_sqrt(1.f - z * z);
  float phi = 2.f * kPi * u.y;
  return {r * cosf(phi), r * sinf(phi), z};
}
LUZ_INLINE float uniform_sphere_pdf() { return kInv4Pi; }

// Uniform over the cone of directions with cos θ ≥ cos_max, around +z. The
// cone is given by 1 - cos_max (exact even for tiny cones; see
// cone_one_minus_cos) so narrow cones keep their precision.
LUZ_INLINE Vec3 square_to_uniform_cone(Vec2 u, float one_minus_cos_max) {
  float one_minus_z = u.x * one_minus_cos_max;
  float z = 1.f - one_minus_z;
  float r = safe_sqrt(one_minus_z * (2.f - one_minus_z));
  float phi = 2.f * kPi * u.y;
  return {r * cosf(phi), r * sinf(phi), z};
}
LUZ_INLINE float uniform_cone_pdf(float one_minus_cos_max) { return 1.f / (2.f * kPi * one_minus_cos_max); }
// 1 - cos θmax for the cone subtended by a sphere with sin²θmax = s2, as
// s2 / (1 + cos θmax): no cancellation, so it keeps float precision for every
// s2 (1 - sqrt(1 - s2) lost up to 7e-5 relative just above s2 = 1e-3, where
// a series used to take over; tests/test_warp.cpp checks it).
LUZ_INLINE float cone_one_minus_cos(float s2) { return s2 / (1.f + safe_sqrt(1.f - s2)); }

// Uniform on a triangle: barycentrics (b1, b2) of vertices 1 and 2.
LUZ_INLINE Vec2 square_to_triangle_barycentrics(Vec2 u) {
  float s = sqrtf(u.x);
  return {1.f - s, u.y * s};
}

// Cosine-power lobe around +z (Lafortune & Willems 1994): pdf (n+1)/(2π) cos^n θ.
LUZ_INLINE Vec3 square_to_cosine_power(Vec2 u, float n) {
  float z = powf(u.x, 1.f / (n + 1.f));
  float r = safe_sqrt(1.f - z * z);
  float phi = 2.f * kPi * u.y;
  return {r * cosf(phi), r * sinf(phi), z};
}
LUZ_INLINE float cosine_power_pdf(float cos_theta, float n) {
  return cos_theta > 0.f ? (n + 1.f) * kInv2Pi * powf(cos_theta, n) : 0.f;
}

LUZ_INLINE float power_heuristic(float a, float b) {
  float a2 = a * a, b2 = b * b;
  if (!(a2 < kInfinity)) return 1.f;
  return a2 > 0.f ? a2 / (a2 + b2) : 0.f;
}
// power_heuristic(a, b) / a for a > 0 (a light sample's weight over its
// pdf): one division instead of two.
LUZ_INLINE float power_heuristic_over_a(float a, float b) {
  float a2 = a * a, b2 = b * b;
  if (!(a2 < kInfinity)) return 1.f / a;
  return a / (a2 + b2);
}

}  // namespace luz
