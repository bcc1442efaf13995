// Pieces shared by every BSDF model: the parameter slot, the transport mode
// and the sample record. Conventions as in bsdf.h: local shading frame with
// the normal +z, wo toward the viewer, wi the sampled direction (toward where
// light comes from), f() without the cosine.
#pragma once

#include "luz/math/vec.h"
#include "luz/sampling/warp.h"

namespace luz {

// The parameters a texture can drive (material/material.h binds textures to
// them by these names). Each model answers which of its members a name
// means: Color* color_param(BsdfParam) and float* float_param(BsdfParam),
// null for a name it does not have or that cannot vary over the surface.
enum class BsdfParam : uint8_t {
  Reflectance,
  DiffuseReflectance,
  SpecularReflectance,
  SpecularTransmittance,
  Eta,
  K,
  AlphaU,
  AlphaV,
  Exponent,
  BaseColor,  // glTF metallic-roughness (gltf_pbr.h)
  Metallic,
  Roughness,
  Transmission,   // KHR_materials_transmission
  Specular,       // KHR_materials_specular: the strength
  SpecularColor,  // and the F0 colour
  Clearcoat,      // KHR_materials_clearcoat: the coat's weight (also principled's)
  ClearcoatRoughness,
  Anisotropic,  // Mitsuba 3's principled (principled.h); its spec_trans is Transmission
  SpecularTint,
  Sheen,
  SheenTint,
  Flatness,
  ClearcoatGloss,
  Transmittance,  // pbrt-v4's diffusetransmission
  DiffuseTransmission,  // KHR_materials_diffuse_transmission: the factor
  DiffuseTransmissionColor,
};

// What is transported along the path: radiance (camera paths, the path
// tracer) or importance (light paths). The two differ only for refraction:
// radiance BTDFs carry the 1/η² solid-angle compression (Veach 1997, §5.2),
// importance BTDFs do not.
enum class TransportMode : uint32_t { Radiance, Importance };

struct BsdfSample {
  Vec3 wi;
  Color weight;  // f(wo, wi) |cos θi| / pdf; for a delta lobe, its amplitude / its probability
  float pdf = 0.f;  // solid-angle density; for a delta lobe the discrete probability of choosing it
  bool valid = false;
  // A delta (specular) lobe: wi is one exact direction. f() and pdf() never
  // include it; an emitter hit through it takes MIS weight 1 (no light
  // sample could have found it).
  bool delta = false;
  // wi lies on the other side of the surface than wo (refraction, or a thin
  // sheet passing light straight through): the continuation must start on
  // the far side of the geometric surface.
  bool transmission = false;
  // η on wi's side / η on wo's side (1 for reflection and thin sheets). In
  // radiance mode `weight` already includes the 1/η² factor; a path that wants
  // Russian roulette on the radiance-independent throughput multiplies by η².
  float eta = 1.f;
};

// The common ending of sampling a non-delta reflection mixture: once s.wi
// is chosen by one lobe, the sample's density is the whole mixture's pdf()
// and its weight f·cos/pdf; a direction below the horizon is a failed sample.
template <class Model>
LUZ_INLINE BsdfSample finish_reflection_sample(const Model& m, Vec3 wo, BsdfSample s) {
  if (!(s.wi.z > 0.f)) return s;
  s.pdf = m.pdf(wo, s.wi);
  if (!(s.pdf > 0.f)) return s;
  s.weight = m.f(wo, s.wi) * (s.wi.z / s.pdf);
  s.valid = true;
  return s;
}

// Sampling a "glossy facet lobe or Lambertian" mixture (wo above the
// surface): the facet normal h from sample_facet(u2), wi = reflect(wo, h) (h
// facing away from wo is a failed sample), or wi cosine-weighted; then as
// finish_reflection_sample.
template <class Model, class FacetSampler>
LUZ_INLINE BsdfSample sample_facet_or_cosine(const Model& m, Vec3 wo, bool facet, Vec2 u2,
                                             FacetSampler sample_facet) {
  BsdfSample s;
  if (facet) {
    Vec3 h = sample_facet(u2);
    if (!(dot(wo, h) > 0.f)) return s;
    s.wi = reflect(wo, h);
  } else {
    s.wi = square_to_cosine_hemisphere(u2);
  }
  return finish_reflection_sample(m, wo, s);
}

}  // namespace luz
