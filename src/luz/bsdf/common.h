// Pieces shared by every BSDF model: the parameter slot, the transport mode
// and the sample record. Conventions as in bsdf.h: local shading frame with
// the normal +z, wo toward the viewer, wi the sampled direction (toward where
// light comes from), f() without the cosine.
#pragma once

#include "luz/math/vec.h"

namespace luz {

// A texture-or-constant slot. Constants only for now: a later textures issue
// adds a texture id (and eval() takes the shading point's uv); every model
// already reads its parameters through eval(), so only this struct changes.
struct Param {
  Color value;
  LUZ_INLINE Color eval() const { return value; }
};
struct ScalarParam {
  float value = 0.f;
  LUZ_INLINE float eval() const { return value; }
};
LUZ_INLINE Param param(Color c) { return Param{c}; }
LUZ_INLINE Param param(float v) { return Param{{v, v, v}}; }
LUZ_INLINE ScalarParam scalar_param(float v) { return ScalarParam{v}; }

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

}  // namespace luz
