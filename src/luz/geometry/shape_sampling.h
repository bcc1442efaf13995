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

// --- Rectangles by solid angle (Ureña, Fajardo & King 2013, "An
// Area-Preserving Parametrization for Spherical Rectangles", in pbrt-v4's
// formulation): directions uniform over the rectangle's solid angle S,
// pdf 1/S. Area sampling's pdf d²/(cos θ_l · area) varies over a near or
// wide light by far more than the light's solid angle does.

// Where the map is used; outside, area sampling (which differs little from
// it for a small, far light). In float the map's cumulative distribution
// is off by up to 1.5e-4 at S = 1e-2 seen at a grazing angle, 1e-6 seen
// head-on (1e-2 and 1e-6 at S = 1e-3), and up to S = 6 (a point 3.5% of
// the side above a square's centre) by at most 4e-5; beyond that by up to
// 1 (a point nearly on the plane: 1 - cu² and 1 - hv² cancel). The
// decision is a function of the solid angle alone, which sample and pdf
// compute by the same code from the same inputs, so they always agree.
inline constexpr float kMinRectSolidAngle = 1e-2f, kMaxRectSolidAngle = 6.f;

// True when edges e1, e2 are perpendicular to float precision (a rectangle,
// not a sheared parallelogram).
LUZ_INLINE bool is_rectangle(Vec3 e1, Vec3 e2) {
  const float d = dot(e1, e2);
  return d * d <= 1e-10f * length_squared(e1) * length_squared(e2);
}

// A rectangle c + s e1 + t e2 (e1 ⊥ e2) as seen from ref, in the frame of
// its edges (x along e1, y along e2, z its unit normal n): [x0, x1] × [y0,
// y1] at height z0 below ref, the distances r.. from ref to its corners,
// and its solid angle (0 from its back or its plane).
struct SphericalRect {
  Vec3 ex, ey;
  float x0, y0, x1, y1, z0;
  float r00, r10, r01, r11;
  float solid_angle = 0.f;
};

// The solid angle as two triangles by Van Oosterom & Strackee's tan(Ω/2) =
// |R1·(R2×R3)| / (r1 r2 r3 + (R1·R2) r3 + (R1·R3) r2 + (R2·R3) r1): the
// triple product of either half is the height times the area, and the
// denominators are sums of positive terms for small angles, so it keeps
// float's relative precision at every size (the sum of the spherical
// rectangle's angles minus 2π does not: 1e-7 absolute). The two halves'
// angles α + β in one atan2, from (cos, sin) of the sum: both tangents
// over r1 r2 r3 first, so that nothing overflows.
LUZ_FORCE_INLINE SphericalRect spherical_rect(Vec3 c, Vec3 e1, Vec3 e2, Vec3 n, Vec3 ref) {
  SphericalRect q;
  const float l1 = length(e1), l2 = length(e2);
  q.ex = e1 / l1;
  q.ey = e2 / l2;
  const Vec3 d = c - ref;
  q.x0 = dot(d, q.ex), q.y0 = dot(d, q.ey), q.z0 = dot(d, n);
  q.x1 = q.x0 + l1, q.y1 = q.y0 + l2;
  const float z2 = q.z0 * q.z0, num = -q.z0 * l1 * l2;
  const float xx = q.x0 * q.x1, yy = q.y0 * q.y1;
  q.r00 = sqrtf(q.x0 * q.x0 + q.y0 * q.y0 + z2), q.r10 = sqrtf(q.x1 * q.x1 + q.y0 * q.y0 + z2);
  q.r01 = sqrtf(q.x0 * q.x0 + q.y1 * q.y1 + z2), q.r11 = sqrtf(q.x1 * q.x1 + q.y1 * q.y1 + z2);
  if (!(num > 0.f)) return q;
  const float d00_11 = xx + yy + z2;  // R00 · R11
  const float den1 = q.r00 * q.r10 * q.r11 + (xx + q.y0 * q.y0 + z2) * q.r11 + d00_11 * q.r10 +
                     (q.x1 * q.x1 + yy + z2) * q.r00;
  const float den2 = q.r00 * q.r11 * q.r01 + d00_11 * q.r01 + (q.x0 * q.x0 + yy + z2) * q.r11 +
                     (xx + q.y1 * q.y1 + z2) * q.r00;
  const float s1 = 1.f / (q.r00 * q.r10 * q.r11), s2 = 1.f / (q.r00 * q.r11 * q.r01);
  const float n1 = num * s1, c1 = den1 * s1, n2 = num * s2, c2 = den2 * s2;
  q.solid_angle = 2.f * atan2f(n1 * c2 + c1 * n2, c1 * c2 - n1 * n2);
  return q;
}

LUZ_INLINE bool rect_by_solid_angle(float solid_angle) {
  return solid_angle >= kMinRectSolidAngle && solid_angle <= kMaxRectSolidAngle;
}

// Ureña et al.'s map of u to a point of the rectangle: u.x picks the line
// x = xu that cuts off the fraction u.x of the solid angle, u.y the point on
// it, uniform in solid angle too. The point is returned on the plane (c
// plus in-plane offsets). The planes through ref and the edges have normals
// n0 = (0, z0, -y0)/L0 (edge y0), n1 = (-z0, 0, x1)/L1, n2 = (0, -z0,
// y1)/L2, n3 = (z0, 0, -x0)/L3; the rectangle's angle g_i between n_i and
// n_{i+1} has cos · L_i L_{i+1} = -n_i · n_{i+1} (unnormalised) and sin ·
// L_i L_{i+1} = |z0| r (r: the corner's distance). The cut-off part's
// angle sum minus 2π is au = u.x S - (g2 + g3): its cos and sin by
// rotating those of u.x S by g2 + g3, whose cos and sin are those of a
// product of two complex numbers (one sincos, no atan2 or acos). With S
// the accurate solid angle, the interior density is 1/S; the error of g2 +
// g3 (about 1e-7) only moves a sliver of that size onto an edge.
LUZ_FORCE_INLINE Vec3 rect_map(const SphericalRect& q, Vec3 c, Vec2 u) {
  const float x0 = q.x0, y0 = q.y0, y1 = q.y1, z0 = q.z0, z2 = z0 * z0, az = fabsf(z0);
  const float L0 = sqrtf(z2 + y0 * y0), L2 = sqrtf(z2 + y1 * y1), L3s = z2 + x0 * x0;
  const float b0 = -y0 / L0, b1 = y1 / L2;  // n0.z, n2.z
  // (x0 y1 + i |z0| r01)(-x0 y0 + i |z0| r00) = L2 L3 e^{i g2} · L3 L0 e^{i g3}.
  const float inv = 1.f / (L0 * L2 * L3s);
  const float cg = (-x0 * x0 * y0 * y1 - z2 * q.r01 * q.r00) * inv;
  const float sg = az * x0 * (y1 * q.r00 - y0 * q.r01) * inv;
  float su, cu_s;
  sincosf(u.x * q.solid_angle, &su, &cu_s);
  const float cos_au = cu_s * cg + su * sg, sin_au = su * cg - cu_s * sg;
  const float fu = (cos_au * b0 - b1) / sin_au;
  const float cu = clamp(copysignf(1.f / sqrtf(fu * fu + b0 * b0), fu), -kOneMinusEpsilon, kOneMinusEpsilon);
  const float xu = clamp(-(cu * z0) / safe_sqrt(1.f - cu * cu), x0, q.x1);
  // Along the line x = xu, uniform in solid angle: linear in the sine of
  // the elevation h = y / |(xu, y, z0)|.
  const float dd2 = xu * xu + z2;
  const float h0 = y0 / sqrtf(dd2 + y0 * y0), h1 = y1 / sqrtf(dd2 + y1 * y1);
  const float hv = h0 + u.y * (h1 - h0), hv2 = hv * hv;
  const float yv = hv2 < kOneMinusEpsilon ? clamp(hv * sqrtf(dd2 / (1.f - hv2)), y0, y1) : y1;
  return c + q.ex * (xu - x0) + q.ey * (yv - y0);
}

// A parallelogram light seen from ref: by solid angle where it is a
// rectangle and its solid angle lies in [kMinRectSolidAngle,
// kMaxRectSolidAngle]; elsewhere uniform by area.
LUZ_FORCE_INLINE ShapeSample rectangle_sample(Vec3 c, Vec3 e1, Vec3 e2, Vec3 n, float area, Vec3 ref, Vec2 u) {
  if (!is_rectangle(e1, e2)) return parallelogram_sample(c, e1, e2, n, area, ref, u);
  const SphericalRect q = spherical_rect(c, e1, e2, n, ref);
  if (!rect_by_solid_angle(q.solid_angle)) return parallelogram_sample(c, e1, e2, n, area, ref, u);
  ShapeSample ss;
  ss.p = rect_map(q, c, u);
  ss.n = n;
  const Vec3 w = ss.p - ref;
  ss.dist = length(w);
  ss.wi = w / ss.dist;
  ss.pdf = 1.f / q.solid_angle;
  return ss;
}

// The density of rectangle_sample toward the point at distance dist along
// unit wi, where the light's normal is n_hit (n: its normal as stored).
LUZ_INLINE float rectangle_pdf(Vec3 c, Vec3 e1, Vec3 e2, Vec3 n, float area, Vec3 ref, Vec3 n_hit, Vec3 wi,
                               float dist) {
  if (is_rectangle(e1, e2)) {
    const float sa = spherical_rect(c, e1, e2, n, ref).solid_angle;
    if (rect_by_solid_angle(sa)) return -dot(n_hit, wi) > 0.f ? 1.f / sa : 0.f;
  }
  return planar_pdf(n_hit, area, wi, dist);
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
