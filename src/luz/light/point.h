// A point light (Mitsuba's `point`): radiant intensity I in every direction
// from one position. A delta light: found only by next-event estimation.
#pragma once

#include <algorithm>

#include "luz/light/light_bounds.h"
#include "luz/light/light_sample.h"
#include "luz/sampling/warp.h"

namespace luz {

// The delta-light sample toward position p with intensity I (in the
// direction of the sample): I / d², pdf 1.
LUZ_INLINE LightSample point_light_sample(Vec3 p, Vec3 ref, Color intensity_toward_ref) {
  LightSample ls;
  ls.p = p;
  Vec3 d = p - ref;
  float d2 = length_squared(d);
  ls.dist = sqrtf(d2);
  if (!(d2 > 0.f)) return ls;
  ls.wi = d / ls.dist;
  ls.radiance = intensity_toward_ref * (1.f / d2);
  ls.pdf = 1.f;
  ls.delta = true;
  return ls;
}

struct PointLight {
  static constexpr bool kDelta = true, kEnvironment = false;
  Color intensity;  // W/sr
  Vec3 position;

  LUZ_INLINE LightSample sample_li(const LightSampleContext& ctx, Vec2, const LightData&) const {
    return point_light_sample(position, ctx.p, intensity);
  }
  LUZ_INLINE float pdf_li(const LightSampleContext&, Vec3, const LightHit&, const LightData&) const { return 0.f; }
  // Emitted rays: uniform over the sphere of directions.
  LUZ_INLINE LightLeSample sample_le(Vec2, Vec2 u_dir, const LightData&, Vec3, float) const {
    LightLeSample s;
    s.p = position;
    s.d = square_to_uniform_sphere(u_dir);
    s.radiance = intensity;
    s.pdf_pos = 1.f;
    s.pdf_dir = uniform_sphere_pdf();
    s.delta_pos = true;
    return s;
  }
  LUZ_INLINE LightLePdf pdf_le(Vec3, Vec3, Vec3, const LightData&, float) const { return {1.f, uniform_sphere_pdf()}; }
  LUZ_INLINE Color eval(Vec3, Vec3, Vec2, const LightData&) const { return {}; }
  double phi(float) const { return 4.0 * M_PI * std::max(0.0, double(average(intensity))); }
  LightBounds bounds() const {
    LightBounds b;
    b.lo = b.hi = position;
    b.w = {0.f, 0.f, 1.f};
    b.cos_theta_o = -1.f;
    b.phi = float(std::max(0.0, double(average(intensity))));
    return b;
  }
};

}  // namespace luz
