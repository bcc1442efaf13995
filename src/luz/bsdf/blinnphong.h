// Normalised Blinn-Phong (Blinn 1977, "Models of light reflection for
// computer synthesized pictures"), with the approximate energy
// normalisation (n + 8) / (8π) of Akenine-Möller, Haines & Hoffman,
// Real-Time Rendering 3rd ed. (2008), chapter 7 "Advanced Shading" (after
// Sloan & Hoffman):
//   f = k_d / π + k_s (n + 8) / (8π) cos^n θh,   h = (wo + wi)/|wo + wi|.
// It is reciprocal but conserves energy only approximately (the factor is a
// fit, not an exact normalisation): tests/test_bsdf_models.cpp measures and
// prints its worst albedo.
//
// Sampling: one number picks the lobe as PhongBsdf does (largest channels
// of k_d and k_s, scaled down if they sum above 1); diffuse: cosine-weighted;
// specular: h from the cosine-power density (n + 1)/(2π) cos^n θh around the
// normal, wi = reflect(wo, h), pdf (n + 1)/(2π) cos^n θh / (4 wo·h)
// (the reflection Jacobian); h facing away from wo, or wi below the horizon,
// is a failed sample.
#pragma once

#include "luz/bsdf/common.h"
#include "luz/sampling/warp.h"

namespace luz {

struct BlinnPhongBsdf {
  static constexpr bool kDeltaOnly = false, kHasDelta = false, kTransmission = false;
  // The members textures can drive (material.h).
  LUZ_INLINE Color* color_param(BsdfParam p) {
    return p == BsdfParam::DiffuseReflectance ? &diffuse_reflectance :
           p == BsdfParam::SpecularReflectance ? &specular_reflectance : nullptr;
  }
  LUZ_INLINE float* float_param(BsdfParam p) { return p == BsdfParam::Exponent ? &exponent : nullptr; }
  Color diffuse_reflectance, specular_reflectance;
  float exponent = 0.f;

  LUZ_INLINE void lobe_probabilities(float& pd, float& ps) const {
    pd = max_component(diffuse_reflectance);
    ps = max_component(specular_reflectance);
    float sum = pd + ps;
    if (sum > 1.f) {
      pd /= sum;
      ps /= sum;
    }
  }
  LUZ_INLINE Color f(Vec3 wo, Vec3 wi) const {
    if (!(wo.z > 0.f) || !(wi.z > 0.f)) return {};
    Vec3 h = normalize(wo + wi);
    float n = exponent;
    return diffuse_reflectance * kInvPi +
           specular_reflectance * ((n + 8.f) * (kInvPi / 8.f) * powf(max(h.z, 0.f), n));
  }
  LUZ_INLINE float pdf(Vec3 wo, Vec3 wi) const {
    if (!(wo.z > 0.f) || !(wi.z > 0.f)) return 0.f;
    float pd, ps;
    lobe_probabilities(pd, ps);
    Vec3 h = normalize(wo + wi);
    return pd * cosine_hemisphere_pdf(wi) + ps * cosine_power_pdf(h.z, exponent) / (4.f * dot(wo, h));
  }
  LUZ_INLINE BsdfSample sample(Vec3 wo, float u1, Vec2 u2) const {
    BsdfSample s;
    if (!(wo.z > 0.f)) return s;
    float pd, ps;
    lobe_probabilities(pd, ps);
    if (u1 < ps) {
      Vec3 h = square_to_cosine_power(u2, exponent);
      if (!(dot(wo, h) > 0.f)) return s;
      s.wi = reflect(wo, h);
    } else if (u1 < ps + pd) {
      s.wi = square_to_cosine_hemisphere(u2);
    } else {
      return s;  // absorbed
    }
    return finish_reflection_sample(*this, wo, s);
  }
};

}  // namespace luz
