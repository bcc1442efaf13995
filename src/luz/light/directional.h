// A directional light (Mitsuba's `directional`): irradiance E on surfaces
// facing it, from one direction at infinity (a distant sun). A delta light.
#pragma once

#include <algorithm>

#include "luz/light/light_sample.h"

namespace luz {

struct DirectionalLight {
  static constexpr bool kDelta = true, kEnvironment = false;
  Color irradiance;  // W/m² on a surface perpendicular to the light
  Vec3 direction;    // unit, the way the light travels

  LUZ_INLINE LightSample sample_li(const LightSampleContext&, Vec2, const float*) const {
    LightSample ls;
    ls.wi = -direction;
    ls.dist = kInfinity;
    ls.radiance = irradiance;
    ls.pdf = 1.f;
    ls.delta = true;
    return ls;
  }
  LUZ_INLINE float pdf_li(const LightSampleContext&, Vec3, const LightHit&, const float*) const { return 0.f; }
  LUZ_INLINE Color eval(Vec3, Vec3) const { return {}; }
  // The flux through the scene's bounding disk.
  double phi(float scene_radius) const {
    return M_PI * double(scene_radius) * scene_radius * std::max(0.0, double(average(irradiance)));
  }
};

}  // namespace luz
