// Conductors: a smooth mirror with the exact conductor Fresnel term, and the
// rough (microfacet) conductor.
//
// Rough conductor: the Cook-Torrance microfacet BRDF (Cook & Torrance 1982,
// in the normalisation of Walter et al. 2007, eq. 20):
//   f(wo, wi) = F(wo·h) D(h) G2(wo, wi, h) / (4 cos θo cos θi),  h = (wo + wi)/|wo + wi|,
// with D Beckmann or GGX (microfacet.h) and the height-correlated Smith G2
// (Heitz 2014, eq. 99). "Cook-Torrance" is the classic name of this same
// model: Cook & Torrance's Beckmann D and V-cavity G are the special case
// of a different G; this struct is it with Smith's G.
//
// Sampling: visible normals from wo (Heitz & d'Eon 2014; Heitz 2018 for
// GGX), wi = reflect(wo, m): pdf(wi) = D_wo(m) / (4 wo·m) (the reflection
// Jacobian, Walter et al. 2007, eq. 14), weight = F G2 / G1(wo).
//
// Parameters as Mitsuba's `conductor` / `roughconductor`: eta, k (complex
// IOR per RGB channel), specular_reflectance (a factor), distribution,
// alpha_u, alpha_v. One-sided: the Bsdf wrapper handles `twosided`.
#pragma once

#include "luz/bsdf/common.h"
#include "luz/bsdf/fresnel.h"
#include "luz/bsdf/microfacet.h"

namespace luz {

struct SmoothConductorBsdf {
  static constexpr bool kDeltaOnly = true, kHasDelta = true, kTransmission = false;
  // The members textures can drive (material.h).
  LUZ_INLINE Color* color_param(BsdfParam p) {
    return p == BsdfParam::Eta ? &eta :
           p == BsdfParam::K ? &k :
           p == BsdfParam::SpecularReflectance ? &specular_reflectance : nullptr;
  }
  LUZ_INLINE float* float_param(BsdfParam) { return nullptr; }
  Color eta, k, specular_reflectance;

  LUZ_INLINE Color f(Vec3, Vec3) const { return {}; }
  LUZ_INLINE float pdf(Vec3, Vec3) const { return 0.f; }
  LUZ_INLINE BsdfSample sample(Vec3 wo, float, Vec2) const {
    BsdfSample s;
    if (!(wo.z > 0.f)) return s;
    s.wi = {-wo.x, -wo.y, wo.z};
    s.pdf = 1.f;
    s.delta = true;
    s.weight = specular_reflectance * fresnel_conductor(wo.z, eta, k);
    s.valid = true;
    return s;
  }
};

struct RoughConductorBsdf {
  static constexpr bool kDeltaOnly = false, kHasDelta = false, kTransmission = false;
  // The members textures can drive (material.h).
  LUZ_INLINE Color* color_param(BsdfParam p) {
    return p == BsdfParam::Eta ? &eta :
           p == BsdfParam::K ? &k :
           p == BsdfParam::SpecularReflectance ? &specular_reflectance : nullptr;
  }
  LUZ_INLINE float* float_param(BsdfParam p) {
    return p == BsdfParam::AlphaU ? &alpha_u :
           p == BsdfParam::AlphaV ? &alpha_v : nullptr;
  }
  MicrofacetType distribution = MicrofacetType::Beckmann;
  float alpha_u = 0.f, alpha_v = 0.f;
  Color eta, k, specular_reflectance;

  LUZ_INLINE MicrofacetDistribution dist() const {
    return MicrofacetDistribution::make(distribution, alpha_u, alpha_v);
  }
  LUZ_INLINE Color f(Vec3 wo, Vec3 wi) const {
    if (!(wo.z > 0.f) || !(wi.z > 0.f)) return {};
    Vec3 h = normalize(wo + wi);
    MicrofacetDistribution d = dist();
    float D = d.D(h);
    if (D == 0.f) return {};
    float G = d.G2(wo, wi, h);
    Color F = fresnel_conductor(dot(wo, h), eta, k);
    return specular_reflectance * F * (D * G / (4.f * wo.z * wi.z));
  }
  LUZ_INLINE float pdf(Vec3 wo, Vec3 wi) const {
    if (!(wo.z > 0.f) || !(wi.z > 0.f)) return 0.f;
    Vec3 h = normalize(wo + wi);
    return dist().pdf_visible(wo, h) / (4.f * dot(wo, h));
  }
  LUZ_INLINE BsdfSample sample(Vec3 wo, float, Vec2 u) const {
    BsdfSample s;
    if (!(wo.z > 0.f)) return s;
    MicrofacetDistribution d = dist();
    Vec3 m = d.sample_visible(wo, u);
    float wom = dot(wo, m);
    if (!(wom > 0.f)) return s;
    s.wi = reflect(wo, m);
    if (!(s.wi.z > 0.f)) return s;  // reflected below the horizon: a failed sample
    s.pdf = d.pdf_visible(wo, m) / (4.f * wom);
    if (!(s.pdf > 0.f)) return s;
    float lo = d.lambda(wo), li = d.lambda(s.wi);
    Color F = fresnel_conductor(wom, eta, k);
    s.weight = specular_reflectance * F * ((1.f + lo) / (1.f + lo + li));  // F G2 / G1
    s.valid = true;
    return s;
  }
};

}  // namespace luz
