// The seed's modified Phong (Lewis 1994; Lafortune & Willems 1994), eq. (2.10),
// Mitsuba 0.6's `phong` (diffuse_reflectance, specular_reflectance, exponent):
//   f = k_d/π + k_s (n+2)/(2π) cos^n α,
// α the angle between wi and the mirror direction of wo. Energy-conserving
// when k_d + k_s ≤ 1 (checked at load time).
//
// Sampling as the seed's §2.5.1: one uniform number picks the specular lobe
// with probability p_s, the diffuse lobe with p_d, and absorption otherwise.
// The seed uses p_s = k_s, p_d = k_d; for RGB we use the largest channel of
// each (scaled down if p_s + p_d > 1), which keeps the weights ≤ 1 where k is
// grey. Diffuse: cosine-weighted hemisphere (correct disk warp). Specular:
// cosine-power lobe around the mirror direction; a direction below the
// horizon is a failed sample. pdf() is the density of the whole mixture (a
// sub-probability density: it integrates to the chance that sample() returns
// a direction), which is what multiple importance sampling needs.
#pragma once

#include "luz/bsdf/common.h"
#include "luz/sampling/warp.h"

namespace luz {

struct PhongBsdf {
  static constexpr bool kDeltaOnly = false, kHasDelta = false, kTransmission = false;
  // The members textures can drive (material.h).
  LUZ_INLINE Color* color_param(BsdfParam p) {
    return p == BsdfParam::DiffuseReflectance ? &kd :
           p == BsdfParam::SpecularReflectance ? &ks : nullptr;
  }
  LUZ_INLINE float* float_param(BsdfParam p) { return p == BsdfParam::Exponent ? &exponent : nullptr; }
  Color kd, ks;
  float exponent = 1.f;

  LUZ_INLINE void lobe_probabilities(float& pd, float& ps) const {
    pd = max_component(kd);
    ps = max_component(ks);
    float sum = pd + ps;
    if (sum > 1.f) {
      pd /= sum;
      ps /= sum;
    }
  }
  LUZ_INLINE Color f(Vec3 wo, Vec3 wi) const {
    Vec3 r = {-wo.x, -wo.y, wo.z};
    float c = dot(wi, r);
    Color v = kd * kInvPi;
    if (c > 0.f) v += ks * ((exponent + 2.f) * kInv2Pi * powf(c, exponent));
    return v;
  }
  LUZ_INLINE float pdf(Vec3 wo, Vec3 wi) const {
    if (wi.z <= 0.f) return 0.f;
    float pd, ps;
    lobe_probabilities(pd, ps);
    Vec3 r = {-wo.x, -wo.y, wo.z};
    return pd * cosine_hemisphere_pdf(wi) + ps * cosine_power_pdf(dot(wi, r), exponent);
  }
  LUZ_INLINE BsdfSample sample(Vec3 wo, float u1, Vec2 u2) const {
    BsdfSample s;
    float pd, ps;
    lobe_probabilities(pd, ps);
    if (u1 < ps) {
      Frame mirror = Frame::from_normal({-wo.x, -wo.y, wo.z});
      s.wi = mirror.to_world(square_to_cosine_power(u2, exponent));
    } else if (u1 < ps + pd) {
      s.wi = square_to_cosine_hemisphere(u2);
    } else {
      return s;  // absorbed
    }
    return finish_reflection_sample(*this, wo, s);
  }
};

}  // namespace luz
