// A directional light (Mitsuba's `directional`): irradiance E on surfaces
// facing it, from one direction at infinity (a distant sun). A delta light.
#pragma once

#include <algorithm>

#include "luz/geometry/shape_sampling.h"
#include "luz/light/light_sample.h"

namespace luz {

// An emitted ray of a light at infinity, travelling along unit d: its origin
// uniform on the disk of the scene's bounding sphere perpendicular to d,
// moved back to center - d·radius so that it starts outside the scene
// (pbrt-v4's DistantLight::SampleLe). pdf_dir: d's density (1 if a delta).
LUZ_INLINE LightLeSample infinite_le_sample(Vec3 d, Color radiance, float pdf_dir, Vec2 u_pos, Vec3 scene_center,
                                            float scene_radius) {
  LightLeSample s;
  const AreaSample as = disk_area_sample(scene_center - d * scene_radius, d, scene_radius, u_pos);
  if (!(as.pdf > 0.f) || !(pdf_dir > 0.f)) return s;
  s.p = as.p;
  s.d = d;
  s.radiance = radiance;
  s.pdf_pos = as.pdf;
  s.pdf_dir = pdf_dir;
  return s;
}

// The emitted ray of an environment (a constant or an envmap): a direction
// as its sample_li draws it, then through the disk as above.
template <class Environment>
LUZ_INLINE LightLeSample environment_le_sample(const Environment& env, Vec2 u_pos, Vec2 u_dir, const LightData& data,
                                               Vec3 scene_center, float scene_radius) {
  const LightSample ls = env.sample_li({}, u_dir, data);
  return infinite_le_sample(-ls.wi, ls.radiance, ls.pdf, u_pos, scene_center, scene_radius);
}

struct DirectionalLight {
  static constexpr bool kDelta = true, kEnvironment = false;
  Color irradiance;  // W/m² on a surface perpendicular to the light
  Vec3 direction;    // unit, the way the light travels

  LUZ_INLINE LightSample sample_li(const LightSampleContext&, Vec2, const LightData&) const {
    LightSample ls;
    ls.wi = -direction;
    ls.dist = kInfinity;
    ls.radiance = irradiance;
    ls.pdf = 1.f;
    ls.delta = true;
    return ls;
  }
  LUZ_INLINE float pdf_li(const LightSampleContext&, Vec3, const LightHit&, const LightData&) const { return 0.f; }
  LUZ_INLINE LightLeSample sample_le(Vec2 u_pos, Vec2, const LightData&, Vec3 scene_center, float scene_radius) const {
    LightLeSample s = infinite_le_sample(direction, irradiance, 1.f, u_pos, scene_center, scene_radius);
    s.delta_dir = true;
    return s;
  }
  LUZ_INLINE LightLePdf pdf_le(Vec3, Vec3, Vec3, const LightData&, float scene_radius) const {
    return {disk_area_pdf(scene_radius), 1.f};
  }
  LUZ_INLINE Color eval(Vec3, Vec3, Vec2, const LightData&) const { return {}; }
  // The flux through the scene's bounding disk.
  double phi(float scene_radius) const {
    return M_PI * double(scene_radius) * scene_radius * std::max(0.0, double(average(irradiance)));
  }
  // The irradiance it gives an unoccluded surface facing it.
  double irradiance_estimate() const { return std::max(0.0, double(average(irradiance))); }
};

}  // namespace luz
