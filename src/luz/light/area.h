// Diffuse area lights: constant radiance on the side of the geometric normal
// (one-sided, as Mitsuba's `area`), on a triangle, a parallelogram (a quad
// light: two triangles of one mesh merged by Scene::compile and sampled as
// one) or a sphere. Each samples its shape through geometry/shape_sampling.h.
#pragma once

#include <algorithm>

#include "luz/geometry/shape_sampling.h"
#include "luz/light/light_bounds.h"
#include "luz/light/light_sample.h"

namespace luz {

LUZ_INLINE LightSample area_light_sample(const ShapeSample& ss, Color radiance) {
  LightSample ls;
  ls.wi = ss.wi;
  ls.dist = ss.dist;
  ls.p = ss.p;
  ls.n = ss.n;
  ls.pdf = ss.pdf;
  if (ss.pdf > 0.f) ls.radiance = radiance;
  return ls;
}

// Radiance leaving a point of normal n toward w (away from it).
LUZ_INLINE Color one_sided(Color radiance, Vec3 n, Vec3 w) { return dot(n, w) <= 0.f ? Color{} : radiance; }

// What triangles and parallelograms share: a one-sided plane piece.
struct PlanarLight {
  static constexpr bool kDelta = false, kEnvironment = false;
  Color radiance;
  // Set by Scene::compile, so that sampling does not recompute them at every vertex.
  Vec3 normal;  // unit, the emitting side
  float area = 0.f;

  LUZ_INLINE float pdf_li(const LightSampleContext&, Vec3 wi, const LightHit& h, const float*) const {
    return planar_pdf(h.n, area, wi, h.dist);
  }
  LUZ_INLINE Color eval(Vec3 n, Vec3 w) const { return one_sided(radiance, n, w); }
  double phi(float) const { return M_PI * double(area) * std::max(0.0, double(average(radiance))); }
  // Emits into the hemisphere of `normal` from within [lo, hi].
  LightBounds planar_bounds(Vec3 lo, Vec3 hi) const {
    LightBounds b;
    b.lo = lo;
    b.hi = hi;
    b.w = normal;
    b.phi = float(double(area) * std::max(0.0, double(average(radiance))));
    return b;
  }
};

struct TriangleLight : PlanarLight {
  uint32_t prim = 0;  // the triangle
  Vec3 v0, v1, v2;    // its vertices, copied: no index look-ups when sampling

  LUZ_FORCE_INLINE LightSample sample_li(const LightSampleContext& ctx, Vec2 u, const float*) const {
    return area_light_sample(triangle_sample(v0, v1, v2, normal, area, ctx.p, u), radiance);
  }
  LightBounds bounds() const { return planar_bounds(vmin(v0, vmin(v1, v2)), vmax(v0, vmax(v1, v2))); }
};

struct ParallelogramLight : PlanarLight {
  uint32_t prim = 0, prim2 = 0;  // its two triangles
  Vec3 corner, e1, e2;           // points corner + u e1 + v e2

  LUZ_FORCE_INLINE LightSample sample_li(const LightSampleContext& ctx, Vec2 u, const float*) const {
    return area_light_sample(parallelogram_sample(corner, e1, e2, normal, area, ctx.p, u), radiance);
  }
  LightBounds bounds() const {
    const Vec3 far = corner + e1 + e2;
    return planar_bounds(vmin(vmin(corner, far), vmin(corner + e1, corner + e2)),
                         vmax(vmax(corner, far), vmax(corner + e1, corner + e2)));
  }
};

struct SphereLight {
  static constexpr bool kDelta = false, kEnvironment = false;
  Color radiance;
  uint32_t prim = 0;  // the sphere
  // Copied from the sphere by Scene::compile.
  Vec3 center;
  float radius = 0.f;
  bool flip = false;  // emits inward

  LUZ_FORCE_INLINE LightSample sample_li(const LightSampleContext& ctx, Vec2 u, const float*) const {
    return area_light_sample(sphere_sample(center, radius, flip, ctx.p, u), radiance);
  }
  LUZ_INLINE float pdf_li(const LightSampleContext& ctx, Vec3 wi, const LightHit& h, const float*) const {
    return sphere_pdf(center, radius, ctx.p, h.n, wi, h.dist);
  }
  LUZ_INLINE Color eval(Vec3 n, Vec3 w) const { return one_sided(radiance, n, w); }
  double phi(float) const {
    return M_PI * (4.0 * M_PI * double(radius) * radius) * std::max(0.0, double(average(radiance)));
  }
  // Normals every way (outward or, flipped, inward); intensity L·πr².
  LightBounds bounds() const {
    LightBounds b;
    const Vec3 r{radius, radius, radius};
    b.lo = center - r;
    b.hi = center + r;
    b.w = {0.f, 0.f, 1.f};
    b.cos_theta_o = -1.f;
    b.phi = float(M_PI * double(radius) * radius * std::max(0.0, double(average(radiance))));
    return b;
  }
};

}  // namespace luz
