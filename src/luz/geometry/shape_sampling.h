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
