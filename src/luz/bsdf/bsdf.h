// BSDFs: small tagged structs, dispatched by a switch (no virtual calls), so
// the same code runs on the CPU and in CUDA kernels.
//
// Conventions: directions are unit vectors in the local shading frame (normal
// +z), both pointing away from the surface. `wo` points toward the viewer
// (where the path came from), `wi` toward where light arrives from (the
// sampled continuation). f() is the BSDF value itself, without the cosine.
#pragma once

#include "luz/math/vec.h"
#include "luz/sampling/warp.h"

namespace luz {

enum class BsdfType : uint32_t { Diffuse, Phong };

struct BsdfSample {
  Vec3 wi;
  Color weight;  // f(wo, wi) |cos θi| / pdf
  float pdf = 0.f;
  bool valid = false;
};

// Lambertian reflector: f = ρ/π.
struct DiffuseBsdf {
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

// The seed's modified Phong (Lewis 1994; Lafortune & Willems 1994), eq. (2.10):
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
struct PhongBsdf {
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
    if (s.wi.z <= 0.f) return s;  // specular lobe below the horizon
    s.pdf = pdf(wo, s.wi);
    if (!(s.pdf > 0.f)) return s;
    s.weight = f(wo, s.wi) * (s.wi.z / s.pdf);
    s.valid = true;
    return s;
  }
};

// The tagged BSDF. `two_sided` mirrors the local frame so the back face
// behaves like the front (Mitsuba's `twosided`); one-sided BSDFs are black
// from behind. Reflection only for now: wo and wi on the same side.
struct Bsdf {
  BsdfType type = BsdfType::Diffuse;
  bool two_sided = false;
  DiffuseBsdf diffuse;
  PhongBsdf phong;

  // Brings wo to the upper hemisphere; false if the surface is black from there.
  LUZ_INLINE bool orient(Vec3& wo, float& flip) const {
    flip = 1.f;
    if (wo.z < 0.f) {
      if (!two_sided) return false;
      flip = -1.f;
      wo.z = -wo.z;
    }
    return wo.z != 0.f;
  }

  LUZ_INLINE Color f(Vec3 wo, Vec3 wi) const {
    float flip;
    if (!orient(wo, flip)) return {};
    wi.z *= flip;
    if (wi.z <= 0.f) return {};
    switch (type) {
      case BsdfType::Phong: return phong.f(wo, wi);
      default: return diffuse.f(wo, wi);
    }
  }

  LUZ_INLINE float pdf(Vec3 wo, Vec3 wi) const {
    float flip;
    if (!orient(wo, flip)) return 0.f;
    wi.z *= flip;
    if (wi.z <= 0.f) return 0.f;
    switch (type) {
      case BsdfType::Phong: return phong.pdf(wo, wi);
      default: return diffuse.pdf(wo, wi);
    }
  }

  // u1 picks a lobe, u2 the direction within it.
  LUZ_INLINE BsdfSample sample(Vec3 wo, float u1, Vec2 u2) const {
    float flip;
    if (!orient(wo, flip)) return {};
    BsdfSample s;
    switch (type) {
      case BsdfType::Phong: s = phong.sample(wo, u1, u2); break;
      default: s = diffuse.sample(wo, u1, u2); break;
    }
    s.wi.z *= flip;
    return s;
  }

  LUZ_INLINE static Bsdf make_diffuse(Color r, bool two_sided = false) {
    Bsdf b;
    b.type = BsdfType::Diffuse;
    b.two_sided = two_sided;
    b.diffuse.reflectance = r;
    return b;
  }
  LUZ_INLINE static Bsdf make_phong(Color kd, Color ks, float n, bool two_sided = true) {
    Bsdf b;
    b.type = BsdfType::Phong;
    b.two_sided = two_sided;
    b.phong.kd = kd;
    b.phong.ks = ks;
    b.phong.exponent = n;
    return b;
  }
};

}  // namespace luz
