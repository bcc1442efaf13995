// Mitsuba 3's `principled` BSDF (src/bsdfs/principled.cpp, principledhelpers.h),
// Burley's Disney BSDF ("Physically Based Shading at Disney", 2012; "Extending
// the Disney BRDF to a BSDF with Integrated Subsurface Scattering", 2015) as
// Mitsuba 3 writes it, so that its scenes render as there. With v = wo (toward
// the viewer), l = wi, m = metallic, t = spec_trans, brdf = (1-m)(1-t),
// bsdf = (1-m) t, and f without the cosine:
//
//   main lobe   GGX of (αx, αy) = max(0.001, r²/a, r² a), a = √(1 - 0.9 anisotropic),
//               separable G = G1(v,h) G1(l,h); h the reflection or refraction
//               half vector, F the exact dielectric Fresnel at v·h and η
//   reflection  F_p D G / (4 |v.z| |l.z|), on the front
//               F_p = (1-m)(1-tint) F + m S(base) + (1-m) tint S(c_tint R0(η)),
//               S(R0) = R0 + (1-R0)(1-c)⁵ (Schlick; c = |v·h| for η > 1, else the
//               refracted cosine), c_tint = base / luminance(base); behind,
//               bsdf · F; none where F = 0 (Mitsuba's mask: η = 1 leaves no
//               main reflection, even for metals)
//   refraction  √base · bsdf · (1-F) D G η² |v·h||l·h| / (|v.z||l.z| (v·h + η l·h)²),
//               η = η_l / η_v, × 1/η² in radiance mode (Walter et al. 2007)
//   clear coat  0.25 clearcoat S(0.04) D_c(h) G_c, front reflection only: D_c
//               GTR1 of α = lerp(0.1, 0.001, clearcoat_gloss), G_c separable GGX of
//               α = 0.25; without the 1/(4 |v.z| |l.z|) of the main lobe, as
//               Mitsuba 3 writes it
//   diffuse     brdf · base/π · lerp(f_d + f_r, f_ss, flatness), front only:
//               f_d = (1 - F_v/2)(1 - F_l/2), F_x = (1 - |x.z|)⁵,
//               R = 2 roughness (h·l)², f_r = R (F_l + F_v + F_l F_v (R - 1)),
//               f_ss = 1.25 (F_ss (1/(|v.z| + |l.z|) - 0.5) + 0.5),
//               F_ss = lerp(1, R/2, F_l) lerp(1, R/2, F_v)
//   sheen       sheen (1-m) (1 - h·l)⁵ lerp(1, c_tint, sheen_tint), front only
//               (as Mitsuba's vector variants: also where brdf = 0)
//
// (Mitsuba's thin variant, `principledthin`, is PrincipledThinBsdf below.)
//
// "Front" is v.z > 0. Without spec_trans (PrincipledBsdf) the model is
// reflection only and black from behind (Mitsuba's `twosided` mirrors it, as
// for every reflection model); with it (PrincipledTransmissionBsdf) the back
// is the inside of a dielectric: reflection bsdf F and refraction as above.
// Reciprocal on each side (the refraction in the generalised η² form); not
// energy conserving (the diffuse, sheen and coat add to the reflection).
//
// Sampling, as Mitsuba 3: on the front, diffuse (cosine), coat (GTR1 normals)
// and main lobe (GGX visible normals) with weights brdf·diffuse_rate,
// 0.25 clearcoat·clearcoat_rate and spec_rate; the main lobe refracts with
// probability bsdf (1 - F) at the sampled normal; behind, reflection F,
// refraction 1 - F. pdf() is that mixture's density; samples weigh f·|cos|/pdf.
#pragma once

#include "luz/bsdf/common.h"
#include "luz/bsdf/fresnel.h"
#include "luz/bsdf/microfacet.h"
#include "luz/sampling/warp.h"

namespace luz {

// The parameters (Mitsuba 3's names and defaults; eta from specular 0.5).
struct PrincipledParams {
  Color base_color{.5f, .5f, .5f};
  float roughness = .5f, anisotropic = 0.f, metallic = 0.f, spec_trans = 0.f, spec_tint = 0.f, sheen = 0.f,
        sheen_tint = 0.f, flatness = 0.f, clearcoat = 0.f, clearcoat_gloss = 0.f;
  float eta = 1.5f;  // interior / exterior
  float spec_rate = 1.f, clearcoat_rate = 1.f, diffuse_rate = 1.f;  // sampling weights (positive)

  // η from Mitsuba 3's `specular`: 2 / (1 - √(0.08 specular)) - 1 (1.5 at the default 0.5).
  LUZ_INLINE static float specular_to_eta(float specular) { return 2.f / (1.f - sqrtf(0.08f * specular)) - 1.f; }

  // What principled and principledthin share.
  // Mitsuba's calc_dist_params: GGX of (r²/a, r² a), a = √(1 - 0.9 anisotropic), at least 0.001.
  LUZ_INLINE static MicrofacetDistribution ggx(float rough, float aniso) {
    const float r2 = rough * rough, a = sqrtf(max(1.f - 0.9f * aniso, 0.f));
    return MicrofacetDistribution::make(MicrofacetType::GGX, max(0.001f, r2 / a), max(0.001f, r2 * a));
  }
  LUZ_INLINE MicrofacetDistribution dist() const { return ggx(roughness, anisotropic); }
  // Mitsuba's calc_schlick: R0 + (1 - R0) w, w at |cos_i| where light enters
  // the denser side (η_it > 1), else at the refracted cosine (1 on TIR).
  LUZ_INLINE float schlick_w(float cos_i) const {
    const float eta_it = cos_i >= 0.f ? eta : 1.f / eta;
    if (eta_it > 1.f) return schlick_weight(fabsf(cos_i));
    const float inv = 1.f / eta_it;
    return schlick_weight(safe_sqrt(1.f - (1.f - cos_i * cos_i) * inv * inv));
  }
  // base / luminance(base) (Mitsuba's weights of linear sRGB), or 1 for a
  // black base (Mitsuba's c_tint = 1 there).
  LUZ_INLINE Color tint_color() const {
    const float lum = 0.212671f * base_color.x + 0.715160f * base_color.y + 0.072169f * base_color.z;
    return lum > 0.f ? base_color / lum : Color{1.f, 1.f, 1.f};
  }
  // The spec_tint part of both Fresnel terms: Schlick's of R0 = c_tint
  // R0(η_it) at cos_i, its weight w = schlick_w(cos_i) given.
  LUZ_INLINE Color tinted_schlick(float cos_i, float w) const {
    const float eta_it = cos_i >= 0.f ? eta : 1.f / eta, r = (eta_it - 1.f) / (eta_it + 1.f);
    const Color tinted = tint_color() * (r * r);
    return tinted + (Color{1.f, 1.f, 1.f} - tinted) * w;
  }
  // The diffuse reflection (retro-reflection, flatness) and the sheen, for
  // |v.z|, |l.z| and h·l, weighted wd and ws:
  //   wd base/π · lerp(f_d + f_r, f_ss, flatness) + ws sheen (1 - h·l)⁵ lerp(1, c_tint, sheen_tint).
  LUZ_INLINE Color diffuse_and_sheen(float vz, float lz, float hl, float wd, float ws) const {
    Color value{};
    const float Fl = schlick_weight(lz), Fv = schlick_weight(vz);
    if (wd > 0.f) {
      const float fd = (1.f - 0.5f * Fv) * (1.f - 0.5f * Fl);
      const float R = 2.f * roughness * hl * hl, fr = R * (Fl + Fv + Fl * Fv * (R - 1.f));
      float shape = fd + fr;
      if (flatness != 0.f) {
        const float ss90 = 0.5f * R;
        const float Fss = (1.f + (ss90 - 1.f) * Fl) * (1.f + (ss90 - 1.f) * Fv);
        const float fss = 1.25f * (Fss * (1.f / (vz + lz) - 0.5f) + 0.5f);
        shape += (fss - shape) * flatness;
      }
      value = base_color * (wd * kInvPi * shape);
    }
    if (sheen > 0.f && ws > 0.f) {
      const Color one{1.f, 1.f, 1.f};
      const Color c = sheen_tint != 0.f ? one + (tint_color() - one) * sheen_tint : one;
      value += c * (ws * sheen * schlick_weight(fabsf(hl)));
    }
    return value;
  }
};

template <bool kSpecTrans>
struct PrincipledModel : PrincipledParams {
  static constexpr bool kDeltaOnly = false, kHasDelta = false, kTransmission = kSpecTrans;
  // The members textures can drive (material.h); spec_trans only where the
  // material transmits.
  LUZ_INLINE Color* color_param(BsdfParam p) { return p == BsdfParam::BaseColor ? &base_color : nullptr; }
  LUZ_INLINE float* float_param(BsdfParam p) {
    switch (p) {
      case BsdfParam::Roughness: return &roughness;
      case BsdfParam::Anisotropic: return &anisotropic;
      case BsdfParam::Metallic: return &metallic;
      case BsdfParam::Transmission: return kSpecTrans ? &spec_trans : nullptr;
      case BsdfParam::SpecularTint: return &spec_tint;
      case BsdfParam::Sheen: return &sheen;
      case BsdfParam::SheenTint: return &sheen_tint;
      case BsdfParam::Flatness: return &flatness;
      case BsdfParam::Clearcoat: return &clearcoat;
      case BsdfParam::ClearcoatGloss: return &clearcoat_gloss;
      default: return nullptr;
    }
  }
  LUZ_INLINE float metal() const { return clamp(metallic, 0.f, 1.f); }
  LUZ_INLINE float trans() const { return kSpecTrans ? clamp(spec_trans, 0.f, 1.f) : 0.f; }
  LUZ_INLINE float brdf_weight() const { return (1.f - metal()) * (1.f - trans()); }
  LUZ_INLINE float bsdf_weight() const { return (1.f - metal()) * trans(); }

  LUZ_INLINE float coat_alpha() const { return 0.1f + (0.001f - 0.1f) * clearcoat_gloss; }

  // F_p on the front, at v·h = cos_i (> 0 there).
  LUZ_INLINE Color front_fresnel(float F, float cos_i) const {
    const float m = metal(), w = schlick_w(cos_i), tint = spec_tint;
    const Color one{1.f, 1.f, 1.f};
    Color Fp = one * ((1.f - m) * (1.f - tint) * F) + (base_color + (one - base_color) * w) * m;
    if (tint != 0.f) Fp += tinted_schlick(cos_i, w) * ((1.f - m) * tint);
    return Fp;
  }

  // GTR1 (Burley 2012, App. B): D(h) = (α² - 1) / (π ln α² (1 + (α² - 1) cos²θh)),
  // the denominator's 1 + (α² - 1) cos² as sin² + α² cos² (no cancellation
  // near the normal, where a glossy coat peaks).
  LUZ_INLINE static float gtr1(Vec3 h, float alpha) {
    const float a2 = alpha * alpha;
    const float d = (a2 - 1.f) / (kPi * logf(a2) * (h.x * h.x + h.y * h.y + a2 * h.z * h.z));
    return d * h.z > 1e-20f ? d : 0.f;
  }
  LUZ_INLINE static Vec3 sample_gtr1(Vec2 u, float alpha) {
    const float a2 = alpha * alpha, phi = 2.f * kPi * u.x;
    const float cos2 = (1.f - powf(a2, 1.f - u.y)) / (1.f - a2);
    const float sin_t = safe_sqrt(1.f - cos2), cos_t = safe_sqrt(cos2);
    return {cosf(phi) * sin_t, sinf(phi) * sin_t, cos_t};
  }

  // What f and pdf share for a pair: the half vector h (upper hemisphere),
  // η = η_l / η_v, whether l is reflected, and Mitsuba's side conditions.
  struct Pair {
    Vec3 h;
    float eta_p = 1.f;
    bool reflect = false, front = false, facing = false;
  };
  LUZ_INLINE bool pair(Vec3 v, Vec3 l, Pair& p) const {
    if (v.z == 0.f || l.z == 0.f) return false;
    p.front = v.z > 0.f;
    p.reflect = v.z * l.z > 0.f;
    if (!kSpecTrans && !(p.front && p.reflect)) return false;
    p.eta_p = p.reflect ? 1.f : (p.front ? eta : 1.f / eta);
    const Vec3 h = v + l * p.eta_p;
    const float l2 = dot(h, h);
    if (!(l2 > 0.f)) return false;
    p.h = h * (1.f / sqrtf(l2));
    if (p.h.z < 0.f) p.h = -p.h;
    // h seen from v's side by v, and from l's side by l (Mitsuba's mac_mic_compatibility).
    const float s = p.front ? 1.f : -1.f;
    p.facing = dot(v, p.h) * s > 0.f && dot(l, p.h) * (p.reflect ? s : -s) > 0.f;
    return true;
  }
  // F at the pair's facet; for refraction from the cosine on the less dense
  // side (from the denser one, near the critical angle, cos θt is the root
  // of a cancellation), so that f(v, l) and f(l, v) also agree in float.
  LUZ_INLINE float pair_fresnel(Vec3 v, Vec3 l, const Pair& p) const {
    const Vec3 w = p.reflect || (eta >= 1.f) == p.front ? v : l;
    return fresnel_dielectric(dot(w, p.h), eta).F;
  }

  LUZ_INLINE Color f(Vec3 v, Vec3 l, TransportMode mode = TransportMode::Radiance) const {
    Pair p;
    if (!pair(v, l, p)) return {};
    const float bsdf = bsdf_weight();
    if (!p.front && !(bsdf > 0.f)) return {};
    const MicrofacetDistribution d = dist();
    const float F = pair_fresnel(v, l, p);
    const float vz = fabsf(v.z), lz = fabsf(l.z);
    Color value{};
    if (p.facing) {
      const float DG = d.D(p.h) * d.G1(v, p.h) * d.G1(l, p.h);
      if (p.reflect && F > 0.f) {
        const Color Fp = p.front ? front_fresnel(F, dot(v, p.h)) : Color{1.f, 1.f, 1.f} * (bsdf * F);
        value += Fp * (DG / (4.f * vz * lz));
      }
      if (!p.reflect && bsdf > 0.f && F < 1.f) {
        const float vh = dot(v, p.h), lh = dot(l, p.h), denom = vh + p.eta_p * lh;
        float t = bsdf * (1.f - F) * DG * p.eta_p * p.eta_p * fabsf(vh * lh) / (vz * lz * denom * denom);
        if (mode == TransportMode::Radiance) t /= p.eta_p * p.eta_p;
        value += Color{sqrtf(max(base_color.x, 0.f)), sqrtf(max(base_color.y, 0.f)), sqrtf(max(base_color.z, 0.f))} * t;
      }
      if (p.reflect && p.front && clearcoat > 0.f) {
        const MicrofacetDistribution c = MicrofacetDistribution::make(MicrofacetType::GGX, .25f, .25f);
        const float w = schlick_w(dot(v, p.h)), Fc = 0.04f + 0.96f * w;
        value += Color{1.f, 1.f, 1.f} *
                 (0.25f * clearcoat * Fc * gtr1(p.h, coat_alpha()) * c.G1(v, p.h) * c.G1(l, p.h));
      }
    }
    // The diffuse part weighs brdf, the sheen 1 - metallic (also where brdf = 0).
    if (p.reflect && p.front) value += diffuse_and_sheen(vz, lz, dot(p.h, l), brdf_weight(), 1.f - metal());
    return value;
  }

  // Lobe weights, normalised: diffuse, coat, main (front); behind, all main.
  LUZ_INLINE void lobes(bool front, float& pd, float& pc, float& ps) const {
    if (!front) {
      pd = pc = 0.f, ps = 1.f;
      return;
    }
    pd = brdf_weight() * diffuse_rate;
    pc = 0.25f * max(clearcoat, 0.f) * clearcoat_rate;
    ps = spec_rate;
    const float inv = 1.f / (pd + pc + ps);
    pd *= inv, pc *= inv, ps *= inv;
  }
  // The main lobe's share that refracts, at a facet of Fresnel F.
  LUZ_INLINE float refract_share(bool front, float F) const {
    if (!kSpecTrans) return 0.f;
    return front ? bsdf_weight() * (1.f - F) : 1.f - F;
  }

  LUZ_INLINE float pdf(Vec3 v, Vec3 l) const {
    Pair p;
    if (!pair(v, l, p)) return 0.f;
    if (!p.front && !(bsdf_weight() > 0.f)) return 0.f;
    float pd, pc, ps;
    lobes(p.front, pd, pc, ps);
    float pdf = p.reflect ? pd * cosine_hemisphere_pdf(l) : 0.f;
    if (!p.facing) return pdf;
    const Vec3 vu = p.front ? v : -v;  // the view the normals were sampled for
    const float lh = dot(l, p.h);
    const float denom = dot(v, p.h) + p.eta_p * lh;  // dh/dl: reflection, refraction
    const float dwh = p.reflect ? 1.f / (4.f * fabsf(lh)) : p.eta_p * p.eta_p * fabsf(lh) / (denom * denom);
    const float t = refract_share(p.front, pair_fresnel(v, l, p));
    pdf += ps * (p.reflect ? 1.f - t : t) * dist().pdf_visible(vu, p.h) * dwh;
    if (p.reflect && pc > 0.f) pdf += pc * gtr1(p.h, coat_alpha()) * p.h.z * dwh;
    return pdf;
  }

  LUZ_INLINE BsdfSample sample(Vec3 v, float u1, Vec2 u2, TransportMode mode = TransportMode::Radiance) const {
    BsdfSample s;
    if (v.z == 0.f || !(v.z == v.z)) return s;
    const bool front = v.z > 0.f;
    if (!front && !(kSpecTrans && bsdf_weight() > 0.f)) return s;
    float pd, pc, ps;
    lobes(front, pd, pc, ps);
    if (u1 < pd) {
      s.wi = square_to_cosine_hemisphere(u2);
    } else if (u1 < pd + pc) {
      const Vec3 m = sample_gtr1(u2, coat_alpha());
      if (!(dot(v, m) > 0.f)) return s;
      s.wi = reflect(v, m);
    } else {
      const Vec3 vu = front ? v : -v;
      const Vec3 m = dist().sample_visible_ggx(vu, u2);
      const float vm = dot(v, m);
      if (!(vm * v.z > 0.f)) return s;
      const FresnelDielectric fr = fresnel_dielectric(vm, eta);
      const float u = min((u1 - pd - pc) / ps, kOneMinusEpsilon);
      if (u < refract_share(front, fr.F)) {
        s.wi = normalize(refract(v, m, fr.cos_t, fr.eta_ti));
        s.transmission = true;
        s.eta = fr.eta_it;
      } else {
        s.wi = reflect(v, m);
      }
    }
    if (!(s.transmission ? s.wi.z * v.z < 0.f : s.wi.z * v.z > 0.f)) return BsdfSample{};
    s.pdf = pdf(v, s.wi);
    if (!(s.pdf > 0.f)) return BsdfSample{};
    s.weight = f(v, s.wi, mode) * (fabsf(s.wi.z) / s.pdf);
    s.valid = true;
    return s;
  }
};

using PrincipledBsdf = PrincipledModel<false>;
using PrincipledTransmissionBsdf = PrincipledModel<true>;

// Mitsuba 3's `principledthin` (src/bsdfs/principledthin.cpp): a thin sheet
// (leaves, paper, cloth, soap film), the same from both sides (Mitsuba
// mirrors wo and wi to the front: wo.z > 0 below), no metal, no coat. With
// s = spec_trans, d = diff_trans / 2 (Mitsuba's diff_trans lies in [0, 2]),
// h = normalize(wo + w̄i), w̄i = wi mirrored to wo's side, and f without the
// cosine:
//   reflection     s F_thin D G / (4 |wo.z| |wi.z|)   (only where s > 0)
//                  F_thin = (1 - tint) F + tint S(c_tint R0(η)), F the exact
//                  dielectric Fresnel at wo·h and η (`eta`, a texture too)
//   transmission   s base (1 - F) D_t G_t / (4 |wo.z| |wi.z|) across, D_t, G_t
//                  of the roughness scaled by 0.65 η - 0.35 (Burley 2015, Fig. 15)
//                  at the mirrored direction (no refraction of the ray)
//   diffuse        (1 - s)(1 - d) (base/π · lerp(f_d + f_r, f_ss, flatness) + sheen),
//                  principled's terms (above)
//   diffuse transmission  (1 - s) d base / π across.
// Sampling, as Mitsuba: the four lobes with weights s·rate/2, s·rate/2,
// (1 - s)(1 - d)·rate, (1 - s) d·rate (the four sampling rates).
// Reciprocal on each side. Across, Mitsuba masks the specular transmission
// by the facet as the transmitted direction itself sees it (wi·h < 0, with
// G1(wi, h)): near grazing that passes one way only, so f(wo, wi) and
// f(wi, wo) differ there (a fifth of the transmitted energy at roughness 1);
// Luz keeps Mitsuba's mask, for Mitsuba's image.
struct PrincipledThinBsdf : PrincipledParams {
  static constexpr bool kDeltaOnly = false, kHasDelta = false, kTransmission = true;
  // The members textures can drive (material.h).
  LUZ_INLINE Color* color_param(BsdfParam p) { return p == BsdfParam::BaseColor ? &base_color : nullptr; }
  LUZ_INLINE float* float_param(BsdfParam p) {
    switch (p) {
      case BsdfParam::Roughness: return &roughness;
      case BsdfParam::Anisotropic: return &anisotropic;
      case BsdfParam::Transmission: return &spec_trans;
      case BsdfParam::SpecularTint: return &spec_tint;
      case BsdfParam::Sheen: return &sheen;
      case BsdfParam::SheenTint: return &sheen_tint;
      case BsdfParam::Flatness: return &flatness;
      case BsdfParam::Eta: return &eta;
      case BsdfParam::DiffuseTransmission: return &diff_trans;
      default: return nullptr;
    }
  }
  float diff_trans = 0.f;  // Mitsuba's, in [0, 2]
  // Sampling weights beside spec_rate (specular reflection) and diffuse_rate.
  float spec_trans_rate = 1.f, diff_trans_rate = 1.f;

  LUZ_INLINE float st() const { return clamp(spec_trans, 0.f, 1.f); }
  LUZ_INLINE float dt() const { return clamp(0.5f * diff_trans, 0.f, 1.f); }
  LUZ_INLINE MicrofacetDistribution trans_dist() const { return ggx((0.65f * eta - 0.35f) * roughness, anisotropic); }

  // wo brought to the front, wi with it (the sheet is symmetric).
  LUZ_INLINE static bool front(Vec3& v, Vec3& l) {
    if (v.z < 0.f) v = -v, l = -l;
    return v.z > 0.f && l.z != 0.f;
  }
  // Lobe probabilities: specular reflection, specular transmission, diffuse
  // reflection, diffuse transmission.
  LUZ_INLINE void lobes(float& psr, float& pst, float& pdr, float& pdt) const {
    const float s = st(), d = dt();
    psr = s * spec_rate * 0.5f;
    pst = s * spec_trans_rate * 0.5f;
    pdr = diffuse_rate * (1.f - s) * (1.f - d);
    pdt = diff_trans_rate * (1.f - s) * d;
    const float total = psr + pst + pdr + pdt;
    const float inv = total > 0.f ? 1.f / total : 0.f;
    psr *= inv, pst *= inv, pdr *= inv, pdt *= inv;
  }

  LUZ_INLINE Color f(Vec3 v, Vec3 l, TransportMode = TransportMode::Radiance) const {
    if (!front(v, l)) return {};
    const bool reflect = l.z > 0.f;
    const Vec3 lr{l.x, l.y, fabsf(l.z)};
    const Vec3 h = normalize(v + lr);
    const float s = st(), d = dt(), vz = v.z, lz = fabsf(l.z), vh = dot(v, h), lh = dot(l, h);
    Color value{};
    if (s > 0.f && vh > 0.f) {
      const float F = fresnel_dielectric(vh, eta).F;
      if (reflect && lh > 0.f) {
        const MicrofacetDistribution m = dist();
        const float DG = m.D(h) * m.G1(v, h) * m.G1(l, h) / (4.f * vz * lz);
        Color Ft = Color{1.f, 1.f, 1.f} * ((1.f - spec_tint) * F);
        if (spec_tint != 0.f) Ft += tinted_schlick(vh, schlick_w(vh)) * spec_tint;
        value += Ft * (s * DG);
      }
      if (!reflect && lh < 0.f) {
        const MicrofacetDistribution m = trans_dist();
        value += base_color * (s * (1.f - F) * m.D(h) * m.G1(v, h) * m.G1(l, h) / (4.f * vz * lz));
      }
    }
    if (reflect && s < 1.f && d < 1.f) value += diffuse_and_sheen(vz, lz, lh, (1.f - s) * (1.f - d), (1.f - s) * (1.f - d));
    if (!reflect && s < 1.f && d > 0.f) value += base_color * ((1.f - s) * d * kInvPi);
    return value;
  }

  LUZ_INLINE float pdf(Vec3 v, Vec3 l) const {
    if (!front(v, l)) return 0.f;
    float psr, pst, pdr, pdt;
    lobes(psr, pst, pdr, pdt);
    const bool reflect = l.z > 0.f;
    float pdf = (reflect ? pdr : pdt) * fabsf(l.z) * kInvPi;
    if (psr + pst > 0.f) {
      const Vec3 lr{l.x, l.y, fabsf(l.z)};
      const Vec3 h = normalize(v + lr);
      const float lh = dot(l, h), dwh = 1.f / (4.f * fabsf(dot(lr, h)));
      if (dot(v, h) > 0.f && (reflect ? lh > 0.f : lh < 0.f))
        pdf += (reflect ? psr * dist().pdf_visible(v, h) : pst * trans_dist().pdf_visible(v, h)) * dwh;
    }
    return pdf;
  }

  LUZ_INLINE BsdfSample sample(Vec3 wo, float u1, Vec2 u2, TransportMode mode = TransportMode::Radiance) const {
    BsdfSample s;
    if (wo.z == 0.f || !(wo.z == wo.z)) return s;
    const float side = wo.z > 0.f ? 1.f : -1.f;
    const Vec3 v = wo * side;
    float psr, pst, pdr, pdt;
    lobes(psr, pst, pdr, pdt);
    Vec3 l;
    if (u1 < psr + pst) {
      const Vec3 m = (u1 < psr ? dist() : trans_dist()).sample_visible_ggx(v, u2);
      if (!(dot(v, m) > 0.f)) return s;
      l = reflect(v, m);
      if (!(l.z > 0.f)) return s;
      if (u1 >= psr) {  // through the sheet, unbent, where the facet faces away from it
        l.z = -l.z;
        if (!(dot(l, m) < 0.f)) return s;
      }
    } else {
      l = square_to_cosine_hemisphere(u2);
      if (u1 >= psr + pst + pdr && pdt > 0.f) l = -l;
    }
    s.wi = l * side;
    s.pdf = pdf(wo, s.wi);
    if (!(s.pdf > 0.f)) return BsdfSample{};
    s.weight = f(wo, s.wi, mode) * (fabsf(s.wi.z) / s.pdf);
    s.transmission = s.wi.z * wo.z < 0.f;
    s.valid = true;
    return s;
  }
};

}  // namespace luz
