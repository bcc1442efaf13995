// BSDFs: small structs, one model per file, in a tagged union dispatched by
// one `visit` over the type enum (no virtual calls), so the same code runs on
// the CPU and in CUDA kernels. A model is a plain struct with
//   static constexpr bool kDeltaOnly;     // only delta lobes: f() and pdf() are 0 everywhere
//   static constexpr bool kHasDelta;      // some lobe is a delta (kDeltaOnly implies it)
//   static constexpr bool kTransmission;  // a lobe through the surface: the model
//                                         // answers wo on either side itself
//   Color f(Vec3 wo, Vec3 wi) const;      // + TransportMode for kTransmission models
//   float pdf(Vec3 wo, Vec3 wi) const;
//   BsdfSample sample(Vec3 wo, float u1, Vec2 u2) const;  // + TransportMode, as f
// The transport mode matters only for refraction (common.h), so only the
// transmissive models take it.
//
// Conventions: directions are unit vectors in the local shading frame (normal
// +z), both pointing away from the surface. `wo` points toward the viewer
// (where the path came from), `wi` toward where light arrives from (the
// sampled continuation). f() is the BSDF value itself, without the cosine.
#pragma once

#include <cstring>
#include <type_traits>

#include "luz/bsdf/blinnphong.h"
#include "luz/bsdf/common.h"
#include "luz/bsdf/conductor.h"
#include "luz/bsdf/dielectric.h"
#include "luz/bsdf/diffuse.h"
#include "luz/bsdf/gltf_pbr.h"
#include "luz/bsdf/phong.h"
#include "luz/bsdf/plastic.h"
#include "luz/bsdf/principled.h"
#include "luz/bsdf/roughplastic.h"
#include "luz/bsdf/ward.h"
#include "luz/math/vec.h"
#include "luz/sampling/warp.h"

// Bsdf's general case (every model but plain Lambert) stays out of line:
// inlined into the integrator, the dispatch over all models bloats the path
// loop (measured: the Cornell box 4% slower on the CPU once rough plastic
// joined the dispatch; on the GPU, bench/RESULTS.md 2026-12-04).
#define LUZ_BSDF_GENERAL LUZ_NOINLINE

namespace luz {

enum class BsdfType : uint32_t {
  Diffuse,
  Phong,
  SmoothConductor,
  RoughConductor,
  SmoothDielectric,
  RoughDielectric,
  ThinDielectric,
  SmoothPlastic,
  BlinnPhong,
  Ward,
  RoughPlastic,
  GltfPbr,
  GltfPbrTransmission,
  Principled,
  PrincipledTransmission,
  DiffuseTransmission,
  PrincipledThin,  // the last: kBsdfTypeCount follows it
};
constexpr uint32_t kBsdfTypeCount = uint32_t(BsdfType::PrincipledThin) + 1;

// One BSDF model: a tag and the model's parameters in a union (every model
// is a small trivially copyable struct).
// The tag of constructors that leave a BSDF's storage unwritten, for one
// that is filled at once (Bsdf::copy_live).
struct Uninitialized {};

struct BsdfComponent {
  BsdfType type;
  union {
    DiffuseBsdf diffuse;
    PhongBsdf phong;
    SmoothConductorBsdf smooth_conductor;
    RoughConductorBsdf rough_conductor;
    SmoothDielectricBsdf smooth_dielectric;
    RoughDielectricBsdf rough_dielectric;
    ThinDielectricBsdf thin_dielectric;
    SmoothPlasticBsdf smooth_plastic;
    BlinnPhongBsdf blinn_phong;
    WardBsdf ward;
    RoughPlasticBsdf rough_plastic;
    GltfPbrBsdf gltf_pbr;
    GltfPbrTransmissionBsdf gltf_pbr_transmission;
    PrincipledBsdf principled;
    PrincipledTransmissionBsdf principled_transmission;
    DiffuseTransmissionBsdf diffuse_transmission;
    PrincipledThinBsdf principled_thin;
  };

  // The models' members have default initialisers, so the union needs a
  // constructor saying which one is live: a diffuse grey 0 until set.
  LUZ_INLINE BsdfComponent() : type(BsdfType::Diffuse), diffuse() {}
  LUZ_INLINE explicit BsdfComponent(Uninitialized) {}
};
static_assert(std::is_trivially_copyable_v<BsdfComponent>, "BSDFs are copied to the GPU as bytes");

// Calls f with the component's model (const as the component is).
template <class C, class F, std::enable_if_t<std::is_base_of_v<BsdfComponent, std::remove_const_t<C>>, int> = 0>
LUZ_FORCE_INLINE decltype(auto) visit(C& c, F&& f) {
  switch (c.type) {
    case BsdfType::Diffuse: return f(c.diffuse);
    case BsdfType::Phong: return f(c.phong);
    case BsdfType::SmoothConductor: return f(c.smooth_conductor);
    case BsdfType::RoughConductor: return f(c.rough_conductor);
    case BsdfType::SmoothDielectric: return f(c.smooth_dielectric);
    case BsdfType::RoughDielectric: return f(c.rough_dielectric);
    case BsdfType::ThinDielectric: return f(c.thin_dielectric);
    case BsdfType::SmoothPlastic: return f(c.smooth_plastic);
    case BsdfType::BlinnPhong: return f(c.blinn_phong);
    case BsdfType::Ward: return f(c.ward);
    case BsdfType::GltfPbr: return f(c.gltf_pbr);
    case BsdfType::GltfPbrTransmission: return f(c.gltf_pbr_transmission);
    case BsdfType::Principled: return f(c.principled);
    case BsdfType::PrincipledTransmission: return f(c.principled_transmission);
    case BsdfType::DiffuseTransmission: return f(c.diffuse_transmission);
    case BsdfType::PrincipledThin: return f(c.principled_thin);
    default: return f(c.rough_plastic);
  }
}

// The component's member a parameter name means (BsdfParam), or null.
LUZ_INLINE Color* color_param(BsdfComponent& c, BsdfParam p) {
  return visit(c, [&](auto& m) { return m.color_param(p); });
}
LUZ_INLINE float* float_param(BsdfComponent& c, BsdfParam p) {
  return visit(c, [&](auto& m) { return m.float_param(p); });
}

// The flags of the component's model.
LUZ_INLINE bool is_delta_only(const BsdfComponent& c) {
  return visit(c, [](const auto& m) { return std::decay_t<decltype(m)>::kDeltaOnly; });
}
LUZ_INLINE bool has_delta_lobe(const BsdfComponent& c) {
  return visit(c, [](const auto& m) { return std::decay_t<decltype(m)>::kHasDelta; });
}
LUZ_INLINE bool is_transmissive(const BsdfComponent& c) {
  return visit(c, [](const auto& m) { return std::decay_t<decltype(m)>::kTransmission; });
}

// The tagged BSDF: one component (the base class: `type`, `diffuse`,
// `phong`, ... name it), or a blend of two (Mitsuba's `blendbsdf`):
//   f = (1 - w) f_0 + w f_1,  pdf = (1 - w) pdf_0 + w pdf_1,
// sampled by choosing component 1 with probability w (u1 is rescaled and
// reused). No recursion and no pointers: the second component is a flat
// slot, and a blend of blends is not representable.
//
// `two_sided` mirrors the local frame for reflection-only components so the
// back face behaves like the front (Mitsuba's `twosided`); one-sided ones are
// black from behind. Transmissive components (dielectrics) see wo as it is,
// on either side. Mitsuba's `twosided` with two nested BSDFs (the first for
// the front, the second for the back) sets `has_back`: a query whose wo is
// below the surface (wo.z < 0) is then answered by the `back` component alone,
// in the mirrored frame, and the front (a component or a blend) serves wo.z > 0.
// The back slot holds one component (not a blend): again no recursion.
//
// Every sample carries BsdfSample::delta / transmission / eta (common.h).
// f() and pdf() never include delta lobes.
struct Bsdf : BsdfComponent {
  bool two_sided;
  bool blend;
  float blend_weight;  // w: the share of `second`
  bool has_back;       // two_sided with a different BSDF behind
  BsdfComponent second;
  BsdfComponent back;

  LUZ_INLINE Bsdf() : two_sided(false), blend(false), blend_weight(0.f), has_back(false) {}
  LUZ_INLINE explicit Bsdf(Uninitialized u) : BsdfComponent(u), second(u), back(u) {}

  // Becomes a copy of what src's type and flags make live: each component in use,
  // its active model only (a diffuse one is 12 bytes of the Bsdf's 552),
  // the rest of the storage left unwritten.
  LUZ_FORCE_INLINE void copy_live(const Bsdf& src) {
    copy_component(*this, src);
    two_sided = src.two_sided;
    blend = src.blend;
    blend_weight = src.blend_weight;
    has_back = src.has_back;
    if (src.blend) copy_component(second, src.second);
    if (src.has_back) copy_component(back, src.back);
  }
  LUZ_FORCE_INLINE static void copy_component(BsdfComponent& dst, const BsdfComponent& src) {
    dst.type = src.type;
    // Every model starts at the union's address; they are trivially copyable.
    visit(src, [&](const auto& m) { memcpy(static_cast<void*>(&dst.diffuse), &m, sizeof(m)); });
  }

  // wo is on the back side and a separate back BSDF serves it.
  LUZ_INLINE bool use_back(Vec3 wo) const { return has_back && wo.z < 0.f; }

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

  // Brings wo and wi to the side a reflection-only model sees (orient);
  // false where f and pdf are 0: a side without surface, or wi across it.
  LUZ_INLINE bool reflection_side(Vec3& wo, Vec3& wi) const {
    float flip;
    if (!orient(wo, flip)) return false;
    wi.z *= flip;
    return !(wi.z <= 0.f);
  }

  // A component's f, pdf and sample: transmissive models see wo as it is,
  // the others on the side orient() gives.
  LUZ_INLINE Color component_f(const BsdfComponent& c, Vec3 wo, Vec3 wi, TransportMode mode) const {
    return visit(c, [&](const auto& m) {
      if constexpr (std::decay_t<decltype(m)>::kTransmission) return m.f(wo, wi, mode);
      else return reflection_side(wo, wi) ? m.f(wo, wi) : Color{};
    });
  }
  LUZ_INLINE float component_pdf(const BsdfComponent& c, Vec3 wo, Vec3 wi) const {
    return visit(c, [&](const auto& m) {
      if constexpr (std::decay_t<decltype(m)>::kTransmission) return m.pdf(wo, wi);
      else return reflection_side(wo, wi) ? m.pdf(wo, wi) : 0.f;
    });
  }
  LUZ_INLINE BsdfSample component_sample(const BsdfComponent& c, Vec3 wo, float u1, Vec2 u2,
                                         TransportMode mode) const {
    return visit(c, [&](const auto& m) {
      if constexpr (std::decay_t<decltype(m)>::kTransmission) {
        return m.sample(wo, u1, u2, mode);
      } else {
        float flip;
        if (!orient(wo, flip)) return BsdfSample{};
        BsdfSample s = m.sample(wo, u1, u2);
        s.wi.z *= flip;
        return s;
      }
    });
  }

  // The Lambertian case is the common one (every Cornell box wall): it takes
  // an inlined path, not the dispatch through every model (measured: the
  // generic dispatch made the Cornell benchmark 13% slower).
  LUZ_INLINE bool plain_diffuse() const { return type == BsdfType::Diffuse && !blend && !has_back; }

  // f, pdf and sample of a plain_diffuse() BSDF (the integrator, having
  // asked plain_diffuse() once per vertex, calls these or the _general ones).
  // Light reflects only from a side the surface has, into that same side.
  LUZ_INLINE bool diffuse_reflects(Vec3 wo, Vec3 wi) const {
    return (wo.z > 0.f || (two_sided && wo.z < 0.f)) && wo.z * wi.z > 0.f;
  }
  LUZ_INLINE Color f_diffuse(Vec3 wo, Vec3 wi) const {
    return diffuse_reflects(wo, wi) ? diffuse.reflectance * kInvPi : Color{};
  }
  LUZ_INLINE float pdf_diffuse(Vec3 wo, Vec3 wi) const { return diffuse_reflects(wo, wi) ? fabsf(wi.z) * kInvPi : 0.f; }
  LUZ_INLINE BsdfSample sample_diffuse(Vec3 wo, float u1, Vec2 u2) const {
    float flip;
    if (!orient(wo, flip)) return {};
    BsdfSample s = diffuse.sample(wo, u1, u2);
    s.wi.z *= flip;
    return s;
  }

  LUZ_INLINE Color f(Vec3 wo, Vec3 wi, TransportMode mode = TransportMode::Radiance) const {
    return plain_diffuse() ? f_diffuse(wo, wi) : f_general(wo, wi, mode);
  }
  LUZ_BSDF_GENERAL Color f_general(Vec3 wo, Vec3 wi, TransportMode mode) const {
    if (use_back(wo)) return component_f(back, wo, wi, mode);
    if (!blend) return component_f(*this, wo, wi, mode);
    return component_f(*this, wo, wi, mode) * (1.f - blend_weight) +
           component_f(second, wo, wi, mode) * blend_weight;
  }

  LUZ_INLINE float pdf(Vec3 wo, Vec3 wi) const { return plain_diffuse() ? pdf_diffuse(wo, wi) : pdf_general(wo, wi); }
  LUZ_BSDF_GENERAL float pdf_general(Vec3 wo, Vec3 wi) const {
    if (use_back(wo)) return component_pdf(back, wo, wi);
    if (!blend) return component_pdf(*this, wo, wi);
    return component_pdf(*this, wo, wi) * (1.f - blend_weight) + component_pdf(second, wo, wi) * blend_weight;
  }

  // u1 picks a lobe, u2 the direction within it.
  LUZ_INLINE BsdfSample sample(Vec3 wo, float u1, Vec2 u2, TransportMode mode = TransportMode::Radiance) const {
    return plain_diffuse() ? sample_diffuse(wo, u1, u2) : sample_general(wo, u1, u2, mode);
  }
  LUZ_BSDF_GENERAL BsdfSample sample_general(Vec3 wo, float u1, Vec2 u2, TransportMode mode) const {
    if (use_back(wo)) return component_sample(back, wo, u1, u2, mode);
    if (!blend) return component_sample(*this, wo, u1, u2, mode);
    float w = blend_weight;
    bool pick_second = u1 < w;
    float sel = pick_second ? w : 1.f - w;
    float u1r = pick_second ? u1 / w : (u1 - w) / (1.f - w);
    u1r = min(max(u1r, 0.f), kOneMinusEpsilon);
    BsdfSample s = component_sample(pick_second ? second : *this, wo, u1r, u2, mode);
    if (!s.valid) return s;
    if (s.delta) {
      s.pdf *= sel;  // weight: (sel · amplitude) / (sel · probability), unchanged
      return s;
    }
    s.pdf = pdf(wo, s.wi);
    if (!(s.pdf > 0.f)) {
      s.valid = false;
      return s;
    }
    s.weight = f(wo, s.wi, mode) * (fabsf(s.wi.z) / s.pdf);
    return s;
  }

  // Over both sides (the integrator asks without a direction).
  LUZ_INLINE bool delta_only() const {
    return is_delta_only(*this) && (!blend || is_delta_only(second)) && (!has_back || is_delta_only(back));
  }
  LUZ_INLINE bool has_delta() const {
    return has_delta_lobe(*this) || (blend && has_delta_lobe(second)) || (has_back && has_delta_lobe(back));
  }
  LUZ_INLINE bool has_transmission() const {
    return is_transmissive(*this) || (blend && is_transmissive(second)) || (has_back && is_transmissive(back));
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
  // Mitsuba `conductor`: eta, k per channel (fresnel.h presets), specular_reflectance.
  LUZ_INLINE static Bsdf make_smooth_conductor(Color eta, Color k, Color specular = {1.f, 1.f, 1.f},
                                               bool two_sided = false) {
    Bsdf b;
    b.type = BsdfType::SmoothConductor;
    b.two_sided = two_sided;
    b.smooth_conductor = SmoothConductorBsdf{eta, k, specular};
    return b;
  }
  // Mitsuba `roughconductor`: distribution, alpha_u, alpha_v, eta, k, specular_reflectance.
  LUZ_INLINE static Bsdf make_rough_conductor(MicrofacetType t, float alpha_u, float alpha_v, Color eta, Color k,
                                              Color specular = {1.f, 1.f, 1.f}, bool two_sided = false) {
    Bsdf b;
    b.type = BsdfType::RoughConductor;
    b.two_sided = two_sided;
    b.rough_conductor =
        RoughConductorBsdf{t, alpha_u, alpha_v, eta, k, specular};
    return b;
  }
  // Mitsuba `dielectric`: int_ior, ext_ior, specular_reflectance, specular_transmittance.
  LUZ_INLINE static Bsdf make_smooth_dielectric(float int_ior, float ext_ior, Color refl = {1.f, 1.f, 1.f},
                                                Color trans = {1.f, 1.f, 1.f}) {
    Bsdf b;
    b.type = BsdfType::SmoothDielectric;
    b.smooth_dielectric = SmoothDielectricBsdf{int_ior / ext_ior, refl, trans};
    return b;
  }
  // Mitsuba `thindielectric`.
  LUZ_INLINE static Bsdf make_thin_dielectric(float int_ior, float ext_ior, Color refl = {1.f, 1.f, 1.f},
                                              Color trans = {1.f, 1.f, 1.f}) {
    Bsdf b;
    b.type = BsdfType::ThinDielectric;
    b.thin_dielectric = ThinDielectricBsdf{int_ior / ext_ior, refl, trans};
    return b;
  }
  // Mitsuba `roughdielectric`.
  LUZ_INLINE static Bsdf make_rough_dielectric(MicrofacetType t, float alpha_u, float alpha_v, float int_ior,
                                               float ext_ior, Color refl = {1.f, 1.f, 1.f},
                                               Color trans = {1.f, 1.f, 1.f}) {
    Bsdf b;
    b.type = BsdfType::RoughDielectric;
    b.rough_dielectric = RoughDielectricBsdf{t,       alpha_u, alpha_v, int_ior / ext_ior,
                                             refl, trans};
    return b;
  }
  // Mitsuba `plastic`. Host only (integrates F_dr).
  static Bsdf make_smooth_plastic(Color diffuse, Color specular = {1.f, 1.f, 1.f}, float int_ior = 1.49f,
                                  float ext_ior = 1.000277f, bool two_sided = false, bool nonlinear = false) {
    Bsdf b;
    b.type = BsdfType::SmoothPlastic;
    b.two_sided = two_sided;
    b.smooth_plastic = SmoothPlasticBsdf::make(diffuse, specular, int_ior, ext_ior, nonlinear);
    return b;
  }
  LUZ_INLINE static Bsdf make_blinn_phong(Color kd, Color ks, float n, bool two_sided = false) {
    Bsdf b;
    b.type = BsdfType::BlinnPhong;
    b.two_sided = two_sided;
    b.blinn_phong = BlinnPhongBsdf{kd, ks, n};
    return b;
  }
  // Mitsuba `roughplastic`: distribution, alpha (isotropic), int_ior, ext_ior,
  // diffuse_reflectance, specular_reflectance, nonlinear. Host only (tabulates
  // the coat's albedos).
  static Bsdf make_rough_plastic(MicrofacetType t, float alpha, Color diffuse, Color specular = {1.f, 1.f, 1.f},
                                 float int_ior = 1.49f, float ext_ior = 1.000277f, bool nonlinear = false,
                                 bool two_sided = false) {
    Bsdf b;
    b.type = BsdfType::RoughPlastic;
    b.two_sided = two_sided;
    b.rough_plastic = RoughPlasticBsdf::make(t, alpha, diffuse, specular, int_ior, ext_ior, nonlinear);
    return b;
  }
  // Mitsuba 0.6 `ward` (variants "ward", "ward-duer" and "balanced").
  LUZ_INLINE static Bsdf make_ward(WardVariant v, Color kd, Color ks, float alpha_u, float alpha_v,
                                   bool two_sided = false) {
    Bsdf b;
    b.type = BsdfType::Ward;
    b.two_sided = two_sided;
    b.ward = WardBsdf{v, kd, ks, alpha_u, alpha_v};
    return b;
  }
  // glTF 2.0 metallic-roughness (gltf_pbr.h): baseColor, metallic,
  // roughness, KHR_materials_ior's ior, doubleSided.
  LUZ_INLINE static Bsdf make_gltf_pbr(Color base_color, float metallic, float roughness, float ior = 1.5f,
                                       bool two_sided = false) {
    Bsdf b;
    b.type = BsdfType::GltfPbr;
    b.two_sided = two_sided;
    b.gltf_pbr = GltfPbrBsdf{base_color, metallic, roughness, GltfPbrBsdf::ior_to_f0(ior)};
    return b;
  }
  // The same with KHR_materials_transmission's transmissionFactor (a thin
  // sheet, two-sided by nature).
  LUZ_INLINE static Bsdf make_gltf_pbr_transmission(Color base_color, float metallic, float roughness,
                                                    float transmission, float ior = 1.5f) {
    Bsdf b;
    b.type = BsdfType::GltfPbrTransmission;
    b.gltf_pbr_transmission.surface = make_gltf_pbr(base_color, metallic, roughness, ior).gltf_pbr;
    b.gltf_pbr_transmission.transmission = transmission;
    return b;
  }
  // pbrt-v4 `diffusetransmission` (diffuse.h): R/π on wo's side, T/π through.
  LUZ_INLINE static Bsdf make_diffuse_transmission(Color r, Color t) {
    Bsdf b;
    b.type = BsdfType::DiffuseTransmission;
    b.diffuse_transmission = DiffuseTransmissionBsdf{r, t};
    return b;
  }
  // Mitsuba 3 `principled` (principled.h): the model with its parameters
  // set; spec_trans > 0 (or textured) makes it the transmissive type.
  LUZ_INLINE static Bsdf make_principled(const PrincipledParams& p, bool transmits, bool two_sided = false) {
    Bsdf b;
    b.two_sided = two_sided;
    if (transmits) {
      b.type = BsdfType::PrincipledTransmission;
      static_cast<PrincipledParams&>(b.principled_transmission) = p;
    } else {
      b.type = BsdfType::Principled;
      static_cast<PrincipledParams&>(b.principled) = p;
      b.principled.spec_trans = 0.f;
    }
    return b;
  }
  // Mitsuba 3 `principledthin` (principled.h).
  LUZ_INLINE static Bsdf make_principled_thin(const PrincipledThinBsdf& p) {
    Bsdf b;
    b.type = BsdfType::PrincipledThin;
    b.principled_thin = p;
    return b;
  }
  // Mitsuba `blendbsdf`: (1 - weight) a + weight b. a and b must not be blends
  // themselves; two_sided is taken from a.
  LUZ_INLINE static Bsdf make_blend(const Bsdf& a, const Bsdf& b, float weight) {
    Bsdf r = a;
    r.blend = true;
    r.blend_weight = clamp(weight, 0.f, 1.f);
    r.second = b;  // slices off b's wrapper fields
    return r;
  }
  // Mitsuba `twosided` with two nested BSDFs: `front` for wo.z > 0 (it may be
  // a blend), `back` for wo.z < 0 (one component), both reflection only.
  // Both sides must be reflection-only (no dielectrics), as Mitsuba requires:
  // the loader refuses the others; a transmissive side made here would send
  // light into the side that the other BSDF answers.
  LUZ_INLINE static Bsdf make_two_sided(const Bsdf& front, const Bsdf& back) {
    Bsdf r = front;
    r.two_sided = true;
    r.has_back = true;
    r.back = back;  // slices off back's wrapper fields
    return r;
  }
};

}  // namespace luz

#undef LUZ_BSDF_GENERAL
