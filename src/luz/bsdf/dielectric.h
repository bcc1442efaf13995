// Dielectric interfaces: smooth (delta reflection + delta refraction), rough
// (Walter et al. 2007), and a thin sheet (two parallel interfaces, no
// refraction of the ray).
//
// Frame: the normal +z points to the outside (exterior IOR ext_ior), the
// interior has int_ior; `eta` = int_ior / ext_ior as Mitsuba. wo may be on
// either side (wo.z < 0: the path is inside), so these models do their own
// two-sidedness and the Bsdf wrapper passes them wo as it is.
//
// Transport mode. Refraction compresses solid angle: radiance crossing into a
// medium of higher IOR grows by (η_t/η_i)² (Veach 1997, §5.2). In
// TransportMode::Radiance (the path tracer: wo toward the camera, light
// arrives along wi) the BTDF carries the factor (η_wo/η_wi)² = 1/η², η =
// η_wi/η_wo = BsdfSample::eta; in Importance mode it does not. Walter et al.
// 2007, eq. 21 is the radiance form; the generalised reciprocity (Veach
// 1997, §5.2) reads f(wo, wi) / η_wo² = f(wi, wo) / η_wi².
#pragma once

#include "luz/bsdf/common.h"
#include "luz/bsdf/fresnel.h"
#include "luz/bsdf/microfacet.h"

namespace luz {

struct SmoothDielectricBsdf {
  static constexpr bool kDeltaOnly = true, kHasDelta = true, kTransmission = true;
  // The members textures can drive (material.h).
  LUZ_INLINE Color* color_param(BsdfParam p) {
    return p == BsdfParam::SpecularReflectance ? &specular_reflectance :
           p == BsdfParam::SpecularTransmittance ? &specular_transmittance : nullptr;
  }
  LUZ_INLINE float* float_param(BsdfParam) { return nullptr; }
  float eta = 1.5046f;  // int_ior / ext_ior
  Color specular_reflectance, specular_transmittance;

  LUZ_INLINE Color f(Vec3, Vec3, TransportMode = TransportMode::Radiance) const { return {}; }
  LUZ_INLINE float pdf(Vec3, Vec3) const { return 0.f; }
  // u1 chooses reflection with probability F (Fresnel), refraction otherwise.
  LUZ_INLINE BsdfSample sample(Vec3 wo, float u1, Vec2, TransportMode mode = TransportMode::Radiance) const {
    BsdfSample s;
    if (wo.z == 0.f || !(wo.z == wo.z)) return s;
    FresnelDielectric fr = fresnel_dielectric(wo.z, eta);
    s.delta = true;
    s.valid = true;
    if (u1 < fr.F) {
      s.wi = {-wo.x, -wo.y, wo.z};
      s.pdf = fr.F;
      s.weight = specular_reflectance;
    } else {
      s.wi = refract(wo, Vec3{0.f, 0.f, 1.f}, fr.cos_t, fr.eta_ti);
      s.pdf = 1.f - fr.F;
      s.weight = specular_transmittance;
      if (mode == TransportMode::Radiance) s.weight *= fr.eta_ti * fr.eta_ti;
      s.transmission = true;
      s.eta = fr.eta_it;
    }
    return s;
  }
};

// Thin dielectric sheet (Mitsuba's `thindielectric`): two parallel smooth
// interfaces; the internal bounces sum in closed form, R' = R + T²R/(1 - R²)
// (geometric series), T' = 1 - R'. Transmission goes straight through (wi =
// -wo, no net refraction, eta = 1, no radiance scaling).
struct ThinDielectricBsdf {
  static constexpr bool kDeltaOnly = true, kHasDelta = true, kTransmission = true;
  // The members textures can drive (material.h).
  LUZ_INLINE Color* color_param(BsdfParam p) {
    return p == BsdfParam::SpecularReflectance ? &specular_reflectance :
           p == BsdfParam::SpecularTransmittance ? &specular_transmittance : nullptr;
  }
  LUZ_INLINE float* float_param(BsdfParam) { return nullptr; }
  float eta = 1.5046f;
  Color specular_reflectance, specular_transmittance;

  LUZ_INLINE Color f(Vec3, Vec3, TransportMode = TransportMode::Radiance) const { return {}; }
  LUZ_INLINE float pdf(Vec3, Vec3) const { return 0.f; }
  LUZ_INLINE float reflectance(float cos_o) const {
    float R = fresnel_dielectric(fabsf(cos_o), eta).F, T = 1.f - R;
    if (R < 1.f) R += T * T * R / (1.f - R * R);
    return R;
  }
  LUZ_INLINE BsdfSample sample(Vec3 wo, float u1, Vec2, TransportMode = TransportMode::Radiance) const {
    BsdfSample s;
    if (wo.z == 0.f || !(wo.z == wo.z)) return s;
    float R = reflectance(wo.z);
    s.delta = true;
    s.valid = true;
    if (u1 < R) {
      s.wi = {-wo.x, -wo.y, wo.z};
      s.pdf = R;
      s.weight = specular_reflectance;
    } else {
      s.wi = -wo;
      s.pdf = 1.f - R;
      s.weight = specular_transmittance;
      s.transmission = true;
    }
    return s;
  }
};

// Rough dielectric, Walter et al. 2007 ("Microfacet Models for Refraction
// through Rough Surfaces", EGSR):
//   reflection (eq. 20):   f = F(wo·h) D(h) G2 / (4 |cos θo| |cos θi|),  h = ±(wo + wi)/|·|   (eq. 13)
//   refraction (eq. 21):   f = (1 - F) D G2 |wo·h| |wi·h| / (|cos θo| |cos θi| (wo·h + η wi·h)²)
//                          h = ±(wo + η wi)/|·|  (eq. 16), η = η_wi / η_wo,
// the radiance form; importance: × η². h is taken in the upper hemisphere.
// G2 is Smith's height-correlated term (Heitz 2014, eq. 99), which carries
// the side conditions χ⁺(wo·h / cos θo) χ⁺(wi·h / cos θi).
//
// Sampling: a visible normal m of the side wo is on (Heitz & d'Eon 2014 with
// the view -wo when wo is inside), then reflection with probability F(wo·m)
// and refraction otherwise (Walter et al.'s sampling section, with D_wo in
// place of D cos):
//   pdf_r = F D_wo(m) / (4 |wo·m|)  (eq. 14),
//   pdf_t = (1 - F) D_wo(m) η² |wi·m| / (wo·m + η wi·m)²  (eq. 17),
//   weight = G2 / G1(wo) (× 1/η² for radiance refraction).
// A reflected direction on the far side, or a refracted one on wo's side, is
// a failed sample.
struct RoughDielectricBsdf {
  static constexpr bool kDeltaOnly = false, kHasDelta = false, kTransmission = true;
  // The members textures can drive (material.h).
  LUZ_INLINE Color* color_param(BsdfParam p) {
    return p == BsdfParam::SpecularReflectance ? &specular_reflectance :
           p == BsdfParam::SpecularTransmittance ? &specular_transmittance : nullptr;
  }
  LUZ_INLINE float* float_param(BsdfParam p) {
    return p == BsdfParam::AlphaU ? &alpha_u :
           p == BsdfParam::AlphaV ? &alpha_v : nullptr;
  }
  MicrofacetType distribution = MicrofacetType::Beckmann;
  float alpha_u = 0.f, alpha_v = 0.f;
  float eta = 1.5046f;
  Color specular_reflectance, specular_transmittance;

  LUZ_INLINE MicrofacetDistribution dist() const {
    return MicrofacetDistribution::make(distribution, alpha_u, alpha_v);
  }

  // The half vector of (wo, wi) in the upper hemisphere, and η = η_wi/η_wo
  // (1 for reflection). False where it is undefined.
  LUZ_INLINE bool half_vector(Vec3 wo, Vec3 wi, Vec3& m, float& eta_p, bool& reflect) const {
    if (wo.z == 0.f || wi.z == 0.f) return false;
    reflect = wo.z * wi.z > 0.f;
    eta_p = reflect ? 1.f : (wo.z > 0.f ? eta : 1.f / eta);
    Vec3 h = wo + wi * eta_p;
    float l2 = dot(h, h);
    if (!(l2 > 0.f)) return false;
    m = h * (1.f / sqrtf(l2));
    if (m.z < 0.f) m = -m;
    if (m.z == 0.f) return false;
    // Side conditions (the χ⁺ of G2): h seen from the side each direction is on.
    return dot(wo, m) * wo.z > 0.f && dot(wi, m) * wi.z > 0.f;
  }

  // F at the facet m. For a refraction pair the two sides give the same F;
  // it is taken from the cosine on the less dense side (the outside where
  // η > 1), which is well conditioned (from the denser side near the
  // critical angle cos θt is the root of a cancellation), so f(wo, wi) and
  // f(wi, wo) agree in float too.
  LUZ_INLINE float fresnel(Vec3 wo, float wom, float wim, bool reflect) const {
    if (reflect || (eta >= 1.f) == (wo.z > 0.f)) return fresnel_dielectric(wom, eta).F;
    return fresnel_dielectric(wim, eta).F;
  }

  LUZ_INLINE Color f(Vec3 wo, Vec3 wi, TransportMode mode = TransportMode::Radiance) const {
    Vec3 m;
    float eta_p;
    bool reflect;
    if (!half_vector(wo, wi, m, eta_p, reflect)) return {};
    MicrofacetDistribution d = dist();
    float D = d.D(m);
    if (D == 0.f) return {};
    float G = d.G2(wo, wi, m);
    float wom = dot(wo, m), wim = dot(wi, m);
    float F = fresnel(wo, wom, wim, reflect);
    if (reflect) return specular_reflectance * (F * D * G / (4.f * fabsf(wo.z * wi.z)));
    float denom = wom + eta_p * wim;
    float v = (1.f - F) * D * G * fabsf(wom * wim) / (fabsf(wo.z * wi.z) * denom * denom);
    if (mode == TransportMode::Importance) v *= eta_p * eta_p;
    return specular_transmittance * v;
  }

  LUZ_INLINE float pdf(Vec3 wo, Vec3 wi) const {
    Vec3 m;
    float eta_p;
    bool reflect;
    if (!half_vector(wo, wi, m, eta_p, reflect)) return 0.f;
    MicrofacetDistribution d = dist();
    Vec3 wv = wo.z > 0.f ? wo : -wo;  // the view the normals were sampled for
    float pm = d.pdf_visible(wv, m);
    float wom = dot(wo, m), wim = dot(wi, m);
    float F = fresnel(wo, wom, wim, reflect);
    if (reflect) return F * pm / (4.f * fabsf(wom));
    float denom = wom + eta_p * wim;
    return (1.f - F) * pm * eta_p * eta_p * fabsf(wim) / (denom * denom);
  }

  LUZ_INLINE BsdfSample sample(Vec3 wo, float u1, Vec2 u2, TransportMode mode = TransportMode::Radiance) const {
    BsdfSample s;
    if (wo.z == 0.f || !(wo.z == wo.z)) return s;
    MicrofacetDistribution d = dist();
    Vec3 wv = wo.z > 0.f ? wo : -wo;
    Vec3 m = d.sample_visible(wv, u2);
    float pm = d.pdf_visible(wv, m);
    if (!(pm > 0.f)) return s;
    float wom = dot(wo, m);
    FresnelDielectric fr = fresnel_dielectric(wom, eta);
    float lo = d.lambda(wo);
    if (u1 < fr.F) {
      s.wi = reflect(wo, m);
      if (!(s.wi.z * wo.z > 0.f)) return s;
      s.pdf = fr.F * pm / (4.f * fabsf(wom));
      s.weight = specular_reflectance * ((1.f + lo) / (1.f + lo + d.lambda(s.wi)));
    } else {
      s.wi = normalize(refract(wo, m, fr.cos_t, fr.eta_ti));
      if (!(s.wi.z * wo.z < 0.f)) return s;
      float wim = dot(s.wi, m), eta_p = fr.eta_it;
      float denom = wom + eta_p * wim;
      s.pdf = (1.f - fr.F) * pm * eta_p * eta_p * fabsf(wim) / (denom * denom);
      s.weight = specular_transmittance * ((1.f + lo) / (1.f + lo + d.lambda(s.wi)));
      if (mode == TransportMode::Radiance) s.weight *= fr.eta_ti * fr.eta_ti;
      s.transmission = true;
      s.eta = eta_p;
    }
    if (!(s.pdf > 0.f)) return s;
    s.valid = true;
    return s;
  }
};

}  // namespace luz
