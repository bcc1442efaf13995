// glTF 2.0 metallic-roughness material: the reference BRDF of the glTF 2.0
// specification (Khronos, Appendix B "BRDF Implementation", §B.3), with
// KHR_materials_ior's dielectric F0 and KHR_materials_specular's strength s
// and F0 colour c:
//
//   specular_brdf(α) = D(h) V(wo, wi, h),  α = roughness²
//   D   GGX (Trowbridge-Reitz), isotropic (microfacet.h)
//   V   = G / (4 |n·wo| |n·wi|), G = G1(wo, h) G1(wi, h): the separable Smith
//       form the specification's equations give (§B.3.2), not the
//       height-correlated G2 of Luz's other microfacet models
//   w   = (1 - |wo·h|)⁵  (Schlick)
//   metal      = specular_brdf · (base + (1 - base) w)
//   dielectric = F specular_brdf + (1 - max(F)) base / π,
//                F = F0 + (F90 - F0) w, F0 = min(f0 c, 1) s, F90 = s (per channel),
//                f0 = ((ior - 1) / (ior + 1))² (0.04 for ior 1.5, the core default);
//                c = 1, s = 1 (the core): F = f0 + (1 - f0) w, the mix of §B.3.5
//   f = mix(dielectric, metal, metallic)
//
// KHR_materials_clearcoat (clearcoat c, coat roughness r_c) layers a GGX
// reflection over all of it, as the extension's fresnel_coat:
//   f_coated = (1 - c F_c) f + c F_c D_c V_c,  F_c = 0.04 + 0.96 (1 - n·wo)⁵,
// D_c V_c the specular_brdf of α_c = r_c² (the coat's IOR is 1.5). F_c is
// taken at n·wo, not at the half vector, as the extension does for energy
// conservation: the coated f is not reciprocal (the path tracer evaluates
// it with wo towards the camera).
//
// Reciprocal (|wo·h| = |wi·h|). Not energy conserving in general, as the
// specification says of its approximations: near grazing incidence the
// diffuse part is weighted by 1 - F at the half vectors of diffuse
// directions, while the specular part already took F at the grazing one
// (white dielectric: directional albedo > 1 past ~60°, tests/test_bsdf_models).
//
// KHR_materials_transmission (GltfPbrTransmissionBsdf below): the
// extension's thin-walled model (no KHR_materials_volume: two surfaces back
// to back, no macroscopic refraction), the dielectric's base becoming
//   mix(base / π, specular_btdf · base, transmission),
//   specular_btdf(wo, wi) = specular_brdf(wo, wi mirrored through the surface),
// i.e. the extension's H_T = normalize(wo + wi - 2 (n·wi) n) with the same D
// and separable V; the Fresnel weight of a transmitted pair is taken at H_T.
// The sheet looks the same from either side, and with η = 1 on both sides
// it is reciprocal in both transport modes.
//
// KHR_materials_diffuse_transmission (factor d, colour c_d) splits the
// diffuse part that remains: base / π on wo's side times (1 - d), and
// c_d / π through the surface times d, i.e. the dielectric's base is
//   mix(mix(base / π, c_d / π across, d), specular_btdf · base, transmission),
// its Fresnel weight for a pair across taken at H_T as above.
//
// Sampling: GGX visible normals from wo (wi = reflect(wo, m)) with
// probability P_s, cosine-weighted otherwise, P_s from a Schlick estimate at wo:
//   s = (1 - metallic) F + metallic,  d = (1 - metallic) (1 - F) mean(base),  F = max(F(cos θo)),
//   P_s = max(s, 0.01) / (max(s, 0.01) + d)
// (P_s = 1 exactly when the diffuse lobe is zero, so pdf > 0 wherever f > 0).
// pdf() is the mixture's solid-angle density; sample() returns f cos / pdf.
// A coat is sampled first with probability c F_c (its visible normals),
// the rest as above.
//
// Scene-file names (glTF's): baseColorFactor/Texture -> base_color,
// diffuseTransmissionFactor/Texture (A) -> diffuse_transmission,
// diffuseTransmissionColorFactor/Texture -> diffuse_transmission_color,
// metallicFactor (B channel) -> metallic, roughnessFactor (G channel) ->
// roughness, specularFactor/Texture (A) -> specular_strength,
// specularColorFactor/Texture -> specular_color. One-sided: the Bsdf
// wrapper handles doubleSided.
#pragma once

#include "luz/bsdf/common.h"
#include "luz/bsdf/fresnel.h"
#include "luz/bsdf/microfacet.h"
#include "luz/sampling/warp.h"

namespace luz {

struct GltfPbrBsdf {
  static constexpr bool kDeltaOnly = false, kHasDelta = false, kTransmission = false;
  // The members textures can drive (material.h).
  LUZ_INLINE Color* color_param(BsdfParam p) {
    return p == BsdfParam::BaseColor ? &base_color : p == BsdfParam::SpecularColor ? &specular_color : nullptr;
  }
  LUZ_INLINE float* float_param(BsdfParam p) {
    return p == BsdfParam::Metallic ? &metallic : p == BsdfParam::Roughness ? &roughness
         : p == BsdfParam::Specular ? &specular_strength : p == BsdfParam::Clearcoat ? &clearcoat
         : p == BsdfParam::ClearcoatRoughness ? &clearcoat_roughness : nullptr;
  }
  // glTF's defaults.
  Color base_color{1.f, 1.f, 1.f};
  float metallic = 1.f, roughness = 1.f;
  float f0 = 0.04f;  // dielectric reflectance at normal incidence, from the IOR
  // KHR_materials_specular (1: the core material): the F0 colour (may
  // exceed 1; f0 times it is clamped to 1) and the strength in [0, 1].
  Color specular_color{1.f, 1.f, 1.f};
  float specular_strength = 1.f;
  // KHR_materials_clearcoat (0: none). Not on the transmitting sheet (the
  // loader leaves it out there).
  float clearcoat = 0.f, clearcoat_roughness = 0.f;

  LUZ_INLINE static float ior_to_f0(float ior) {
    float r = (ior - 1.f) / (ior + 1.f);
    return r * r;
  }
  LUZ_INLINE float metal() const { return clamp(metallic, 0.f, 1.f); }
  // The dielectric's Fresnel F = F0 + (F90 - F0) w at Schlick weight w.
  LUZ_INLINE Color dielectric_fresnel(float w) const {
    const float s = clamp(specular_strength, 0.f, 1.f);
    const Color c = vmax(specular_color, Color{});
    const Color f0c = Color{min(f0 * c.x, 1.f), min(f0 * c.y, 1.f), min(f0 * c.z, 1.f)} * s;
    return f0c + (Color{s, s, s} - f0c) * w;
  }
  LUZ_INLINE MicrofacetDistribution dist() const {
    float r = clamp(roughness, 0.f, 1.f);
    return MicrofacetDistribution::make(MicrofacetType::GGX, r * r, r * r);
  }

  // specular_brdf(wo, wi) = D V.
  LUZ_INLINE float specular(Vec3 wo, Vec3 wi, Vec3 h) const { return specular_brdf(dist(), wo, wi, h); }
  LUZ_INLINE static float specular_brdf(const MicrofacetDistribution& d, Vec3 wo, Vec3 wi, Vec3 h) {
    return d.D(h) * d.G1(wo, h) * d.G1(wi, h) / (4.f * wo.z * wi.z);
  }
  // The coat: its weight c F_c at wo (0 without one) and distribution.
  LUZ_INLINE float coat_weight(float cos_o) const {
    const float c = clamp(clearcoat, 0.f, 1.f);
    return c > 0.f ? c * (0.04f + 0.96f * schlick_weight(cos_o)) : 0.f;
  }
  LUZ_INLINE MicrofacetDistribution coat_dist() const {
    const float r = clamp(clearcoat_roughness, 0.f, 1.f);
    return MicrofacetDistribution::make(MicrofacetType::GGX, r * r, r * r);
  }
  LUZ_INLINE Color f(Vec3 wo, Vec3 wi) const {
    const Color base = reflection(wo, wi, 1.f);
    const float k = coat_weight(wo.z);
    if (!(k > 0.f) || !(wo.z > 0.f) || !(wi.z > 0.f)) return base;
    const float coat = specular_brdf(coat_dist(), wo, wi, normalize(wo + wi));
    return base * (1.f - k) + Color{coat, coat, coat} * k;
  }
  // f with the diffuse part scaled by `diffuse` (1 - transmission).
  LUZ_INLINE Color reflection(Vec3 wo, Vec3 wi, float diffuse) const {
    if (!(wo.z > 0.f) || !(wi.z > 0.f)) return {};
    const Vec3 h = normalize(wo + wi);
    const float spec = specular(wo, wi, h);
    const float w = schlick_weight(fabsf(dot(wo, h))), m = metal();
    const Color fd = dielectric_fresnel(w);
    const Color one{1.f, 1.f, 1.f};
    const Color dielectric = base_color * ((1.f - max_component(fd)) * diffuse * kInvPi) + fd * spec;
    const Color metal_f = (base_color + (one - base_color) * w) * spec;
    return dielectric * (1.f - m) + metal_f * m;
  }

  LUZ_INLINE float specular_probability(float cos_o) const {
    const float m = metal(), fd = max_component(dielectric_fresnel(schlick_weight(cos_o)));
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
    const float base = ps * spec + (1.f - ps) * cosine_hemisphere_pdf(wi);
    const float k = coat_weight(wo.z);
    if (!(k > 0.f)) return base;
    const float coat = woh > 0.f ? coat_dist().pdf_visible(wo, h) / (4.f * woh) : 0.f;
    return k * coat + (1.f - k) * base;
  }
  LUZ_INLINE BsdfSample sample(Vec3 wo, float u1, Vec2 u2) const {
    if (!(wo.z > 0.f)) return {};
    const float k = coat_weight(wo.z);
    if (k > 0.f) {
      if (u1 < k) {
        const MicrofacetDistribution c = coat_dist();
        return sample_facet_or_cosine(*this, wo, true, u2, [&](Vec2 u) { return c.sample_visible_ggx(wo, u); });
      }
      u1 = min((u1 - k) / (1.f - k), 0x1.fffffep-1f);
    }
    const float ps = specular_probability(wo.z);
    const MicrofacetDistribution d = dist();
    return sample_facet_or_cosine(*this, wo, u1 < ps, u2, [&](Vec2 u) { return d.sample_visible_ggx(wo, u); });
  }
};

// glTF metallic-roughness with KHR_materials_transmission (t) and
// KHR_materials_diffuse_transmission (d, c_d) (see the top): a thin sheet,
// the same from both sides. f for wi across the surface is
//   (1 - metallic) (1 - F(|wo·h_t|)) (t · base · specular_brdf(wo, w̄i) + (1 - t) d c_d / π),
// w̄i = wi mirrored through the surface, h_t = normalize(wo + w̄i); on wo's side
// it is GltfPbrBsdf's f with the diffuse part scaled by (1 - t)(1 - d).
// Sampling: the specular lobe with P_s as GltfPbrBsdf, else the base lobes in
// the ratio (1 - t)(1 - d) : t : (1 - t) d, the specular transmission as the
// specular lobe's sample mirrored, the diffuse ones cosine-weighted on
// either side.
struct GltfPbrTransmissionBsdf {
  static constexpr bool kDeltaOnly = false, kHasDelta = false, kTransmission = true;
  LUZ_INLINE Color* color_param(BsdfParam p) {
    return p == BsdfParam::DiffuseTransmissionColor ? &diffuse_transmission_color : surface.color_param(p);
  }
  LUZ_INLINE float* float_param(BsdfParam p) {
    return p == BsdfParam::Transmission ? &transmission
         : p == BsdfParam::DiffuseTransmission ? &diffuse_transmission : surface.float_param(p);
  }
  GltfPbrBsdf surface;
  float transmission = 0.f;
  float diffuse_transmission = 0.f;
  Color diffuse_transmission_color{1.f, 1.f, 1.f};

  LUZ_INLINE float share() const { return clamp(transmission, 0.f, 1.f); }
  LUZ_INLINE float diffuse_share() const { return clamp(diffuse_transmission, 0.f, 1.f); }
  LUZ_INLINE static Vec3 mirror(Vec3 w) { return {w.x, w.y, -w.z}; }

  // Both directions brought to the upper side (the sheet is symmetric).
  LUZ_INLINE static bool upper(Vec3& wo, Vec3& wi) {
    if (wo.z < 0.f) wo = mirror(wo), wi = mirror(wi);
    return wo.z > 0.f && wi.z != 0.f;
  }
  LUZ_INLINE Color f(Vec3 wo, Vec3 wi, TransportMode) const {
    if (!upper(wo, wi)) return {};
    const float t = share(), d = diffuse_share();
    if (wi.z > 0.f) return surface.reflection(wo, wi, (1.f - t) * (1.f - d));
    const Vec3 wm = mirror(wi);
    const Vec3 h = normalize(wo + wm);
    const float spec = t > 0.f ? surface.specular(wo, wm, h) : 0.f;
    const float fd = max_component(surface.dielectric_fresnel(schlick_weight(fabsf(dot(wo, h)))));
    const float w = (1.f - surface.metal()) * (1.f - fd);
    Color v = surface.base_color * (w * t * spec);
    if (d > 0.f) v += diffuse_transmission_color * (w * (1.f - t) * d * kInvPi);
    return v;
  }
  // Lobe probabilities at wo (upper side): specular, diffuse, specular
  // transmission, diffuse transmission.
  LUZ_INLINE void lobes(float cos_o, float& ps, float& pd, float& pt, float& pdt) const {
    ps = surface.specular_probability(cos_o);
    const float t = share(), d = diffuse_share();
    pd = (1.f - ps) * (1.f - t) * (1.f - d);
    pt = (1.f - ps) * t;
    pdt = (1.f - ps) * (1.f - t) * d;
  }
  LUZ_INLINE float pdf(Vec3 wo, Vec3 wi) const {
    if (!upper(wo, wi)) return 0.f;
    float ps, pd, pt, pdt;
    lobes(wo.z, ps, pd, pt, pdt);
    const bool across = wi.z < 0.f;
    const Vec3 wr = across ? mirror(wi) : wi;
    const Vec3 h = normalize(wo + wr);
    const float woh = dot(wo, h);
    const float spec = woh > 0.f ? surface.dist().pdf_visible(wo, h) / (4.f * woh) : 0.f;
    return (across ? pt : ps) * spec + (across ? pdt : pd) * cosine_hemisphere_pdf(wr);
  }
  LUZ_INLINE BsdfSample sample(Vec3 wo, float u1, Vec2 u2, TransportMode mode) const {
    BsdfSample s;
    const bool below = wo.z < 0.f;
    Vec3 w = below ? mirror(wo) : wo;
    if (!(w.z > 0.f)) return s;
    float ps, pd, pt, pdt;
    lobes(w.z, ps, pd, pt, pdt);
    if (u1 < ps + pt) {
      const Vec3 h = surface.dist().sample_visible_ggx(w, u2);
      if (!(dot(w, h) > 0.f)) return s;
      s.wi = reflect(w, h);
      if (!(s.wi.z > 0.f)) return s;
      if (u1 >= ps) s.wi = mirror(s.wi);
    } else {
      s.wi = square_to_cosine_hemisphere(u2);
      if (pdt > 0.f && u1 >= ps + pt + pd) s.wi = mirror(s.wi);
    }
    if (below) s.wi = mirror(s.wi);
    s.pdf = pdf(wo, s.wi);
    if (!(s.pdf > 0.f)) return s;
    s.weight = f(wo, s.wi, mode) * (fabsf(s.wi.z) / s.pdf);
    s.transmission = s.wi.z * wo.z < 0.f;
    s.valid = true;
    return s;
  }
};

}  // namespace luz
