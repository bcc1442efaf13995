// A constant environment (Mitsuba's `constant`): the same radiance from every
// direction. Toward a point that can only receive light from one hemisphere
// (LightSampleContext::hemisphere), directions are sampled by the cosine
// about its pole, as a diffuse surface weighs them; else uniformly over the
// sphere. Half of uniform sphere samples would fall where no light arrives.
// Where the render built a guide (LightData::guide, env_guide.h: indoors, the
// directions the sky is actually seen in), a mixture of it and the cosine.
#pragma once

#include <algorithm>

#include "luz/light/directional.h"
#include "luz/light/light_sample.h"
#include "luz/sampling/warp.h"

namespace luz {

struct ConstantLight {
  static constexpr bool kDelta = false, kEnvironment = true;
  Color radiance;

  LUZ_INLINE LightSample sample_li(const LightSampleContext& ctx, Vec2 u, const LightData& data) const {
    LightSample ls;
    ls.dist = kInfinity;
    ls.radiance = radiance;
    if (dot(ctx.hemisphere, ctx.hemisphere) == 0.f) {
      ls.wi = square_to_uniform_sphere(u);
      ls.pdf = uniform_sphere_pdf();
      return ls;
    }
    const int d = data.guide ? data.guide->find(ctx.p, ctx.hemisphere) : -1;
    if (d >= 0) return sample_guided(ctx, u, *data.guide, d);
    const Vec3 local = square_to_cosine_hemisphere(u);
    ls.wi = Frame::from_normal(ctx.hemisphere).to_world(local);
    ls.pdf = cosine_hemisphere_pdf(local);
    return ls;
  }
  LUZ_INLINE float pdf_li(const LightSampleContext& ctx, Vec3 wi, const LightHit&, const LightData& data) const {
    if (dot(ctx.hemisphere, ctx.hemisphere) == 0.f) return uniform_sphere_pdf();
    const float p_cos = fmaxf(dot(wi, ctx.hemisphere), 0.f) * kInvPi;
    const int d = data.guide ? data.guide->find(ctx.p, ctx.hemisphere) : -1;
    return d < 0 ? p_cos : guided_pdf(p_cos, wi, *data.guide, d);
  }
  // The guide's mixture (distribution d with probability guide.mix, the
  // cosine otherwise): u.x picks the strategy, then is reused within it. Out
  // of line on the CPU: scenes without a guide keep their inlined path.
  LUZ_CPU_NOINLINE LightSample sample_guided(const LightSampleContext& ctx, Vec2 u, const EnvGuide& guide, int d) const {
    LightSample ls;
    ls.dist = kInfinity;
    ls.radiance = radiance;
    const float m = guide.mix;
    float p_guide;
    if (u.x < m) {
      u.x = min(u.x / m, kOneMinusEpsilon);
      ls.wi = guide.sample(d, u, p_guide);
    } else {
      u.x = min((u.x - m) / (1.f - m), kOneMinusEpsilon);
      ls.wi = Frame::from_normal(ctx.hemisphere).to_world(square_to_cosine_hemisphere(u));
      p_guide = guide.pdf(d, ls.wi);
    }
    ls.pdf = m * p_guide + (1.f - m) * fmaxf(dot(ls.wi, ctx.hemisphere), 0.f) * kInvPi;
    return ls;
  }
  LUZ_CPU_NOINLINE static float guided_pdf(float p_cos, Vec3 wi, const EnvGuide& guide, int d) {
    return guide.mix * guide.pdf(d, wi) + (1.f - guide.mix) * p_cos;
  }
  // Emitted rays: a uniform direction, then through the scene's disk.
  LUZ_INLINE LightLeSample sample_le(Vec2 u_pos, Vec2 u_dir, const LightData& data, Vec3 scene_center,
                                     float scene_radius) const {
    return environment_le_sample(*this, u_pos, u_dir, data, scene_center, scene_radius);
  }
  LUZ_INLINE LightLePdf pdf_le(Vec3, Vec3, Vec3 d, const LightData& data, float scene_radius) const {
    return {disk_area_pdf(scene_radius), pdf_li({}, -d, {}, data)};
  }
  LUZ_INLINE Color le(Vec3, const LightData&) const { return radiance; }
  // The power its emitted rays carry (sample_le): radiance from every
  // direction through the scene's bounding disk, 4π · πr² · L (pbrt-v4's
  // UniformInfiniteLight::Phi).
  double phi(float scene_radius) const {
    return 4.0 * M_PI * (M_PI * double(scene_radius) * scene_radius) * std::max(0.0, double(average(radiance)));
  }
  // The irradiance it gives an unoccluded surface: πL, whichever way it faces.
  double irradiance_estimate() const { return M_PI * std::max(0.0, double(average(radiance))); }
};

}  // namespace luz
