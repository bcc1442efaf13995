// Lambertian reflector, Mitsuba's `diffuse` (reflectance): f = ρ/π, sampled
// cosine-weighted. One-sided: the Bsdf wrapper handles `twosided`.
#pragma once

#include "luz/bsdf/common.h"
#include "luz/sampling/warp.h"

namespace luz {

struct DiffuseBsdf {
  static constexpr bool kDeltaOnly = false, kHasDelta = false, kTransmission = false;
  // The members textures can drive (material.h).
  LUZ_INLINE Color* color_param(BsdfParam p) { return p == BsdfParam::Reflectance ? &reflectance : nullptr; }
  LUZ_INLINE float* float_param(BsdfParam) { return nullptr; }
  Color reflectance;

  LUZ_INLINE Color f(Vec3, Vec3) const { return reflectance * kInvPi; }
  LUZ_INLINE float pdf(Vec3, Vec3 wi) const { return cosine_hemisphere_pdf(wi); }
  LUZ_INLINE BsdfSample sample(Vec3, float, Vec2 u) const {
    BsdfSample s;
    s.wi = square_to_cosine_hemisphere(u);
    s.pdf = cosine_hemisphere_pdf(s.wi);
    s.valid = s.pdf > 0.f;
    s.weight = reflectance;
    return s;
  }
};

}  // namespace luz
