// Lambertian reflector, Mitsuba's `diffuse` (reflectance): f = ρ/π, sampled
// cosine-weighted. One-sided: the Bsdf wrapper handles `twosided`.
// And pbrt-v4's `diffusetransmission`: a Lambertian reflector and
// transmitter (a leaf, paper, a lamp shade).
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

// pbrt-v4's DiffuseTransmissionBxDF: f = R/π toward wo's side, T/π through
// the surface, the same from both sides (η = 1: reciprocal in both transport
// modes). Sampled cosine-weighted, on wo's side with probability
// max(R) / (max(R) + max(T)), through it otherwise, as pbrt-v4.
struct DiffuseTransmissionBsdf {
  static constexpr bool kDeltaOnly = false, kHasDelta = false, kTransmission = true;
  // The members textures can drive (material.h).
  LUZ_INLINE Color* color_param(BsdfParam p) {
    return p == BsdfParam::Reflectance ? &reflectance : p == BsdfParam::Transmittance ? &transmittance : nullptr;
  }
  LUZ_INLINE float* float_param(BsdfParam) { return nullptr; }
  Color reflectance{.25f, .25f, .25f}, transmittance{.25f, .25f, .25f};  // pbrt-v4's defaults

  // The probability of sampling wo's side, or -1 where nothing scatters.
  LUZ_INLINE float reflect_probability() const {
    const float pr = max(max_component(reflectance), 0.f), pt = max(max_component(transmittance), 0.f);
    return pr + pt > 0.f ? pr / (pr + pt) : -1.f;
  }
  LUZ_INLINE Color f(Vec3 wo, Vec3 wi, TransportMode = TransportMode::Radiance) const {
    const float side = wo.z * wi.z;
    return side > 0.f ? reflectance * kInvPi : side < 0.f ? transmittance * kInvPi : Color{};
  }
  LUZ_INLINE float pdf(Vec3 wo, Vec3 wi) const {
    const float pr = reflect_probability(), side = wo.z * wi.z;
    if (!(pr >= 0.f) || side == 0.f) return 0.f;
    return (side > 0.f ? pr : 1.f - pr) * fabsf(wi.z) * kInvPi;
  }
  LUZ_INLINE BsdfSample sample(Vec3 wo, float u1, Vec2 u2, TransportMode = TransportMode::Radiance) const {
    BsdfSample s;
    const float pr = reflect_probability();
    if (!(pr >= 0.f) || wo.z == 0.f || !(wo.z == wo.z)) return s;
    const bool reflect = u1 < pr;
    s.wi = square_to_cosine_hemisphere(u2);
    if ((wo.z > 0.f) != reflect) s.wi.z = -s.wi.z;
    const float p = reflect ? pr : 1.f - pr;
    s.pdf = p * fabsf(s.wi.z) * kInvPi;
    if (!(s.pdf > 0.f)) return BsdfSample{};
    s.weight = (reflect ? reflectance : transmittance) * (1.f / p);
    s.transmission = !reflect;
    s.valid = true;
    return s;
  }
};

}  // namespace luz
