// glTF 2.0 metallic-roughness material: the reference BRDF of the glTF 2.0
// specification (Khronos, Appendix B "BRDF Implementation", §B.3), with
// KHR_materials_ior's dielectric F0:
//
//   specular_brdf(α) = D(h) V(wo, wi, h),  α = roughness²
//   D   GGX (Trowbridge-Reitz), isotropic (microfacet.h)
//   V   = G / (4 |n·wo| |n·wi|), G = G1(wo, h) G1(wi, h): the separable Smith
//       form the specification's equations give (§B.3.2), not the
//       height-correlated G2 of Luz's other microfacet models
//   w   = (1 - |wo·h|)⁵  (Schlick)
//   metal      = specular_brdf · (base + (1 - base) w)
//   dielectric = mix(base / π, specular_brdf, f0 + (1 - f0) w),
//                f0 = ((ior - 1) / (ior + 1))² (0.04 for ior 1.5, the core default)
//   f = mix(dielectric, metal, metallic)
//
// Reciprocal (|wo·h| = |wi·h|). Not energy conserving in general, as the
// specification says of its approximations: near grazing incidence the
// diffuse part is weighted by 1 - F at the half vectors of diffuse
// directions, while the specular part already took F at the grazing one
// (white dielectric: directional albedo > 1 past ~60°, tests/test_bsdf_models).
// KHR_materials_transmission is not modelled.
//
// Sampling: GGX visible normals from wo (wi = reflect(wo, m)) with
// probability P_s, cosine-weighted otherwise, P_s from a Schlick estimate at wo:
//   s = (1 - metallic) F(cos θo) + metallic,  d = (1 - metallic) (1 - F(cos θo)) mean(base),
//   P_s = max(s, 0.01) / (max(s, 0.01) + d)
// (P_s = 1 exactly when the diffuse lobe is zero, so pdf > 0 wherever f > 0).
// pdf() is the mixture's solid-angle density; sample() returns f cos / pdf.
//
// Scene-file names (glTF's): baseColorFactor/Texture -> base_color,
// metallicFactor (B channel) -> metallic, roughnessFactor (G channel) ->
// roughness. One-sided: the Bsdf wrapper handles doubleSided.
#pragma once

#include "luz/bsdf/common.h"
#include "luz/bsdf/microfacet.h"
#include "luz/sampling/warp.h"

namespace luz {

struct GltfPbrBsdf {
  static constexpr bool kDeltaOnly = false, kHasDelta = false, kTransmission = false;
  // The members textures can drive (material.h).
  LUZ_INLINE Color* color_param(BsdfParam p) { return p == BsdfParam::BaseColor ? &base_color : nullptr; }
  LUZ_INLINE float* float_param(BsdfParam p) {
    return p == BsdfParam::Metallic ? &metallic : p == BsdfParam::Roughness ? &roughness : nullptr;
  }
  // glTF's defaults.
  Color base_color{1.f, 1.f, 1.f};
  float metallic = 1.f, roughness = 1.f;
  float f0 = 0.04f;  // dielectric reflectance at normal incidence

  LUZ_INLINE static float ior_to_f0(float ior) {
    float r = (ior - 1.f) / (ior + 1.f);
    return r * r;
  }
  LUZ_INLINE static float schlick_weight(float c) {
    float x = 1.f - clamp(c, 0.f, 1.f), x2 = x * x;
    return x2 * x2 * x;
  }
  LUZ_INLINE float metal() const { return clamp(metallic, 0.f, 1.f); }
  LUZ_INLINE MicrofacetDistribution dist() const {
    float r = clamp(roughness, 0.f, 1.f);
    return MicrofacetDistribution::make(MicrofacetType::GGX, r * r, r * r);
  }

  LUZ_INLINE Color f(Vec3 wo, Vec3 wi) const {
    if (!(wo.z > 0.f) || !(wi.z > 0.f)) return {};
    const Vec3 h = normalize(wo + wi);
    const MicrofacetDistribution d = dist();
    const float spec = d.D(h) * d.G1(wo, h) * d.G1(wi, h) / (4.f * wo.z * wi.z);
    const float w = schlick_weight(fabsf(dot(wo, h))), m = metal();
    const float fd = f0 + (1.f - f0) * w;
    const Color one{1.f, 1.f, 1.f};
    const Color dielectric = base_color * ((1.f - fd) * kInvPi) + one * (fd * spec);
    const Color metal_f = (base_color + (one - base_color) * w) * spec;
    return dielectric * (1.f - m) + metal_f * m;
  }

  LUZ_INLINE float specular_probability(float cos_o) const {
    const float m = metal(), fd = f0 + (1.f - f0) * schlick_weight(cos_o);
    const float s = max((1.f - m) * fd + m, 0.01f);
    const float mean = (base_color.x + base_color.y + base_color.z) * (1.f / 3.f);
    const float d = (1.f - m) * (1.f - fd) * max(mean, 0.f);
    return s / (s + d);
  }
  LUZ_INLINE float pdf(Vec3 wo, Vec3 wi) const {
    if (!(wo.z > 0.f) || !(wi.z > 0.f)) return 0.f;
    const float ps = specular_probability(wo.z);
    const Vec3 h = normalize(wo + wi);
    const float woh = dot(wo, h);
    const float spec = woh > 0.f ? dist().pdf_visible(wo, h) / (4.f * woh) : 0.f;
    return ps * spec + (1.f - ps) * cosine_hemisphere_pdf(wi);
  }
  LUZ_INLINE BsdfSample sample(Vec3 wo, float u1, Vec2 u2) const {
    if (!(wo.z > 0.f)) return {};
    const float ps = specular_probability(wo.z);
    const MicrofacetDistribution d = dist();
    return sample_facet_or_cosine(*this, wo, u1 < ps, u2, [&](Vec2 u) { return d.sample_visible_ggx(wo, u); });
  }
};

}  // namespace luz
