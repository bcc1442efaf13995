// Diffuse area lights: a constant radiance, or a texture's at the point's
// uv (triangles, spheres), on the side of the geometric normal
// (one-sided, as Mitsuba's `area`; planar ones may emit on both sides, as
// pbrt-v4's `twosided`), on a triangle, a parallelogram (a quad
// light: two triangles of one mesh merged by Scene::compile and sampled as
// one) or a sphere. Each samples its shape through geometry/shape_sampling.h;
// emitted rays start at a point uniform by area, cosine-weighted about the
// emitting normal (pbrt-v4's DiffuseAreaLight::SampleLe).
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

// The densities of area_light_le_sample: pdf_pos by area, direction cosine-
// weighted about the emitting normal n (one-sided), per solid angle.
LUZ_INLINE LightLePdf area_light_le_pdf(float pdf_pos, Vec3 n, Vec3 d) {
  return {pdf_pos, cosine_hemisphere_pdf({0.f, 0.f, dot(n, d)})};
}

// The same for a light emitting on both sides: either side's hemisphere,
// half the density.
LUZ_INLINE LightLePdf two_sided_le_pdf(float pdf_pos, Vec3 n, Vec3 d) {
  return {pdf_pos, 0.5f * cosine_hemisphere_pdf({0.f, 0.f, fabsf(dot(n, d))})};
}

// An emitted ray from a point sampled by area: its direction cosine-weighted
// about the emitting normal, the pdf taken from area_light_le_pdf so that
// the two agree exactly. `two_sided`: u_dir.x first picks the side (the
// sample's n is then that side's normal), and the density halves.
LUZ_INLINE LightLeSample area_light_le_sample(AreaSample as, Color radiance, Vec2 u_dir, bool two_sided = false) {
  LightLeSample s;
  if (!(as.pdf > 0.f)) return s;
  if (two_sided) {
    const bool back = u_dir.x < 0.5f;
    u_dir.x = fminf(back ? 2.f * u_dir.x : 2.f * u_dir.x - 1.f, 0x1.fffffep-1f);
    if (back) as.n = -as.n;
  }
  s.d = normalize(Frame::from_normal(as.n).to_world(square_to_cosine_hemisphere(u_dir)));
  const LightLePdf pdf = two_sided ? two_sided_le_pdf(as.pdf, as.n, s.d) : area_light_le_pdf(as.pdf, as.n, s.d);
  if (!(pdf.pdf_dir > 0.f)) return s;  // grazing, lost to rounding
  s.p = as.p;
  s.n = as.n;
  s.radiance = radiance;
  s.pdf_pos = pdf.pdf_pos;
  s.pdf_dir = pdf.pdf_dir;
  return s;
}

// Radiance leaving a point of normal n toward w (away from it).
LUZ_INLINE Color one_sided(Color radiance, Vec3 n, Vec3 w) { return dot(n, w) <= 0.f ? Color{} : radiance; }

// What triangles and parallelograms share: a plane piece, one-sided or two.
struct PlanarLight {
  static constexpr bool kDelta = false, kEnvironment = false;
  Color radiance;  // for a textured light, the texture's mean (what power and bounds use)
  int32_t texture = -1;  // LightData::textures, or -1: constant radiance
  bool two_sided = false;  // emits on both sides (pbrt-v4's twosided area lights)
  uint8_t zero_[3] = {};   // not padding: checkpoints hash a light's bytes (render/checkpoint.cpp)
  // Set by Scene::compile, so that sampling does not recompute them at every vertex.
  Vec3 normal;  // unit, the emitting side (one of them, when two-sided)
  float area = 0.f;

  // The emitting side's normal as seen from p, on the plane through `on`.
  LUZ_INLINE Vec3 facing(Vec3 on, Vec3 p) const { return two_sided && dot(normal, p - on) < 0.f ? -normal : normal; }
  LUZ_INLINE float pdf_li(const LightSampleContext&, Vec3 wi, const LightHit& h, const LightData&) const {
    return planar_pdf(two_sided && dot(h.n, wi) > 0.f ? -h.n : h.n, area, wi, h.dist);
  }
  LUZ_INLINE LightLePdf pdf_le(Vec3, Vec3 n, Vec3 d, const LightData&, float) const {
    return two_sided ? two_sided_le_pdf(inverse_area(area), n, d) : area_light_le_pdf(inverse_area(area), n, d);
  }
  // At the point of texture coordinates uv.
  LUZ_INLINE Color radiance_at(Vec2 uv, const LightData& data) const {
    return texture < 0 ? radiance : data.textures.eval(uint32_t(texture), uv);
  }
  LUZ_INLINE Color eval(Vec3 n, Vec3 w, Vec2 uv, const LightData& data) const {
    const float c = dot(n, w);
    return c > 0.f || (two_sided && c < 0.f) ? radiance_at(uv, data) : Color{};
  }
  double phi(float) const {
    return (two_sided ? 2.0 : 1.0) * M_PI * double(area) * std::max(0.0, double(average(radiance)));
  }
  // Emits into the hemisphere of `normal` (both, two-sided) from within [lo, hi].
  LightBounds planar_bounds(Vec3 lo, Vec3 hi) const {
    LightBounds b;
    b.lo = lo;
    b.hi = hi;
    b.w = normal;
    b.two_sided = two_sided;
    b.phi = float((two_sided ? 2.0 : 1.0) * double(area) * std::max(0.0, double(average(radiance))));
    return b;
  }
};

struct TriangleLight : PlanarLight {
  uint32_t prim = 0;  // the triangle
  Vec3 v0, v1, v2;    // its vertices, copied: no index look-ups when sampling
  Vec2 uv0, uv1, uv2;  // their texture coordinates (a textured light)

  // The radiance at the point of barycentrics b (of v1, v2).
  LUZ_INLINE Color radiance_at_barycentrics(Vec2 b, const LightData& data) const {
    const float b0 = 1.f - b.x - b.y;
    return radiance_at({uv0.x * b0 + uv1.x * b.x + uv2.x * b.y, uv0.y * b0 + uv1.y * b.x + uv2.y * b.y}, data);
  }
  LUZ_FORCE_INLINE LightSample sample_li(const LightSampleContext& ctx, Vec2 u, const LightData& data) const {
    const Vec3 n = facing(v0, ctx.p);
    if (texture < 0) return area_light_sample(triangle_sample(v0, v1, v2, n, area, ctx.p, u), radiance);
    const Vec2 b = square_to_triangle_barycentrics(u);
    const ShapeSample ss = planar_sample(v0 * (1.f - b.x - b.y) + v1 * b.x + v2 * b.y, n, area, ctx.p);
    return area_light_sample(ss, radiance_at_barycentrics(b, data));
  }
  LUZ_INLINE LightLeSample sample_le(Vec2 u_pos, Vec2 u_dir, const LightData& data, Vec3, float) const {
    const Vec2 b = square_to_triangle_barycentrics(u_pos);
    return area_light_le_sample(triangle_area_sample(v0, v1, v2, normal, area, u_pos),
                                radiance_at_barycentrics(b, data), u_dir, two_sided);
  }
  LightBounds bounds() const { return planar_bounds(vmin(v0, vmin(v1, v2)), vmax(v0, vmax(v1, v2))); }
};

struct ParallelogramLight : PlanarLight {
  uint32_t prim = 0, prim2 = 0;  // its two triangles
  Vec3 corner, e1, e2;           // points corner + u e1 + v e2

  LUZ_FORCE_INLINE LightSample sample_li(const LightSampleContext& ctx, Vec2 u, const LightData&) const {
    return area_light_sample(parallelogram_sample(corner, e1, e2, facing(corner, ctx.p), area, ctx.p, u), radiance);
  }
  LUZ_INLINE LightLeSample sample_le(Vec2 u_pos, Vec2 u_dir, const LightData&, Vec3, float) const {
    return area_light_le_sample(parallelogram_area_sample(corner, e1, e2, normal, area, u_pos), radiance, u_dir,
                                two_sided);
  }
  LightBounds bounds() const {
    const Vec3 far = corner + e1 + e2;
    return planar_bounds(vmin(vmin(corner, far), vmin(corner + e1, corner + e2)),
                         vmax(vmax(corner, far), vmax(corner + e1, corner + e2)));
  }
};

struct SphereLight {
  static constexpr bool kDelta = false, kEnvironment = false;
  Color radiance;  // for a textured light, the texture's mean (what power and bounds use, as PlanarLight)
  uint32_t prim = 0;  // the sphere
  int32_t texture = -1;  // LightData::textures at the sphere's uv (sphere_uv), or -1: constant radiance
  // Copied from the sphere by Scene::compile.
  Vec3 center;
  float radius = 0.f;
  bool flip = false;  // emits inward
  uint8_t zero_[3] = {};  // not padding: checkpoints hash a light's bytes (render/checkpoint.cpp)
  Frame frame{{1.f, 0.f, 0.f}, {0.f, 1.f, 0.f}, {0.f, 0.f, 1.f}};  // Sphere::frame

  // At the sphere's point p.
  LUZ_INLINE Color radiance_at(Vec3 p, const LightData& data) const {
    return texture < 0 ? radiance : data.textures.eval(uint32_t(texture), sphere_uv(frame.to_local(p - center)));
  }
  LUZ_FORCE_INLINE LightSample sample_li(const LightSampleContext& ctx, Vec2 u, const LightData& data) const {
    const ShapeSample ss = sphere_sample(center, radius, flip, ctx.p, u);
    return area_light_sample(ss, radiance_at(ss.p, data));
  }
  LUZ_INLINE float pdf_li(const LightSampleContext& ctx, Vec3 wi, const LightHit& h, const LightData&) const {
    return sphere_pdf(center, radius, ctx.p, h.n, wi, h.dist);
  }
  // Emitted rays: by area over the whole sphere, then cosine-weighted about
  // the emitting normal (inward when flipped).
  LUZ_INLINE LightLeSample sample_le(Vec2 u_pos, Vec2 u_dir, const LightData& data, Vec3, float) const {
    const AreaSample as = sphere_area_sample(center, radius, flip, u_pos);
    return area_light_le_sample(as, radiance_at(as.p, data), u_dir);
  }
  LUZ_INLINE LightLePdf pdf_le(Vec3, Vec3 n, Vec3 d, const LightData&, float) const {
    return area_light_le_pdf(sphere_area_pdf(radius), n, d);
  }
  LUZ_INLINE Color eval(Vec3 n, Vec3 w, Vec2 uv, const LightData& data) const {
    if (texture < 0) return one_sided(radiance, n, w);
    return dot(n, w) <= 0.f ? Color{} : data.textures.eval(uint32_t(texture), uv);
  }
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
