// Smooth plastic: a diffuse base under a smooth dielectric coat, Mitsuba's
// `plastic` (W. Jakob, Mitsuba documentation, after Weidlich & Wilkie 2007,
// "Arbitrarily layered micro-facet surfaces"):
//   specular: delta reflection with amplitude specular_reflectance · F(cos θo),
//   diffuse:  f = (1 - F(cos θo)) (1 - F(cos θi)) / η² · ρ / (1 - F_dr,int) / π,
// with F the dielectric Fresnel term (η = int_ior / ext_ior) and F_dr,int
// the hemispherical-average reflectance of the coat seen from inside
// (light trapped by total internal reflection), computed once on the host by
// quadrature (fresnel_diffuse_reflectance). "Linear" (nonlinear = false):
// ρ/(1 - F_dr,int), not ρ/(1 - ρ F_dr,int), so the diffuse albedo
// is exactly (1 - F(cos θo)) ρ, because the coat's outside and inside
// hemispherical transmittances obey 1 - F_dr,ext = η² (1 - F_dr,int).
// nonlinear = true (Mitsuba's option): ρ/(1 - ρ F_dr,int), the geometric
// series of the light bouncing between base and coat, which darkens and
// saturates colours; its albedo is below the linear one.
//
// Sampling as Mitsuba's: the specular lobe with probability
//   P_s = F w_s / (F w_s + (1 - F)(1 - w_s)),  w_s = mean(ks) / (mean(ks) + mean(ρ)),
// the diffuse lobe (cosine-weighted) otherwise. pdf() is the diffuse part:
// (1 - P_s) cos θi / π.
#pragma once

#include "luz/bsdf/common.h"
#include "luz/bsdf/fresnel.h"
#include "luz/sampling/warp.h"

namespace luz {

struct SmoothPlasticBsdf {
  static constexpr bool kDeltaOnly = false, kHasDelta = true, kTransmission = false;
  // The members textures can drive (material.h).
  LUZ_INLINE Color* color_param(BsdfParam p) {
    return p == BsdfParam::DiffuseReflectance ? &diffuse_reflectance :
           p == BsdfParam::SpecularReflectance ? &specular_reflectance : nullptr;
  }
  LUZ_INLINE float* float_param(BsdfParam) { return nullptr; }
  Color diffuse_reflectance, specular_reflectance;
  float eta = 1.49f / 1.000277f;  // Mitsuba's defaults: polypropylene in air
  float fdr_int = 0.f;            // set by make()
  float specular_sampling_weight = 0.5f;
  bool nonlinear = false;
  uint8_t zero_[3] = {};  // not padding: checkpoints hash a material's bytes (render/checkpoint.cpp)

  static SmoothPlasticBsdf make(Color diffuse, Color specular, float int_ior = 1.49f, float ext_ior = 1.000277f,
                                bool nonlinear = false) {
    SmoothPlasticBsdf p;
    p.nonlinear = nonlinear;
    p.diffuse_reflectance = diffuse;
    p.specular_reflectance = specular;
    p.eta = int_ior / ext_ior;
    p.fdr_int = fresnel_diffuse_reflectance(1.f / p.eta);
    float d = average(diffuse), s = average(specular);
    p.specular_sampling_weight = d + s > 0.f ? s / (d + s) : 0.5f;
    return p;
  }

  LUZ_INLINE float specular_probability(float Fo) const {
    float ps = Fo * specular_sampling_weight, pd = (1.f - Fo) * (1.f - specular_sampling_weight);
    return ps + pd > 0.f ? ps / (ps + pd) : 0.f;
  }
  LUZ_INLINE Color f(Vec3 wo, Vec3 wi) const {
    if (!(wo.z > 0.f) || !(wi.z > 0.f)) return {};
    float Fo = fresnel_dielectric(wo.z, eta).F, Fi = fresnel_dielectric(wi.z, eta).F;
    float scale = (1.f - Fo) * (1.f - Fi) / (eta * eta) * kInvPi;
    Color rho = diffuse_reflectance;
    if (!nonlinear) return rho * (scale / (1.f - fdr_int));
    return {rho.x * scale / (1.f - rho.x * fdr_int), rho.y * scale / (1.f - rho.y * fdr_int),
            rho.z * scale / (1.f - rho.z * fdr_int)};
  }
  LUZ_INLINE float pdf(Vec3 wo, Vec3 wi) const {
    if (!(wo.z > 0.f) || !(wi.z > 0.f)) return 0.f;
    float Fo = fresnel_dielectric(wo.z, eta).F;
    return (1.f - specular_probability(Fo)) * cosine_hemisphere_pdf(wi);
  }
  LUZ_INLINE BsdfSample sample(Vec3 wo, float u1, Vec2 u2) const {
    BsdfSample s;
    if (!(wo.z > 0.f)) return s;
    float Fo = fresnel_dielectric(wo.z, eta).F;
    float ps = specular_probability(Fo);
    if (u1 < ps) {
      s.wi = {-wo.x, -wo.y, wo.z};
      s.pdf = ps;
      s.delta = true;
      s.weight = specular_reflectance * (Fo / ps);
      s.valid = true;
      return s;
    }
    s.wi = square_to_cosine_hemisphere(u2);
    if (!(s.wi.z > 0.f)) return s;
    s.pdf = (1.f - ps) * cosine_hemisphere_pdf(s.wi);
    if (!(s.pdf > 0.f)) return s;
    s.weight = f(wo, s.wi) * (s.wi.z / s.pdf);
    s.valid = true;
    return s;
  }
};

}  // namespace luz
