// Points on shapes as seen from a reference point, with their solid-angle
// densities: what area lights sample (light/area.h). Each sampler and its
// pdf are checked together by a chi-square test (tests/test_emitter_sampling.cpp).
#pragma once

#include "luz/geometry/shapes.h"
#include "luz/sampling/warp.h"

namespace luz {

// A sampled point seen from `ref`. pdf is per solid angle at ref; 0 when the
// point cannot send light to ref (it faces away), and then the other fields
// need not be set.
struct ShapeSample {
  Vec3 p, n;       // the point and the shape's outward (emitting) normal there
  Vec3 wi;         // unit direction from ref toward p
  float dist = 0;  // |p - ref|
  float pdf = 0.f;
};

// Uniform by area over a one-sided planar piece of area `area` and unit
// normal n, once the point p on it is chosen: the area density converted to
// solid angle, d² / (cos θ_l · area).
LUZ_FORCE_INLINE ShapeSample planar_sample(Vec3 p, Vec3 n, float area, Vec3 ref) {
  ShapeSample ss;
  ss.p = p;
  ss.n = n;
  Vec3 d = ss.p - ref;
  float d2 = length_squared(d);
  ss.dist = sqrtf(d2);
  ss.wi = d / ss.dist;
  // cos θ_l · dist, from d itself: the pdf d² / (cos θ_l · area) =
  // d² · dist / (cos_dist · area) then waits for one square root, not for
  // the normalised direction too.
  float cos_dist = -dot(n, d);
  if (cos_dist <= 0.f || area <= 0.f) return ss;  // the back of a one-sided shape
  ss.pdf = d2 * ss.dist / (cos_dist * area);
  return ss;
}

// The solid-angle density of planar_sample toward a point at distance dist
// along unit wi, where the shape's normal is n.
LUZ_INLINE float planar_pdf(Vec3 n, float area, Vec3 wi, float dist) {
  float cos_l = -dot(n, wi);
  if (cos_l <= 0.f || area <= 0.f) return 0.f;
  return dist * dist / (cos_l * area);
}

// A point uniform by area on triangle v0 v1 v2.
LUZ_INLINE Vec3 triangle_point(Vec3 v0, Vec3 v1, Vec3 v2, Vec2 u) {
  Vec2 b = square_to_triangle_barycentrics(u);
  return v0 * (1.f - b.x - b.y) + v1 * b.x + v2 * b.y;
}

// Triangle v0 v1 v2, uniform by area.
LUZ_FORCE_INLINE ShapeSample triangle_sample(Vec3 v0, Vec3 v1, Vec3 v2, Vec3 n, float area, Vec3 ref, Vec2 u) {
  return planar_sample(triangle_point(v0, v1, v2, u), n, area, ref);
}

// Triangle lights are sampled uniformly in the solid angle they subtend where
// it lies in [min, max] steradians, by area elsewhere: below min the
// spherical map loses precision (and area sampling is nearly uniform in
// solid angle there anyway), above max (near a hemisphere) too.
inline constexpr float kSphericalTriangleMin = 3e-4f, kSphericalTriangleMax = 6.22f;

// A triangle as seen from ref: the unit directions to its vertices and the
// solid angle it subtends (Van Oosterom & Strackee 1983),
// tan(Ω/2) = |a·(b×c)| / (1 + a·b + a·c + b·c), with |a·(b×c)| =
// 2 · area · height / (l0 l1 l2) (height: ref's above the triangle's
// plane, given by the caller), so that a small or distant triangle keeps
// its precision.
struct SphericalTriangle {
  Vec3 a, b, c;
  float omega;
  float height;
};
LUZ_INLINE SphericalTriangle spherical_triangle(Vec3 v0, Vec3 v1, Vec3 v2, float area, float height, Vec3 ref) {
  const Vec3 d0 = v0 - ref, d1 = v1 - ref, d2 = v2 - ref;
  const float l0 = length(d0), l1 = length(d1), l2 = length(d2);
  SphericalTriangle t;
  t.height = height;
  t.a = d0 * (1.f / l0);
  t.b = d1 * (1.f / l1);
  t.c = d2 * (1.f / l2);
  t.omega = 2.f * atan2f(2.f * area * height / (l0 * l1 * l2), 1.f + dot(t.a, t.b) + dot(t.a, t.c) + dot(t.b, t.c));
  return t;
}

// Uniform in the solid angle of triangle v0 v1 v2 seen from ref, t from
// spherical_triangle (Arvo 1995): u.x picks the sub-triangle (a, b, c')
// of area A' = u.x·Ω, c' on the arc from a to c, u.y a direction on the
// arc from b to c' (uniform in the area it sweeps: 1 - cos linear in u.y).
// The arc b' from a to c' from the excess of two sides and their angle α,
// tan(A'/2) = tan(b'/2) tan(c/2) sin α / (1 + tan(b'/2) tan(c/2) cos α),
// solved as tan(b'/2) = sin(A'/2) / (tan(c/2) sin(α - A'/2)), and every
// difference of near directions taken from their chord: no cancellation
// for small triangles (Arvo's cos b' loses them). The point is where the
// direction meets the triangle; b gets its barycentrics (of v1, v2).
// n: the emitting normal facing ref. pdf 1/Ω.
LUZ_INLINE ShapeSample spherical_triangle_sample(const SphericalTriangle& t, Vec3 v0, Vec3 v1, Vec3 v2, Vec3 n, Vec3 ref,
                                                 Vec2 u, Vec2* barycentrics) {
  ShapeSample ss;
  const Vec3 a = t.a, bv = t.b, c = t.c;
  const float omega = t.omega;
  // α, the angle at a between the arcs to b and to c, by its cosine and sine.
  const Vec3 n_ab = cross(a, bv), n_ac = cross(a, c);
  const float inv_norms = 1.f / sqrtf(length_squared(n_ab) * length_squared(n_ac));
  const float cos_alpha = dot(n_ab, n_ac) * inv_norms, sin_alpha = length(cross(n_ab, n_ac)) * inv_norms;
  const float tan_half_c = length(bv - a) / length(bv + a);
  const float half_area = 0.5f * u.x * omega, sin_h = sinf(half_area), cos_h = cosf(half_area);
  const float x = sin_h / (tan_half_c * (sin_alpha * cos_h - cos_alpha * sin_h));  // tan(b'/2)
  if (!(x >= 0.f) || !(x < kInfinity)) return ss;
  // c' = a cos b' + (the unit tangent at a toward c) sin b'; c - a (a·c) = (c - a) + a (1 - a·c).
  const Vec3 ac = c - a;
  const Vec3 to_c = normalize(ac + a * (0.5f * length_squared(ac)));
  const float x2 = x * x, inv = 1.f / (1.f + x2);
  const Vec3 cp = a * ((1.f - x2) * inv) + to_c * (2.f * x * inv);
  // On the arc from b to c': 1 - cos θ = u.y (1 - b·c'), each from chords.
  const Vec3 bc = cp - bv;
  const float one_minus_cos = 0.5f * length_squared(bc) * u.y;
  const Vec3 to_cp = normalize(bc + bv * (0.5f * length_squared(bc)));
  const Vec3 w = bv * (1.f - one_minus_cos) + to_cp * safe_sqrt(one_minus_cos * (2.f - one_minus_cos));
  // Where w meets the triangle's plane (ref at t.height above it); the
  // barycentrics of that point for a textured light.
  ss.dist = t.height / -dot(n, w);
  if (!(ss.dist > 0.f) || !(ss.dist < kInfinity)) return ss;
  ss.wi = w;
  ss.p = ref + w * ss.dist;
  ss.n = n;
  if (barycentrics) {
    const Vec3 e1 = v1 - v0, e2 = v2 - v0, q = ss.p - v0, m = cross(e1, e2);
    const float inv = 1.f / length_squared(m);
    barycentrics->x = fminf(fmaxf(dot(cross(q, e2), m) * inv, 0.f), 1.f);
    barycentrics->y = fminf(fmaxf(dot(cross(e1, q), m) * inv, 0.f), 1.f - barycentrics->x);
  }
  ss.pdf = 1.f / omega;
  return ss;
}

// The point of [0, 1)² spherical_triangle_sample maps to the unit
// direction w (toward the triangle): c' where the great circle through b
// and w meets the arc from a to c, u.x the area of (a, b, c') over Ω, u.y
// (1 - b·w) / (1 - b·c') from chords.
LUZ_INLINE Vec2 spherical_triangle_invert(const SphericalTriangle& t, Vec3 w) {
  Vec3 cp = normalize(cross(cross(t.b, w), cross(t.c, t.a)));
  if (dot(cp, t.a + t.c) < 0.f) cp = -cp;
  const Vec3 bc = cp - t.b;
  const float det = fabsf(dot(t.a - t.b, cross(t.b, bc)));  // |a·(b×c')|
  const float area = 2.f * atan2f(det, 1.f + dot(t.a, t.b) + dot(t.a, cp) + dot(t.b, cp));
  const float chord2 = length_squared(bc);
  return {fminf(area / t.omega, 0x1.fffffep-1f),
          chord2 > 0.f ? fminf(length_squared(w - t.b) / chord2, 0x1.fffffep-1f) : 0.f};
}

// The cosines at a shading point of normal ns toward the triangle's
// vertices at the corners of spherical_triangle_sample's square (u.y = 0
// is b; u.y = 1 runs from a to c), at least 0.01 (pbrt-v4): warping the
// square by them makes directions follow the cosine, roughly.
LUZ_INLINE Bilinear spherical_triangle_cosines(const SphericalTriangle& t, Vec3 ns) {
  const float cb = fmaxf(0.01f, fabsf(dot(ns, t.b)));
  return {cb, cb, fmaxf(0.01f, fabsf(dot(ns, t.a))), fmaxf(0.01f, fabsf(dot(ns, t.c)))};
}

// Parallelogram: corner c and edges e1, e2 (points c + u e1 + v e2), uniform
// by area from one 2D point (no square-root warp, no choice between halves).
LUZ_FORCE_INLINE ShapeSample parallelogram_sample(Vec3 c, Vec3 e1, Vec3 e2, Vec3 n, float area, Vec3 ref, Vec2 u) {
  return planar_sample(c + e1 * u.x + e2 * u.y, n, area, ref);
}

// A point sampled on a shape by itself, with no reference point (what
// emission sampling starts from): pdf per unit area, 0 for none.
struct AreaSample {
  Vec3 p, n;  // the point and the shape's emitting normal there
  float pdf = 0.f;
};

LUZ_INLINE float inverse_area(float area) { return area > 0.f ? 1.f / area : 0.f; }

LUZ_INLINE AreaSample triangle_area_sample(Vec3 v0, Vec3 v1, Vec3 v2, Vec3 n, float area, Vec2 u) {
  return {triangle_point(v0, v1, v2, u), n, inverse_area(area)};
}

LUZ_INLINE AreaSample parallelogram_area_sample(Vec3 c, Vec3 e1, Vec3 e2, Vec3 n, float area, Vec2 u) {
  return {c + e1 * u.x + e2 * u.y, n, inverse_area(area)};
}

// Uniform over a sphere's surface; `flip`: the emitting normal points inward.
LUZ_INLINE float sphere_area_pdf(float radius) { return inverse_area(4.f * kPi * radius * radius); }
LUZ_INLINE AreaSample sphere_area_sample(Vec3 center, float radius, bool flip, Vec2 u) {
  const Vec3 d = square_to_uniform_sphere(u);
  return {center + d * radius, flip ? -d : d, sphere_area_pdf(radius)};
}

// Uniform over the disk of the given radius about `center`, perpendicular to
// unit n (concentric map).
LUZ_INLINE float disk_area_pdf(float radius) { return inverse_area(kPi * radius * radius); }
LUZ_INLINE AreaSample disk_area_sample(Vec3 center, Vec3 n, float radius, Vec2 u) {
  const Vec2 q = square_to_uniform_disk(u);
  const Frame f = Frame::from_normal(n);
  return {center + (f.s * q.x + f.t * q.y) * radius, n, disk_area_pdf(radius)};
}

// A sphere seen from outside: uniform in the cone it subtends (pbrt-v4's
// Sphere::Sample), with the density of that cone; from inside or on it,
// uniform by area. `flip`: the emitting side faces inward.
LUZ_FORCE_INLINE ShapeSample sphere_sample(Vec3 center, float radius, bool flip, Vec3 ref, Vec2 u) {
  ShapeSample ss;
  Vec3 to_c = center - ref;
  float dc2 = length_squared(to_c);
  float r2 = radius * radius;
  if (dc2 <= r2 * 1.00001f) {
    // Inside (or on) the sphere: uniform area sampling.
    const AreaSample as = sphere_area_sample(center, radius, flip, u);
    ss.p = as.p;
    ss.n = as.n;
    Vec3 w = ss.p - ref;
    float l2 = length_squared(w);
    ss.dist = sqrtf(l2);
    if (ss.dist <= 0.f) return ss;
    ss.wi = w / ss.dist;
    float cos_l = -dot(ss.n, ss.wi);
    if (cos_l <= 0.f) return ss;
    ss.pdf = l2 / (cos_l * 4.f * kPi * r2);
    return ss;
  }
  float dc = sqrtf(dc2);
  float sin2_max = r2 / dc2;
  float omc = cone_one_minus_cos(sin2_max);
  Frame fr = Frame::from_normal(to_c / dc);
  Vec3 local = square_to_uniform_cone(u, omc);
  ss.wi = normalize(fr.to_world(local));
  float t = intersect_sphere(center, radius, ref, ss.wi, kInfinity);
  if (t <= 0.f) {
    // Grazing direction lost to rounding: take the tangent point.
    t = dot(to_c, ss.wi);
  }
  Vec3 nrm = normalize(ref + ss.wi * t - center);
  ss.p = center + nrm * radius;
  ss.dist = length(ss.p - ref);
  ss.n = flip ? -nrm : nrm;
  if (dot(ss.n, ss.wi) >= 0.f) return ss;  // a flipped sphere seen from outside
  ss.pdf = uniform_cone_pdf(omc);
  return ss;
}

// The density of sphere_sample toward the point at distance dist along unit
// wi, where the sphere's emitting normal is n.
LUZ_INLINE float sphere_pdf(Vec3 center, float radius, Vec3 ref, Vec3 n, Vec3 wi, float dist) {
  float dc2 = length_squared(center - ref);
  float r2 = radius * radius;
  if (dc2 <= r2 * 1.00001f) {
    float cos_l = -dot(n, wi);
    if (cos_l <= 0.f) return 0.f;
    return dist * dist / (cos_l * 4.f * kPi * r2);
  }
  if (dot(n, wi) >= 0.f) return 0.f;
  return uniform_cone_pdf(cone_one_minus_cos(r2 / dc2));
}

}  // namespace luz
