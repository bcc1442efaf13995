// The BSDF library (every model of bsdf/, blends and two-sided pairs in
// bsdf.h; the lists below cover every BsdfType, checked): chi-square of
// sample() against pdf() for every model with a non-delta lobe, at several
// incidences including grazing and roughness ≤ 0.05, over the whole sphere
// for transmissive models and for twosided pairs with a different back BSDF
// (wo on both sides; delta samples and failures go to the failure bin);
// sample weights against f·|cos|/pdf; reciprocity (the generalised η² form
// for rough dielectrics); directional albedo ≤ 1 by Monte Carlo with an error
// bar; delta lobes; the twosided pair answers each side with its own BSDF.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "bsdf_cases.h"
#include "chi2.h"
#include "luz/bsdf/bsdf.h"
#include "sanitizer.h"

using namespace luz;

namespace {

constexpr uint64_t kSamples = 200000;
constexpr float kAzimuth = 0.7f;
const float kIncidenceDeg[] = {0.f, 45.f, 80.f, 89.f};
// Transmissive models also from inside (wo.z < 0); 60° is past the critical
// angle of η = 1.5 and 1.33.
const float kInsideDeg[] = {30.f, 60.f, 89.f};

Vec3 direction(float theta_deg, float phi) {
  float t = theta_deg * kPi / 180.f;
  return {sinf(t) * cosf(phi), sinf(t) * sinf(phi), cosf(t)};
}
Vec3 mirror_z(Vec3 v) { return {v.x, v.y, -v.z}; }

const Color kWhite = {1.f, 1.f, 1.f};
Color au_eta() { Color e, k; find_conductor_preset("Au", e, k); return e; }
Color au_k() { Color e, k; find_conductor_preset("Au", e, k); return k; }

// Mitsuba 3's principled with spec_trans t (t > 0: the transmissive type).
Bsdf principled(PrincipledParams p, float spec_trans = 0.f) {
  p.spec_trans = spec_trans;
  return Bsdf::make_principled(p, spec_trans > 0.f);
}
struct Case {
  std::string name;
  Bsdf b;
  float width;  // angular scale of the narrowest lobe (radians of wi), for the grid
};

// Every model with a non-delta lobe, with textbook parameters. Built once
// (rough plastic tabulates its coat's albedos when made).
std::vector<Case> build_models() {
  std::vector<Case> v;
  const MicrofacetType B = MicrofacetType::Beckmann, G = MicrofacetType::GGX;
  v.push_back({"diffuse rgb", Bsdf::make_diffuse({.9f, .4f, .1f}), 1.f});
  v.push_back({"phong kd .3 ks .5 n 20", Bsdf::make_phong({.3f, .3f, .3f}, {.5f, .5f, .5f}, 20.f, false), 1.f});
  v.push_back({"roughconductor Au beckmann .05", Bsdf::make_rough_conductor(B, .05f, .05f, au_eta(), au_k()), .1f});
  v.push_back({"roughconductor Au ggx .3", Bsdf::make_rough_conductor(G, .3f, .3f, au_eta(), au_k()), 1.f});
  v.push_back({"roughconductor Au ggx (.05,.3)", Bsdf::make_rough_conductor(G, .05f, .3f, au_eta(), au_k()), 1.f});
  v.push_back({"roughconductor beckmann (.4,.1)", Bsdf::make_rough_conductor(B, .4f, .1f, {0.2f, 0.9f, 1.1f},
                                                                              {3.9f, 2.4f, 2.f}), 1.f});
  v.push_back({"roughdielectric ggx .05 η1.5", Bsdf::make_rough_dielectric(G, .05f, .05f, 1.5f, 1.f), .1f});
  v.push_back({"roughdielectric beckmann .3 η1.5", Bsdf::make_rough_dielectric(B, .3f, .3f, 1.5f, 1.f), 1.f});
  v.push_back({"roughdielectric ggx (.1,.3) water", Bsdf::make_rough_dielectric(G, .1f, .3f, 1.333f, 1.000277f), 1.f});
  v.push_back({"roughdielectric ggx .2 air in water (η<1)", Bsdf::make_rough_dielectric(G, .2f, .2f, 1.f, 1.333f), 1.f});
  v.push_back({"plastic ρ=.5", Bsdf::make_smooth_plastic({.5f, .5f, .5f}), 1.f});
  v.push_back({"plastic rgb ρ=(.8,.3,.1)", Bsdf::make_smooth_plastic({.8f, .3f, .1f}, kWhite, 1.5f), 1.f});
  v.push_back({"blinnphong kd .3 ks .7 n 20", Bsdf::make_blinn_phong({.3f, .3f, .3f}, {.7f, .7f, .7f}, 20.f), 1.f});
  v.push_back({"blinnphong ks 1 n 800", Bsdf::make_blinn_phong({0.f, 0.f, 0.f}, kWhite, 800.f), .1f});
  v.push_back({"ward balanced (.1,.3)", Bsdf::make_ward(WardVariant::Balanced, {.2f, .2f, .2f}, {.8f, .8f, .8f}, .1f, .3f), 1.f});
  v.push_back({"ward original .05", Bsdf::make_ward(WardVariant::Ward, {.1f, .1f, .1f}, {.5f, .5f, .5f}, .05f, .05f), .1f});
  v.push_back({"ward-duer (.2,.1)", Bsdf::make_ward(WardVariant::WardDuer, {.3f, .3f, .3f}, {.6f, .6f, .6f}, .2f, .1f), 1.f});
  v.push_back({"ward-duer .04", Bsdf::make_ward(WardVariant::WardDuer, {0.f, 0.f, 0.f}, {.7f, .7f, .7f}, .04f, .04f), .08f});
  v.push_back({"roughplastic beckmann .02 ρ=.2", Bsdf::make_rough_plastic(B, .02f, {.2f, .2f, .2f}), .04f});
  v.push_back({"roughplastic ggx .05 ρ=(.8,.3,.1) η1.5",
               Bsdf::make_rough_plastic(G, .05f, {.8f, .3f, .1f}, kWhite, 1.5f, 1.f), 1.f});
  v.push_back({"roughplastic ggx .3 ρ=.5", Bsdf::make_rough_plastic(G, .3f, {.5f, .5f, .5f}), 1.f});
  v.push_back({"roughplastic beckmann .6 ρ=.5 ks .5 η2.4 nonlinear",
               Bsdf::make_rough_plastic(B, .6f, {.5f, .5f, .5f}, {.5f, .5f, .5f}, 2.4f, 1.f, true), 1.f});
  v.push_back({"gltf metallic 0 rough .5 base (.8,.3,.1)", Bsdf::make_gltf_pbr({.8f, .3f, .1f}, 0.f, .5f), 1.f});
  v.push_back({"gltf metallic 1 rough .3 base (1,.8,.3)", Bsdf::make_gltf_pbr({1.f, .8f, .3f}, 1.f, .3f), 1.f});
  v.push_back({"gltf metallic .5 rough .2 base .5", Bsdf::make_gltf_pbr({.5f, .5f, .5f}, .5f, .2f), .08f});
  v.push_back({"gltf metallic 0 rough 1 base .5 ior 1", Bsdf::make_gltf_pbr({.5f, .5f, .5f}, 0.f, 1.f, 1.f), 1.f});
  v.push_back({"gltf metallic 0 rough .1 base 0", Bsdf::make_gltf_pbr({0.f, 0.f, 0.f}, 0.f, .1f), .02f});
  v.push_back({"gltf transmission .8 metallic 0 rough .3 base (.9,.6,.3)",
               Bsdf::make_gltf_pbr_transmission({.9f, .6f, .3f}, 0.f, .3f, .8f), 1.f});
  Bsdf translucent = Bsdf::make_gltf_pbr_transmission({.6f, .8f, .3f}, 0.f, .4f, 0.f);
  translucent.gltf_pbr_transmission.diffuse_transmission = .7f;
  translucent.gltf_pbr_transmission.diffuse_transmission_color = {.9f, .9f, .2f};
  v.push_back({"gltf diffuse transmission .7 rough .4", translucent, 1.f});
  translucent.gltf_pbr_transmission.transmission = .4f;
  translucent.gltf_pbr_transmission.surface.metallic = .2f;
  v.push_back({"gltf transmission .4 diffuse transmission .7 metallic .2", translucent, 1.f});
  v.push_back({"gltf transmission 1 metallic .3 rough .1 base .7",
               Bsdf::make_gltf_pbr_transmission({.7f, .7f, .7f}, .3f, .1f, 1.f), 1.f});
  // KHR_materials_specular: a strength and an F0 colour (clamped in red).
  Bsdf spec = Bsdf::make_gltf_pbr({.6f, .5f, .4f}, .2f, .3f, 1.8f);
  spec.gltf_pbr.specular_strength = .4f;
  spec.gltf_pbr.specular_color = {12.f, .5f, 0.f};
  v.push_back({"gltf specular .4 colour (12,.5,0) ior 1.8 metallic .2 rough .3", spec, 1.f});
  Bsdf spec_t = Bsdf::make_gltf_pbr_transmission({.8f, .8f, .9f}, 0.f, .2f, .7f);
  spec_t.gltf_pbr_transmission.surface.specular_strength = .7f;
  spec_t.gltf_pbr_transmission.surface.specular_color = {1.f, 2.f, .3f};
  v.push_back({"gltf transmission .7 specular .7 colour (1,2,.3) rough .2", spec_t, 1.f});
  // KHR_materials_clearcoat: a sharp and a rough coat.
  Bsdf coat = Bsdf::make_gltf_pbr({.7f, .2f, .1f}, .3f, .6f);
  coat.gltf_pbr.clearcoat = .8f;
  coat.gltf_pbr.clearcoat_roughness = .3f;
  v.push_back({"gltf clearcoat .8 rough .3 over metallic .3 rough .6", coat, 1.f});
  coat.gltf_pbr.clearcoat = 1.f;
  coat.gltf_pbr.clearcoat_roughness = .2f;
  v.push_back({"gltf clearcoat 1 rough .2 over metallic .3 rough .6", coat, .08f});
  v.push_back({"diffusetransmission R (.6,.3,.1) T (.2,.5,.3)",
               Bsdf::make_diffuse_transmission({.6f, .3f, .1f}, {.2f, .5f, .3f}), 1.f});
  v.push_back({"diffusetransmission R 0 T .8", Bsdf::make_diffuse_transmission({}, {.8f, .8f, .8f}), 1.f});
  // Mitsuba 3's principled: its defaults; its documentation's example (with
  // and without spec_trans); a narrow clear glass; η < 1 (Schlick at the
  // refracted cosine); a glossy coat over a flattened rough diffuse.
  v.push_back({"principled defaults", principled({}), 1.f});
  v.push_back({"principled doc example without spec_trans", luz_test::principled_doc_example(0.f), 1.f});
  v.push_back({"principled doc example (spec_trans .4)", luz_test::principled_doc_example(.4f), 1.f});
  PrincipledParams glass;
  glass.base_color = {.9f, .95f, 1.f};
  glass.roughness = .25f;  // α = .0625
  glass.eta = 1.33f;
  v.push_back({"principled glass spec_trans 1 roughness .25 η1.33", principled(glass, 1.f), 1.f});
  PrincipledParams below;
  below.base_color = {.2f, .6f, .9f};
  below.eta = .8f;
  below.metallic = .3f;
  below.spec_tint = .7f;
  below.roughness = .3f;
  v.push_back({"principled η .8 spec_tint .7 metallic .3", principled(below), .2f});
  PrincipledParams layered;
  layered.base_color = {.7f, .3f, .2f};
  layered.roughness = .9f;
  layered.flatness = .6f;
  layered.clearcoat = 1.f;
  layered.clearcoat_gloss = .5f;  // GTR1 α ≈ .05
  layered.sheen = 1.f;
  layered.sheen_tint = .5f;
  layered.anisotropic = .8f;
  v.push_back({"principled coat 1 gloss .5 flatness .6 sheen 1 aniso .8", principled(layered), .1f});
  // principledthin: its documentation's example, Blender's Translucent as
  // the mitsuba-blender add-on exports it (diff_trans 2), a sheer cloth.
  v.push_back({"principledthin doc example", luz_test::principledthin_doc_example(), 1.f});
  PrincipledThinBsdf leaf;
  leaf.base_color = {.2f, .6f, .4f};
  leaf.diff_trans = 2.f;
  v.push_back({"principledthin diff_trans 2 (Blender's Translucent)", Bsdf::make_principled_thin(leaf), 1.f});
  PrincipledThinBsdf cloth;
  cloth.base_color = {.8f, .7f, .5f};
  cloth.roughness = .7f;
  cloth.spec_trans = .3f;
  cloth.diff_trans = 1.f;
  cloth.sheen = .8f;
  cloth.sheen_tint = .5f;
  cloth.flatness = .5f;
  cloth.spec_tint = .4f;
  cloth.eta = 1.6f;
  v.push_back({"principledthin cloth sheen .8 flatness .5", Bsdf::make_principled_thin(cloth), 1.f});
  v.push_back({"twosided ggx .2 conductor / diffuse .7",
               Bsdf::make_two_sided(Bsdf::make_rough_conductor(G, .2f, .2f, au_eta(), au_k()),
                                    Bsdf::make_diffuse({.7f, .7f, .7f})), 1.f});
  v.push_back({"twosided blend(diffuse, roughplastic .1) / ward balanced",
               Bsdf::make_two_sided(Bsdf::make_blend(Bsdf::make_diffuse({.5f, .2f, .2f}),
                                                     Bsdf::make_rough_plastic(G, .1f, {.2f, .2f, .6f}), .5f),
                                    Bsdf::make_ward(WardVariant::Balanced, {.2f, .2f, .2f}, {.6f, .6f, .6f}, .15f, .3f)),
               1.f});
  v.push_back({"blend diffuse .8 / ggx .2 conductor, w .4",
               Bsdf::make_blend(Bsdf::make_diffuse({.8f, .8f, .8f}),
                                Bsdf::make_rough_conductor(G, .2f, .2f, au_eta(), au_k()), .4f), 1.f});
  v.push_back({"blend roughdielectric ggx .2 / smooth conductor, w .5",
               Bsdf::make_blend(Bsdf::make_rough_dielectric(G, .2f, .2f, 1.5f, 1.f),
                                Bsdf::make_smooth_conductor(au_eta(), au_k()), .5f), 1.f});
  return v;
}
const std::vector<Case>& models() {
  static const std::vector<Case> v = build_models();
  return v;
}

// Models that answer queries from both sides: transmissive ones and
// twosided pairs with their own back BSDF.
bool both_sides(const Bsdf& b) { return b.has_transmission() || b.has_back; }

std::vector<float> incidences(const Bsdf& b) {
  std::vector<float> v(std::begin(kIncidenceDeg), std::end(kIncidenceDeg));
  if (both_sides(b))
    for (float d : kInsideDeg) v.push_back(-d);  // negative: wo below the surface
  return v;
}
Vec3 wo_for(float deg) { return deg >= 0.f ? direction(deg, kAzimuth) : mirror_z(direction(-deg, kAzimuth)); }

int count_chi2_tests() {
  int n = 0;
  for (const Case& c : models()) n += int(incidences(c.b).size());
  return n;
}
const int kChi2Tests = count_chi2_tests();
const double kThreshold = chi2::sidak(chi2::kAlpha, kChi2Tests);

// η of the medium on the side of w, for the rough dielectric under test.
float side_eta(const Bsdf& b, Vec3 w) {
  return w.z > 0.f ? 1.f : (b.type == BsdfType::RoughDielectric ? b.rough_dielectric.eta : b.principled_transmission.eta);
}

// Every model with a delta lobe.
std::vector<Case> delta_models() {
  return {
      {"smoothconductor Au", Bsdf::make_smooth_conductor(au_eta(), au_k()), 0.f},
      {"smoothdielectric 1.5", Bsdf::make_smooth_dielectric(1.5f, 1.f), 0.f},
      {"smoothdielectric 1/1.5", Bsdf::make_smooth_dielectric(1.f, 1.5f), 0.f},
      {"thindielectric 1.5", Bsdf::make_thin_dielectric(1.5f, 1.f), 0.f},
      {"plastic", Bsdf::make_smooth_plastic({.5f, .5f, .5f}), 0.f},
  };
}

// Whether a case's BSDF has a component of type t.
bool uses(const Case& c, BsdfType t) {
  return c.b.type == t || (c.b.blend && c.b.second.type == t) || (c.b.has_back && c.b.back.type == t);
}

}  // namespace

// The lists of cases cover every type of the enum: each model with a
// non-delta lobe is in models() (the chi-square, weight and reciprocity
// harness), each with a delta lobe in delta_models(); a new type must join.
TEST(BsdfModels, CasesCoverEveryType) {
  const std::vector<Case> deltas = delta_models();
  for (uint32_t i = 0; i < kBsdfTypeCount; ++i) {
    BsdfComponent c;
    c.type = BsdfType(i);
    EXPECT_TRUE(!is_delta_only(c) || has_delta_lobe(c)) << "type " << i << ": delta-only implies a delta lobe";
    auto has = [&](const Case& k) { return uses(k, c.type); };
    if (!is_delta_only(c))
      EXPECT_TRUE(std::any_of(models().begin(), models().end(), has)) << "type " << i << " not in models()";
    if (has_delta_lobe(c)) EXPECT_TRUE(std::any_of(deltas.begin(), deltas.end(), has)) << "type " << i << " not in delta_models()";
  }
}

// Chi-square of sample() against pdf(). Reflection-only models with a narrow
// lobe are binned around the mirror direction of wo (the rest is the
// overflow bin); the others around the normal over the whole sphere.
TEST(BsdfModels, SamplingMatchesPdfChi2) {
  uint64_t seed = 5000;
  double min_p = 1.0;
  std::string min_case;
  for (const Case& c : models())
    for (float deg : incidences(c.b)) {
      Vec3 wo = wo_for(deg);
      chi2::SphereGrid g;
      if (!both_sides(c.b) && c.width < 0.5f) {
        g.axis = {-wo.x, -wo.y, wo.z};
        g.theta_max = 6.0 * c.width;
        g.n_theta = 12;
        g.n_phi = 24;
      } else {
        g.axis = {0.0, 0.0, 1.0};
        g.theta_max = chi2::kPi;
        g.n_theta = both_sides(c.b) ? 40 : 20;
        g.n_phi = 40;
      }
      ++seed;
      auto sample = [&](uint64_t i, Vec3& w) {
        BsdfSample s = c.b.sample(wo, chi2::rand01(seed, i, 0), chi2::rand2(seed, i, 1));
        w = s.wi;
        return s.valid && !s.delta;  // delta lobes: not part of pdf(), they count as failures
      };
      auto pdf = [&](chi2::D3 w) { return double(c.b.pdf(wo, chi2::to_vec3(w))); };
      chi2::Outcome o = chi2::run_sphere(g, luz_test::sanitized_count(kSamples), sample, pdf);
      EXPECT_LE(o.mass, 1.0 + 1e-3) << c.name << " at " << deg << "°";
      EXPECT_TRUE(o.result.passes(kThreshold)) << c.name << " at " << deg << "°: " << o.describe(kThreshold);
      if (o.result.p_value < min_p) {
        min_p = o.result.p_value;
        min_case = c.name + " at " + std::to_string(deg);
      }
    }
  std::printf("chi2 over %d cases: smallest p-value %.3g (%s), reject below %.3g\n", kChi2Tests, min_p,
              min_case.c_str(), kThreshold);
}

// Wherever pdf > 0: sample()'s pdf is pdf(wo, wi), its weight f·|cos|/pdf,
// in both transport modes; directions are unit; transmission flags agree
// with the side wi is on.
TEST(BsdfModels, SampleWeightMatchesEval) {
  double worst = 0.0;
  for (const Case& c : models())
    for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
      int checked = 0;
      for (uint64_t i = 0; i < 20000; ++i) {
        Vec3 wo = square_to_uniform_sphere(chi2::rand2(21, i, 0));
        if (!both_sides(c.b) && wo.z < 0.f) wo.z = -wo.z;
        BsdfSample s = c.b.sample(wo, chi2::rand01(21, i, 2), chi2::rand2(21, i, 3), mode);
        if (!s.valid) continue;
        ASSERT_NEAR(length(s.wi), 1.f, 1e-4f) << c.name;
        ASSERT_EQ(s.transmission, s.wi.z * wo.z < 0.f) << c.name;
        for (int k = 0; k < 3; ++k) ASSERT_TRUE(std::isfinite(s.weight[k]) && s.weight[k] >= 0.f) << c.name;
        if (s.delta) continue;
        float pdf = c.b.pdf(wo, s.wi);
        ASSERT_GT(pdf, 0.f) << c.name;
        ASSERT_NEAR(s.pdf, pdf, 1e-3f * pdf) << c.name;
        Color expect = c.b.f(wo, s.wi, mode) * (std::fabs(s.wi.z) / pdf);
        for (int k = 0; k < 3; ++k) {
          ASSERT_NEAR(s.weight[k], expect[k], 1e-3f * std::fabs(expect[k]) + 1e-7f) << c.name << " channel " << k;
          if (expect[k] > 0.f) worst = std::max(worst, std::fabs(double(s.weight[k]) / expect[k] - 1.0));
        }
        ++checked;
      }
      EXPECT_GT(checked, 1000) << c.name;
    }
  std::printf("sample weight vs f|cos|/pdf: largest relative difference %.3g\n", worst);
}

// Reciprocity: f(a, b) = f(b, a) for reflection; for the rough dielectric's
// refraction the generalised form f(wo, wi)/η_wo² = f(wi, wo)/η_wi² (radiance
// mode), and the importance BTDF is the radiance BTDF with its arguments
// swapped. Float tolerance: 1e-4 relative (Fresnel of wo·h and wi·h, equal
// in exact arithmetic, round differently), plus 4 times the change of f when
// either direction moves by ~4 float roundings (2^-21): sharp lobes turn the
// half vector's rounding into a larger change of D, and near the critical
// angle 1 - F is ill-conditioned (cos θt = sqrt of a cancellation).
TEST(BsdfModels, Reciprocity) {
  // Whether principledthin's transmission mask (Mitsuba's, the facet seen by
  // the transmitted direction itself) lets the pair (v, l) across through.
  auto thin_open = [](Vec3 v, Vec3 l) {
    if (v.z < 0.f) v = -v, l = -l;
    const Vec3 h = normalize(v + Vec3{l.x, l.y, std::fabs(l.z)});
    return dot(v, h) > 0.f && dot(l, h) < 0.f;
  };
  for (const Case& c : models()) {
    int nonzero = 0;
    for (uint64_t i = 0; i < 20000; ++i) {
      Vec3 a = square_to_uniform_sphere(chi2::rand2(31, i, 0)), d = square_to_uniform_sphere(chi2::rand2(31, i, 1));
      if (c.b.has_back) d.z = std::copysign(d.z, a.z);  // each side on its own
      else if (!c.b.has_transmission()) a.z = std::fabs(a.z), d.z = std::fabs(d.z);
      Color f1 = c.b.f(a, d), f2 = c.b.f(d, a);
      Color fp = c.b.f(normalize(a + Vec3{0x1p-21f, 0x1p-21f, 0.f}), d),
            fq = c.b.f(a, normalize(d + Vec3{0x1p-21f, -0x1p-21f, 0.f}));
      auto sens = [&](int k) { return 4.f * std::max(std::fabs(fp[k] - f1[k]), std::fabs(fq[k] - f1[k])); };
      float s1 = 1.f, s2 = 1.f;
      if ((c.b.type == BsdfType::RoughDielectric || c.b.type == BsdfType::PrincipledTransmission) && !c.b.blend) {
        s1 = sqr(side_eta(c.b, a)), s2 = sqr(side_eta(c.b, d));
        Color fi = c.b.f(d, a, TransportMode::Importance);
        for (int k = 0; k < 3; ++k) ASSERT_NEAR(fi[k], f1[k], 1e-4f * f1[k] + sens(k) + 1e-6f) << c.name << " adjoint";
      } else if (c.b.type == BsdfType::PrincipledThin && a.z * d.z < 0.f && !(thin_open(a, d) && thin_open(d, a))) {
        continue;  // principledthin's transmission mask (principled.h): open one way only
      } else if (c.b.has_transmission() && c.b.type != BsdfType::GltfPbrTransmission &&
                 c.b.type != BsdfType::DiffuseTransmission && c.b.type != BsdfType::PrincipledThin) {
        continue;  // blends with a dielectric: covered by their parts
      } else if (c.b.type == BsdfType::GltfPbr && c.b.gltf_pbr.clearcoat > 0.f) {
        break;  // the glTF clear coat's Fresnel at n·wo (gltf_pbr.h): not reciprocal by its definition
      }  // the thin sheets and the diffuse transmitter (η = 1 on both sides): plainly symmetric
      for (int k = 0; k < 3; ++k)
        ASSERT_NEAR(f1[k] / s1, f2[k] / s2, (1e-4f * std::fabs(f1[k]) + sens(k)) / s1 + 1e-6f) << c.name << " pair " << i;
      nonzero += !is_black(f1);
    }
    const bool coated = c.b.type == BsdfType::GltfPbr && c.b.gltf_pbr.clearcoat > 0.f;
    if (!(c.b.has_transmission() && c.b.blend) && !coated) EXPECT_GT(nonzero, 200) << c.name;
  }
}

// Energy: directional albedo E[weight] (importance mode: light arriving along
// wo, all that leaves, delta lobes included) ≤ 1 for white parameters, by
// Monte Carlo with the BSDF's own sampling: rejected if above 1 by more than
// z·σ/√N, z the one-sided Šidák quantile over all cases. Normalised
// Blinn-Phong, the original Ward and Ward-Dür are not energy conserving by
// construction: their worst albedo is measured and printed, not asserted.
// Rough plastic with ρ = k_s = 1: albedo ≤ R(μo) + T(μo) ≤ 1 (roughplastic.h).
TEST(BsdfModels, EnergyConservation) {
  const MicrofacetType B = MicrofacetType::Beckmann, G = MicrofacetType::GGX;
  auto coated = [](Bsdf b, float c, float r) {
    b.gltf_pbr.clearcoat = c;
    b.gltf_pbr.clearcoat_roughness = r;
    return b;
  };
  auto white_principled = [](float metallic, float roughness, float anisotropic = 0.f, float eta = 1.5f) {
    PrincipledParams p;
    p.base_color = kWhite;
    p.metallic = metallic;
    p.roughness = roughness;
    p.anisotropic = anisotropic;
    p.eta = eta;
    return p;
  };
  auto white_thin = [](float spec_trans, float diff_trans) {
    PrincipledThinBsdf p;
    p.base_color = kWhite;
    p.roughness = .4f;
    p.spec_trans = spec_trans;
    p.diff_trans = diff_trans;
    return p;
  };
  Color mirror_eta, mirror_k;
  find_conductor_preset("none", mirror_eta, mirror_k);
  struct E {
    std::string name;
    Bsdf b;
    bool assert_le_1;
  };
  std::vector<E> cases = {
      {"roughconductor F=1 beckmann .05", Bsdf::make_rough_conductor(B, .05f, .05f, mirror_eta, mirror_k), true},
      {"roughconductor F=1 ggx .5", Bsdf::make_rough_conductor(G, .5f, .5f, mirror_eta, mirror_k), true},
      {"roughconductor F=1 ggx 1", Bsdf::make_rough_conductor(G, 1.f, 1.f, mirror_eta, mirror_k), true},
      {"roughconductor F=1 beckmann (.05,.5)", Bsdf::make_rough_conductor(B, .05f, .5f, mirror_eta, mirror_k), true},
      {"smoothconductor F=1", Bsdf::make_smooth_conductor(mirror_eta, mirror_k), true},
      {"roughdielectric ggx .05 η1.5", Bsdf::make_rough_dielectric(G, .05f, .05f, 1.5f, 1.f), true},
      {"roughdielectric ggx .5 η1.5", Bsdf::make_rough_dielectric(G, .5f, .5f, 1.5f, 1.f), true},
      {"roughdielectric beckmann 1 η1.5", Bsdf::make_rough_dielectric(B, 1.f, 1.f, 1.5f, 1.f), true},
      {"smoothdielectric η1.5", Bsdf::make_smooth_dielectric(1.5f, 1.f), true},
      {"thindielectric η1.5", Bsdf::make_thin_dielectric(1.5f, 1.f), true},
      {"plastic ρ=1 η1.49", Bsdf::make_smooth_plastic(kWhite), true},
      {"plastic ρ=1 η2.4", Bsdf::make_smooth_plastic(kWhite, kWhite, 2.4f), true},
      {"ward balanced (.1,.3) ks 1", Bsdf::make_ward(WardVariant::Balanced, {0.f, 0.f, 0.f}, kWhite, .1f, .3f), true},
      {"ward balanced .5 ks 1", Bsdf::make_ward(WardVariant::Balanced, {0.f, 0.f, 0.f}, kWhite, .5f, .5f), true},
      {"blend plastic / roughdielectric .3", Bsdf::make_blend(Bsdf::make_smooth_plastic(kWhite),
                                                              Bsdf::make_rough_dielectric(G, .3f, .3f, 1.5f, 1.f), .5f),
       true},
      {"blinnphong ks 1 n 1", Bsdf::make_blinn_phong({0.f, 0.f, 0.f}, kWhite, 1.f), false},
      {"blinnphong ks 1 n 10", Bsdf::make_blinn_phong({0.f, 0.f, 0.f}, kWhite, 10.f), false},
      {"blinnphong ks 1 n 100", Bsdf::make_blinn_phong({0.f, 0.f, 0.f}, kWhite, 100.f), false},
      {"ward original .1 ks 1", Bsdf::make_ward(WardVariant::Ward, {0.f, 0.f, 0.f}, kWhite, .1f, .1f), false},
      {"ward original .5 ks 1", Bsdf::make_ward(WardVariant::Ward, {0.f, 0.f, 0.f}, kWhite, .5f, .5f), false},
      {"ward-duer .1 ks 1", Bsdf::make_ward(WardVariant::WardDuer, {0.f, 0.f, 0.f}, kWhite, .1f, .1f), false},
      {"ward-duer .5 ks 1", Bsdf::make_ward(WardVariant::WardDuer, {0.f, 0.f, 0.f}, kWhite, .5f, .5f), false},
      {"roughplastic ρ=1 beckmann .01 η1.49", Bsdf::make_rough_plastic(B, .01f, kWhite), true},
      {"roughplastic ρ=1 ggx .05 η1.49", Bsdf::make_rough_plastic(G, .05f, kWhite), true},
      {"roughplastic ρ=1 ggx .3 η1.49", Bsdf::make_rough_plastic(G, .3f, kWhite), true},
      {"roughplastic ρ=1 beckmann .6 η1.49", Bsdf::make_rough_plastic(B, .6f, kWhite), true},
      {"roughplastic ρ=1 ggx .01 η2.4", Bsdf::make_rough_plastic(G, .01f, kWhite, kWhite, 2.4f, 1.f), true},
      {"roughplastic ρ=1 ggx .6 η2.4", Bsdf::make_rough_plastic(G, .6f, kWhite, kWhite, 2.4f, 1.f), true},
      {"roughplastic ρ=1 ggx .3 η1.1", Bsdf::make_rough_plastic(G, .3f, kWhite, kWhite, 1.1f, 1.f), true},
      {"roughplastic ρ=1 ggx .3 1/1.33 (η<1)", Bsdf::make_rough_plastic(G, .3f, kWhite, kWhite, 1.f, 1.33f), true},
      {"roughplastic ρ=.9 nonlinear ggx .1", Bsdf::make_rough_plastic(G, .1f, {.9f, .9f, .9f}, kWhite, 1.49f,
                                                                      1.000277f, true), true},
      {"plastic ρ=.9 nonlinear η1.49", Bsdf::make_smooth_plastic({.9f, .9f, .9f}, kWhite, 1.49f, 1.000277f,
                                                                 false, true), true},
      {"gltf metal base 1 rough .3", Bsdf::make_gltf_pbr(kWhite, 1.f, .3f), true},
      {"gltf metal base 1 rough 1", Bsdf::make_gltf_pbr(kWhite, 1.f, 1.f), true},
      {"gltf metal base 1 rough .05", Bsdf::make_gltf_pbr(kWhite, 1.f, .05f), true},
      {"gltf dielectric base 1 rough .5", Bsdf::make_gltf_pbr(kWhite, 0.f, .5f), false},
      {"gltf dielectric base 1 rough .05", Bsdf::make_gltf_pbr(kWhite, 0.f, .05f), false},
      {"gltf dielectric base .5 rough 1", Bsdf::make_gltf_pbr({.5f, .5f, .5f}, 0.f, 1.f), true},
      {"gltf metal base 1 rough .3 clearcoat 1 rough .2", coated(Bsdf::make_gltf_pbr(kWhite, 1.f, .3f), 1.f, .2f), true},
      {"gltf metal base 1 rough 1 clearcoat .5 rough 0", coated(Bsdf::make_gltf_pbr(kWhite, 1.f, 1.f), .5f, 0.f), true},
      {"gltf transmission 1 base 1 rough .3", Bsdf::make_gltf_pbr_transmission(kWhite, 0.f, .3f, 1.f), true},
      {"gltf transmission .5 base .5 rough .5", Bsdf::make_gltf_pbr_transmission({.5f, .5f, .5f}, 0.f, .5f, .5f),
       true},
      {"diffusetransmission R .5 T .5", Bsdf::make_diffuse_transmission({.5f, .5f, .5f}, {.5f, .5f, .5f}), true},
      {"diffusetransmission R .2 T .8", Bsdf::make_diffuse_transmission({.2f, .2f, .2f}, {.8f, .8f, .8f}), true},
      // principled: its metal (Schlick of base 1, separable G) and its clear
      // dielectric conserve energy; the diffuse, sheen and coat add to what
      // the main lobe reflects (measured, not asserted).
      {"principled metallic 1 base 1 rough .3", principled(white_principled(1.f, .3f)), true},
      {"principled metallic 1 base 1 rough .8 aniso 1", principled(white_principled(1.f, .8f, 1.f)), true},
      {"principled spec_trans 1 base 1 rough .3", principled(white_principled(0.f, .3f), 1.f), true},
      {"principled spec_trans 1 base 1 rough .05 η1.1", principled(white_principled(0.f, .05f, 0.f, 1.1f), 1.f), true},
      {"principled base 1 rough 1 (diffuse + retro)", principled(white_principled(0.f, 1.f)), false},
      {"principled doc example, white, spec_trans .4", luz_test::principled_doc_example(.4f), false},
      {"principledthin diff_trans 2 base 1", Bsdf::make_principled_thin(white_thin(0.f, 2.f)), true},
      {"principledthin spec_trans 1 base 1", Bsdf::make_principled_thin(white_thin(1.f, 0.f)), false},
      {"twosided roughconductor F=1 / roughplastic ρ=1",
       Bsdf::make_two_sided(Bsdf::make_rough_conductor(G, .2f, .2f, mirror_eta, mirror_k),
                            Bsdf::make_rough_plastic(G, .2f, kWhite)), true},
  };
  const float degs[] = {0.f, 30.f, 60.f, 80.f, 89.f, -30.f, -60.f, -89.f};
  int tests = 0;
  for (const E& e : cases)
    for (float deg : degs) tests += (deg >= 0.f || both_sides(e.b));
  const double z = chi2::normal_two_sided_quantile(2.0 * chi2::sidak(chi2::kAlpha, tests));  // one-sided
  const uint64_t N = luz_test::sanitized_count<uint64_t>(100000);
  uint64_t seed = 9000;
  for (const E& e : cases) {
    std::printf("%-40s", e.name.c_str());
    double worst = 0.0, worst_err = 0.0;
    for (float deg : degs) {
      if (deg < 0.f && !both_sides(e.b)) continue;
      Vec3 wo = wo_for(deg);
      double sum = 0.0, sum2 = 0.0;
      ++seed;
      for (uint64_t i = 0; i < N; ++i) {
        BsdfSample s = e.b.sample(wo, chi2::rand01(seed, i, 0), chi2::rand2(seed, i, 1), TransportMode::Importance);
        double w = s.valid ? double(s.weight[0]) : 0.0;
        ASSERT_TRUE(std::isfinite(w)) << e.name;
        sum += w;
        sum2 += w * w;
      }
      double mean = sum / N, sd = std::sqrt(std::max(0.0, sum2 / N - mean * mean) / N);
      std::printf(" %5.0f°:%.4f", deg, mean);
      if (mean > worst) worst = mean, worst_err = sd;
      if (e.assert_le_1) EXPECT_LE(mean, 1.0 + z * sd + 1e-6) << e.name << " at " << deg << "° (±" << sd << ")";
    }
    std::printf("   max %.4f ± %.4f%s\n", worst, worst_err, e.assert_le_1 ? "" : "  (not asserted)");
  }
}

// Delta lobes: no NaN anywhere (grazing, exactly horizontal, below), f and pdf
// zero for pure-delta models; smooth dielectric: P(reflect) + P(refract) = 1,
// F + (1 - F) = 1 in energy (importance mode), Snell's law and the eta field;
// thin dielectric: straight through.
TEST(BsdfModels, DeltaLobes) {
  for (const Case& c : delta_models())
    for (uint64_t i = 0; i < 20000; ++i) {
      Vec3 wo = square_to_uniform_sphere(chi2::rand2(41, i, 0)), wi = square_to_uniform_sphere(chi2::rand2(41, i, 1));
      if (i % 50 == 0) wo.z = 0.f;
      if (i % 50 == 1) wo = normalize(Vec3{wo.x, wo.y, 1e-7f});
      if (c.b.delta_only()) {
        ASSERT_TRUE(is_black(c.b.f(wo, wi))) << c.name;
        ASSERT_EQ(c.b.pdf(wo, wi), 0.f) << c.name;
      }
      BsdfSample s = c.b.sample(wo, chi2::rand01(41, i, 2), chi2::rand2(41, i, 3));
      if (!s.valid) continue;
      ASSERT_TRUE(std::isfinite(s.pdf) && s.pdf > 0.f) << c.name;
      for (int k = 0; k < 3; ++k) ASSERT_TRUE(std::isfinite(s.weight[k])) << c.name;
      ASSERT_TRUE(is_finite(s.wi)) << c.name;
      ASSERT_NEAR(length(s.wi), 1.f, 1e-4f) << c.name;
    }
  for (float eta : {1.5f, 1.f / 1.5f, 2.4f})
    for (int i = 0; i <= 90; ++i) {
      Bsdf b = Bsdf::make_smooth_dielectric(eta, 1.f);
      Vec3 wo = direction(float(i), 0.3f);
      if (i == 90) wo.z = 1e-6f;
      BsdfSample r = b.sample(wo, 0.f, {}, TransportMode::Importance);
      BsdfSample t = b.sample(wo, kOneMinusEpsilon, {}, TransportMode::Importance);
      ASSERT_TRUE(r.valid && r.delta && !r.transmission);
      if (!t.transmission) {  // total internal reflection: reflection only
        ASSERT_NEAR(r.pdf, 1.f, 1e-6f) << eta << " " << i;
        continue;
      }
      ASSERT_NEAR(r.pdf + t.pdf, 1.f, 1e-6f) << eta << " " << i;
      ASSERT_NEAR(r.pdf * r.weight[0] + t.pdf * t.weight[0], 1.f, 1e-6f) << eta << " " << i;  // energy: R + T = 1
      ASSERT_FLOAT_EQ(t.eta, eta);
      float sin_o = std::sqrt(1.f - wo.z * wo.z), sin_i = std::sqrt(1.f - t.wi.z * t.wi.z);
      ASSERT_NEAR(sin_o, eta * sin_i, 1e-5f) << "Snell, η " << eta << ", " << i << "°";
      ASSERT_LT(t.wi.z, 0.f);
      // Radiance mode: the same sample carries 1/η².
      BsdfSample tr = b.sample(wo, kOneMinusEpsilon, {}, TransportMode::Radiance);
      ASSERT_NEAR(tr.weight[0], 1.f / (eta * eta), 1e-6f);
      // From inside, the same pair reversed.
      BsdfSample back = b.sample(t.wi, kOneMinusEpsilon, {}, TransportMode::Importance);
      if (!back.transmission) {  // exactly at the critical angle, float rounding may say TIR
        ASSERT_GE(i, 85) << eta;
        continue;
      }
      ASSERT_NEAR(back.wi.x, wo.x, 1e-5f);
      ASSERT_NEAR(back.wi.z, wo.z, 1e-5f);
      ASSERT_FLOAT_EQ(back.eta, 1.f / eta);
    }
  Bsdf thin = Bsdf::make_thin_dielectric(1.5f, 1.f);
  for (int i = 0; i < 90; ++i) {
    Vec3 wo = direction(float(i), 0.3f);
    BsdfSample r = thin.sample(wo, 0.f, {}), t = thin.sample(wo, kOneMinusEpsilon, {});
    ASSERT_NEAR(r.pdf + t.pdf, 1.f, 1e-6f);
    ASSERT_TRUE(t.transmission && t.eta == 1.f);
    ASSERT_FLOAT_EQ(t.wi.x, -wo.x);
    ASSERT_FLOAT_EQ(t.wi.z, -wo.z);
  }
}

// Mitsuba's twosided with two BSDFs: a query with wo above the surface is the
// front BSDF's (a blend here), one with wo below is the back BSDF's in the
// mirrored frame, bit for bit (f, pdf, and sample() with the same numbers);
// nothing crosses from one side to the other.
TEST(BsdfModels, TwoSidedAnswersEachSideWithItsOwnBsdf) {
  const MicrofacetType G = MicrofacetType::GGX;
  Bsdf front = Bsdf::make_blend(Bsdf::make_diffuse({.5f, .2f, .2f}), Bsdf::make_rough_plastic(G, .1f, {.2f, .2f, .6f}), .5f);
  Bsdf back = Bsdf::make_rough_conductor(G, .3f, .3f, au_eta(), au_k());
  Bsdf pair = Bsdf::make_two_sided(front, back);
  Bsdf front2 = front, back2 = back;
  front2.two_sided = back2.two_sided = true;
  int front_checked = 0, back_checked = 0;
  for (uint64_t i = 0; i < 20000; ++i) {
    Vec3 wo = square_to_uniform_sphere(chi2::rand2(51, i, 0)), wi = square_to_uniform_sphere(chi2::rand2(51, i, 1));
    if (wo.z == 0.f) continue;
    float u1 = chi2::rand01(51, i, 4);
    Vec2 u2 = chi2::rand2(51, i, 3);
    const Bsdf& expect = wo.z > 0.f ? front2 : back2;
    Color f = pair.f(wo, wi), fe = expect.f(wo, wi);
    for (int k = 0; k < 3; ++k) ASSERT_EQ(f[k], fe[k]) << i;
    ASSERT_EQ(pair.pdf(wo, wi), expect.pdf(wo, wi)) << i;
    if (wo.z * wi.z < 0.f) ASSERT_TRUE(is_black(f) && pair.pdf(wo, wi) == 0.f) << "across the surface, " << i;
    BsdfSample s = pair.sample(wo, u1, u2), se = expect.sample(wo, u1, u2);
    ASSERT_EQ(s.valid, se.valid) << i;
    if (!s.valid) continue;
    ASSERT_TRUE(s.wi.x == se.wi.x && s.wi.y == se.wi.y && s.wi.z == se.wi.z) << i;
    ASSERT_EQ(s.pdf, se.pdf) << i;
    for (int k = 0; k < 3; ++k) ASSERT_EQ(s.weight[k], se.weight[k]) << i;
    ASSERT_GT(s.wi.z * wo.z, 0.f) << "a sample stays on wo's side, " << i;
    ++(wo.z > 0.f ? front_checked : back_checked);
  }
  EXPECT_GT(front_checked, 5000);
  EXPECT_GT(back_checked, 5000);
  // The back is really the conductor (mirrored), not the front: at a mirror
  // configuration below the surface the two differ.
  Vec3 wo = mirror_z(direction(30.f, 0.2f)), wr = {-wo.x, -wo.y, wo.z};
  EXPECT_FALSE(pair.f(wo, wr).x == front2.f(wo, wr).x);
  EXPECT_EQ(pair.f(wo, wr).x, back.f(mirror_z(wo), mirror_z(wr)).x);
}

// glTF's metallic-roughness BSDF against the specification's Appendix B
// written out independently, in double (D as §B.3.2's α² / (π (n·h)²(α²-1)+1)²),
// V in its separable form 1 / ((|n·l| + √(α² + (1-α²)(n·l)²)) (|n·v| + √(…)));
// the mixes of §B.3.5, with KHR_materials_specular's Fresnel where a
// strength s and an F0 colour c are given): gltf_pbr.h writes D and V
// through microfacet.h's slopes and Smith Λ instead. Random directions and
// parameters, relative tolerance 1e-4 (float rounding of D near its peak).
TEST(BsdfModels, GltfPbrMatchesSpecificationFormulas) {
  auto reference = [](Color base, double metallic, double roughness, double ior, Vec3 v, Vec3 l, double s = 1.0,
                      Color c = {1.f, 1.f, 1.f}, double coat = 0.0, double coat_roughness = 0.0) {
    const double pi = 3.14159265358979323846, a = roughness * roughness, a2 = a * a;
    double hx = double(v.x) + l.x, hy = double(v.y) + l.y, hz = double(v.z) + l.z;
    const double hn = std::sqrt(hx * hx + hy * hy + hz * hz);
    hx /= hn, hy /= hn, hz /= hn;
    const double nl = l.z, nv = v.z, nh = hz, vh = std::fabs(v.x * hx + v.y * hy + v.z * hz);
    const double dd = nh * nh * (a2 - 1.0) + 1.0, D = a2 / (pi * dd * dd);
    const double V = 1.0 / ((nl + std::sqrt(a2 + (1.0 - a2) * nl * nl)) * (nv + std::sqrt(a2 + (1.0 - a2) * nv * nv)));
    const double spec = V * D, w = std::pow(1.0 - vh, 5.0), f0 = std::pow((ior - 1.0) / (ior + 1.0), 2.0);
    // The extension's dielectric_fresnel = mix(min(f0 c, 1) s, s, w); base weighted by 1 - its maximum.
    std::array<double, 3> fd;
    for (int k = 0; k < 3; ++k) {
      const double f0k = std::min(f0 * c[k], 1.0) * s;
      fd[size_t(k)] = f0k + (s - f0k) * w;
    }
    const double fmax = std::max({fd[0], fd[1], fd[2]});
    std::array<double, 3> out;
    for (int k = 0; k < 3; ++k) {
      const double metal = spec * (base[k] + (1.0 - base[k]) * w);
      const double dielectric = (1.0 - fmax) * base[k] / pi + fd[size_t(k)] * spec;
      out[k] = (1.0 - metallic) * dielectric + metallic * metal;
      if (coat > 0.0) {  // KHR_materials_clearcoat: mix(material, D_c V_c, c (0.04 + 0.96 (1 - n·v)⁵))
        const double ac = std::max(coat_roughness * coat_roughness, 1e-4), ac2 = ac * ac;
        const double dc = nh * nh * (ac2 - 1.0) + 1.0, Dc = ac2 / (pi * dc * dc);
        const double Vc = 1.0 / ((nl + std::sqrt(ac2 + (1.0 - ac2) * nl * nl)) * (nv + std::sqrt(ac2 + (1.0 - ac2) * nv * nv)));
        const double weight = coat * (0.04 + 0.96 * std::pow(1.0 - nv, 5.0));
        out[k] = (1.0 - weight) * out[k] + weight * Dc * Vc;
      }
    }
    return out;
  };
  // n random pairs (v, l) from seed: make(i) gives the BSDF and its
  // reference at (v, l); f must match in every channel, for 95% of the pairs
  // at least (the rest fall too close to the horizon).
  auto check = [](const char* what, uint64_t seed, uint64_t n, auto&& make) {
    uint64_t checked = 0;
    for (uint64_t i = 0; i < n; ++i) {
      Vec3 v = square_to_cosine_hemisphere(chi2::rand2(seed, i, 6)), l = square_to_cosine_hemisphere(chi2::rand2(seed, i, 7));
      if (!(v.z > 1e-3f && l.z > 1e-3f)) continue;
      std::array<double, 3> r;
      const Bsdf b = make(i, v, l, r);
      const Color f = b.f(v, l);
      for (int k = 0; k < 3; ++k) ASSERT_NEAR(f[k], r[k], 1e-4 * r[k] + 1e-7) << what << " pair " << i << " channel " << k;
      ++checked;
    }
    EXPECT_GT(checked, n * 95 / 100) << what;
  };
  auto base_of = [](uint64_t seed, uint64_t i) {
    return Color{chi2::rand01(seed, i, 0), chi2::rand01(seed, i, 1), chi2::rand01(seed, i, 2)};
  };
  check("core", 61, 20000, [&](uint64_t i, Vec3 v, Vec3 l, std::array<double, 3>& r) {
    const Color base = base_of(61, i);
    const float metallic = i % 4 == 0 ? 0.f : (i % 4 == 1 ? 1.f : chi2::rand01(61, i, 3));
    const float roughness = 0.05f + 0.95f * chi2::rand01(61, i, 4), ior = 1.f + chi2::rand01(61, i, 5);
    r = reference(base, metallic, roughness, ior, v, l);
    return Bsdf::make_gltf_pbr(base, metallic, roughness, ior);
  });
  // KHR_materials_specular: strengths in [0, 1], colours in [0, 3) (f0 c
  // clamped to 1 where the IOR is high).
  check("specular", 63, 10000, [&](uint64_t i, Vec3 v, Vec3 l, std::array<double, 3>& r) {
    const Color base = base_of(63, i);
    const float metallic = i % 3 == 0 ? 0.f : chi2::rand01(63, i, 3);
    const float roughness = 0.05f + 0.95f * chi2::rand01(63, i, 4), ior = 1.f + 30.f * chi2::rand01(63, i, 5);
    const float s = chi2::rand01(63, i, 8);
    const Color c = {3.f * chi2::rand01(63, i, 9), 3.f * chi2::rand01(63, i, 10), 3.f * chi2::rand01(63, i, 11)};
    Bsdf b = Bsdf::make_gltf_pbr(base, metallic, roughness, ior);
    b.gltf_pbr.specular_strength = s;
    b.gltf_pbr.specular_color = c;
    r = reference(base, metallic, roughness, ior, v, l, s, c);
    return b;
  });
  // KHR_materials_clearcoat over random materials (α_c at least 1e-4, as microfacet.h clamps).
  check("clearcoat", 64, 10000, [&](uint64_t i, Vec3 v, Vec3 l, std::array<double, 3>& r) {
    const Color base = base_of(64, i);
    const float metallic = chi2::rand01(64, i, 3), roughness = 0.05f + 0.95f * chi2::rand01(64, i, 4);
    const float coat = chi2::rand01(64, i, 8), coat_roughness = 0.1f + 0.9f * chi2::rand01(64, i, 9);
    Bsdf b = Bsdf::make_gltf_pbr(base, metallic, roughness);
    b.gltf_pbr.clearcoat = coat;
    b.gltf_pbr.clearcoat_roughness = coat_roughness;
    r = reference(base, metallic, roughness, 1.5, v, l, 1.0, {1.f, 1.f, 1.f}, coat, coat_roughness);
    return b;
  });
  // KHR_materials_transmission's thin sheet: on wo's side the diffuse part
  // scaled by 1 - t; across, (1 - m)(1 - F) t base · specular_brdf at the
  // mirrored direction (the extension's H_T); the same seen from below.
  // KHR_materials_diffuse_transmission (share d, colour c_d) splits the
  // diffuse part left on wo's side: (1 - t)(1 - d) of it stays, and
  // (1 - m)(1 - F)(1 - t) d c_d / π passes through.
  for (uint64_t i = 0; i < 5000; ++i) {
    const Color base = {chi2::rand01(62, i, 0), chi2::rand01(62, i, 1), chi2::rand01(62, i, 2)};
    const float metallic = chi2::rand01(62, i, 3), t = i % 4 == 3 ? 0.f : chi2::rand01(62, i, 8);
    const float roughness = 0.05f + 0.95f * chi2::rand01(62, i, 4), ior = 1.f + chi2::rand01(62, i, 5);
    const float d = i % 3 == 0 ? 0.f : chi2::rand01(62, i, 9);
    const Color cd = {chi2::rand01(62, i, 10), chi2::rand01(62, i, 11), chi2::rand01(62, i, 12)};
    Vec3 v = square_to_cosine_hemisphere(chi2::rand2(62, i, 6)), l = square_to_cosine_hemisphere(chi2::rand2(62, i, 7));
    if (!(v.z > 1e-3f && l.z > 1e-3f)) continue;
    Bsdf b = Bsdf::make_gltf_pbr_transmission(base, metallic, roughness, t, ior);
    b.gltf_pbr_transmission.diffuse_transmission = d;
    b.gltf_pbr_transmission.diffuse_transmission_color = cd;
    const std::array<double, 3> refl = reference(base, metallic, roughness, ior, v, l);
    const std::array<double, 3> diffuse_only = reference(base, 0.0, 1e9, ior, v, l);  // D → 0: the Lambert part alone
    const std::array<double, 3> spec_white = reference({0.f, 0.f, 0.f}, 1.0, roughness, ior, v, l);  // spec · w
    const std::array<double, 3> spec_black = reference({1.f, 1.f, 1.f}, 1.0, roughness, ior, v, l);  // spec
    const Vec3 below = {l.x, l.y, -l.z}, v_below = {v.x, v.y, -v.z};
    const Color fr = b.f(v, l), ft = b.f(v, below), ft2 = b.f(v_below, l);
    for (int k = 0; k < 3; ++k) {
      const double fd_diffuse = diffuse_only[k] * (1.0 - metallic);  // (1 - m)(1 - F) base / π
      const double expect_r = refl[k] - (1.0 - (1.0 - t) * (1.0 - d)) * fd_diffuse;
      const double w = spec_white[k] / spec_black[k];
      const double f0 = std::pow((ior - 1.0) / (ior + 1.0), 2.0), F = f0 + (1.0 - f0) * w;
      const double expect_t = (1.0 - metallic) * (1.0 - F) * (t * base[k] * spec_black[k] + (1.0 - t) * d * cd[k] / M_PI);
      ASSERT_NEAR(fr[k], expect_r, 1e-4 * refl[k] + 1e-6) << "reflection " << i;
      ASSERT_NEAR(ft[k], expect_t, 1e-4 * expect_t + 1e-6) << "transmission " << i;
      ASSERT_NEAR(ft2[k], ft[k], 1e-6 * ft[k] + 1e-9) << "from below " << i;
    }
  }
  // Pure Lambert where the specification's mix leaves only the diffuse part:
  // metallic 0, ior 1 (f0 = 0), wo = wi = n (|v·h| = 1, so F = 0): f = base / π.
  const Bsdf lambert = Bsdf::make_gltf_pbr({.8f, .4f, .2f}, 0.f, .5f, 1.f);
  const Color fn = lambert.f({0.f, 0.f, 1.f}, {0.f, 0.f, 1.f});
  EXPECT_NEAR(fn.x, .8f / kPi, 1e-7f);
  EXPECT_NEAR(fn.z, .2f / kPi, 1e-7f);
}

// Mitsuba 3's principled eval (src/bsdfs/principled.cpp and
// principledhelpers.h) written out again in double and in Mitsuba's own
// terms: si.wi the viewer, wo the other direction, the value including
// |cos θ_wo|, the GGX D and Smith G1 in Mitsuba's forms (principled.h takes
// them from microfacet.h's slopes and Λ), the exact dielectric Fresnel, its
// principled_fresnel, calc_schlick and GTR1.
namespace principled_ref {
using D3 = std::array<double, 3>;
struct V {
  double x, y, z;
};
double dot(V a, V b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V norm(V a) {
  const double l = std::sqrt(dot(a, a));
  return {a.x / l, a.y / l, a.z / l};
}
// Unit in double: near the critical angle F from the denser side (as
// Mitsuba takes it) amplifies a float direction's length error 10⁴ times.
V v3(Vec3 a) { return norm({a.x, a.y, a.z}); }
double ggx_d(V m, double ax, double ay) {
  if (m.z <= 0.0) return 0.0;
  const double t = m.x * m.x / (ax * ax) + m.y * m.y / (ay * ay) + m.z * m.z;
  return 1.0 / (3.14159265358979323846 * ax * ay * t * t);
}
double smith_g1(V v, V m, double ax, double ay) {
  if (dot(v, m) * v.z <= 0.0) return 0.0;
  const double t2 = (ax * ax * v.x * v.x + ay * ay * v.y * v.y) / (v.z * v.z);
  return 2.0 / (1.0 + std::sqrt(1.0 + t2));
}
double fresnel(double cos_i, double eta) {
  if (eta == 1.0) return 0.0;  // Mitsuba's special cases
  if (cos_i == 0.0) return 1.0;
  const double eta_it = cos_i >= 0.0 ? eta : 1.0 / eta, ci = std::fabs(cos_i);
  const double ct2 = 1.0 - (1.0 - ci * ci) / (eta_it * eta_it);
  if (ct2 <= 0.0) return 1.0;
  const double ct = std::sqrt(ct2);
  const double rs = (ci - eta_it * ct) / (ci + eta_it * ct), rp = (eta_it * ci - ct) / (eta_it * ci + ct);
  return 0.5 * (rs * rs + rp * rp);
}
double schlick_weight(double c) { return std::pow(std::clamp(1.0 - c, 0.0, 1.0), 5.0); }
double calc_schlick(double r0, double cos_i, double eta) {
  const double eta_it = cos_i >= 0.0 ? eta : 1.0 / eta;
  const double ct = std::sqrt(std::max(0.0, 1.0 - (1.0 - cos_i * cos_i) / (eta_it * eta_it)));
  const double w = eta_it > 1.0 ? schlick_weight(std::fabs(cos_i)) : schlick_weight(ct);
  return r0 + (1.0 - r0) * w;
}
double gtr1(V m, double alpha) {
  const double a2 = alpha * alpha;
  const double r = (a2 - 1.0) / (3.14159265358979323846 * std::log(a2) * (1.0 + (a2 - 1.0) * m.z * m.z));
  return r * m.z > 1e-20 ? r : 0.0;
}
// q: the parameters; has_trans: spec_trans given (Mitsuba's m_has_spec_trans).
D3 eval(const PrincipledParams& q, bool has_trans, V wi, V wo, bool radiance) {
  D3 value = {0.0, 0.0, 0.0};
  const double ci = wi.z, co = wo.z, eta = q.eta;
  if (ci == 0.0) return value;
  const double metallic = q.metallic, spec_trans = has_trans ? q.spec_trans : 0.0;
  const double brdf = (1.0 - metallic) * (1.0 - spec_trans), bsdf = (1.0 - metallic) * spec_trans;
  const bool reflect = ci * co > 0.0, refract = ci * co < 0.0, front = ci > 0.0;
  const double eta_path = front ? eta : 1.0 / eta;
  const double r2 = double(q.roughness) * q.roughness, aspect = std::sqrt(1.0 - 0.9 * q.anisotropic);
  const double ax = std::max(0.001, r2 / aspect), ay = std::max(0.001, r2 * aspect);
  const double k = reflect ? 1.0 : eta_path;
  V wh = norm({wi.x + wo.x * k, wi.y + wo.y * k, wi.z + wo.z * k});
  if (wh.z < 0.0) wh = {-wh.x, -wh.y, -wh.z};
  const double F = fresnel(dot(wi, wh), eta), s = front ? 1.0 : -1.0;
  const bool refl_ok = dot(wi, wh) * s > 0.0 && dot(wo, wh) * s > 0.0;
  const bool refr_ok = dot(wi, wh) * s > 0.0 && dot(wo, wh) * -s > 0.0;
  const double D = ggx_d(wh, ax, ay), G = smith_g1(wi, wh, ax, ay) * smith_g1(wo, wh, ax, ay);
  const double lum = 0.212671 * q.base_color.x + 0.715160 * q.base_color.y + 0.072169 * q.base_color.z;
  for (int c = 0; c < 3; ++c) {
    const double base = q.base_color[c], tint = lum > 0.0 ? base / lum : 1.0;
    double v = 0.0;
    if (reflect && refl_ok && F > 0.0) {
      const double cos_i = dot(wi, wh), eta_it = cos_i >= 0.0 ? eta : 1.0 / eta;
      const double r0 = std::pow((eta_it - 1.0) / (eta_it + 1.0), 2.0);
      const double fp = front ? (1.0 - metallic) * (1.0 - q.spec_tint) * F + metallic * calc_schlick(base, cos_i, eta) +
                                    (1.0 - metallic) * q.spec_tint * calc_schlick(tint * r0, cos_i, eta)
                              : bsdf * F;
      v += fp * D * G / (4.0 * std::fabs(ci));
    }
    if (has_trans && bsdf > 0.0 && refract && refr_ok && F < 1.0) {
      const double scale = radiance ? 1.0 / (eta_path * eta_path) : 1.0;
      const double a = dot(wi, wh), b = dot(wo, wh);
      v += std::sqrt(base) * bsdf *
           std::fabs(scale * (1.0 - F) * D * G * eta_path * eta_path * a * b / (ci * std::pow(a + eta_path * b, 2.0)));
    }
    if (q.clearcoat > 0.0 && reflect && refl_ok && front) {
      const double fcc = calc_schlick(0.04, dot(wi, wh), eta);
      const double alpha = 0.1 + (0.001 - 0.1) * q.clearcoat_gloss;
      v += q.clearcoat * 0.25 * fcc * gtr1(wh, alpha) * smith_g1(wi, wh, .25, .25) * smith_g1(wo, wh, .25, .25) *
           std::fabs(co);
    }
    if (brdf > 0.0 && reflect && front) {
      const double Fo = schlick_weight(std::fabs(co)), Fi = schlick_weight(std::fabs(ci));
      const double f_diff = (1.0 - 0.5 * Fi) * (1.0 - 0.5 * Fo), cos_d = dot(wh, wo);
      const double Rr = 2.0 * q.roughness * cos_d * cos_d, f_retro = Rr * (Fo + Fi + Fo * Fi * (Rr - 1.0));
      const double Fss = (1.0 + (Rr / 2.0 - 1.0) * Fo) * (1.0 + (Rr / 2.0 - 1.0) * Fi);
      const double f_ss = 1.25 * (Fss * (1.0 / (std::fabs(co) + std::fabs(ci)) - 0.5) + 0.5);
      const double mix = (f_diff + f_retro) + (f_ss - (f_diff + f_retro)) * q.flatness;
      v += brdf * std::fabs(co) * base / 3.14159265358979323846 * mix;
    }
    if (q.sheen > 0.0 && reflect && 1.0 - metallic > 0.0 && front) {
      const double Fd = schlick_weight(std::fabs(dot(wh, wo))), c_sheen = 1.0 + (tint - 1.0) * q.sheen_tint;
      v += q.sheen * (1.0 - metallic) * Fd * c_sheen * std::fabs(co);
    }
    value[size_t(c)] = v;
  }
  return value;
}
// principledthin's eval (principledthin.cpp): both directions mirrored
// to the front (wi.z > 0), wo_r = wo reflected to wi's side.
D3 eval_thin(const PrincipledThinBsdf& q, V wi, V wo) {
  D3 value = {0.0, 0.0, 0.0};
  if (wi.z == 0.0) return value;
  if (wi.z < 0.0) wi = {-wi.x, -wi.y, -wi.z}, wo = {-wo.x, -wo.y, -wo.z};
  const double ci = wi.z, co = wo.z, eta = q.eta, st = q.spec_trans, dt = q.diff_trans / 2.0;
  const bool reflect = co > 0.0, refract = co < 0.0;
  const V wor = {wo.x, wo.y, std::fabs(wo.z)};
  const V wh = norm({wi.x + wor.x, wi.y + wor.y, wi.z + wor.z});
  const bool refl_ok = dot(wi, wh) > 0.0 && dot(wo, wh) > 0.0, refr_ok = dot(wi, wh) > 0.0 && dot(wo, wh) < 0.0;
  const double r2 = double(q.roughness) * q.roughness, aspect = std::sqrt(1.0 - 0.9 * q.anisotropic);
  const double ax = std::max(0.001, r2 / aspect), ay = std::max(0.001, r2 * aspect);
  const double rs = (0.65 * eta - 0.35) * q.roughness, rs2 = rs * rs;
  const double sx = std::max(0.001, rs2 / aspect), sy = std::max(0.001, rs2 * aspect);
  const double F = fresnel(dot(wi, wh), eta);
  const double lum = 0.212671 * q.base_color.x + 0.715160 * q.base_color.y + 0.072169 * q.base_color.z;
  for (int c = 0; c < 3; ++c) {
    const double base = q.base_color[c], tint = lum > 0.0 ? base / lum : 1.0;
    double v = 0.0;
    if (st > 0.0 && reflect && refl_ok) {
      const double r0 = std::pow((eta - 1.0) / (eta + 1.0), 2.0);
      const double f_thin = (1.0 - q.spec_tint) * F + q.spec_tint * calc_schlick(tint * r0, dot(wi, wh), eta);
      v += st * f_thin * ggx_d(wh, ax, ay) * smith_g1(wi, wh, ax, ay) * smith_g1(wo, wh, ax, ay) / (4.0 * ci);
    }
    if (st > 0.0 && refract && refr_ok)
      v += st * base * (1.0 - F) * ggx_d(wh, sx, sy) * smith_g1(wi, wh, sx, sy) * smith_g1(wo, wh, sx, sy) / (4.0 * ci);
    if (reflect && st < 1.0 && dt < 1.0) {
      const double Fo = schlick_weight(std::fabs(co)), Fi = schlick_weight(ci), cos_d = dot(wh, wo);
      const double f_diff = (1.0 - 0.5 * Fi) * (1.0 - 0.5 * Fo);
      const double Rr = 2.0 * q.roughness * cos_d * cos_d, f_retro = Rr * (Fo + Fi + Fo * Fi * (Rr - 1.0));
      const double Fss = (1.0 + (Rr / 2.0 - 1.0) * Fo) * (1.0 + (Rr / 2.0 - 1.0) * Fi);
      const double f_ss = 1.25 * (Fss * (1.0 / (std::fabs(co) + ci) - 0.5) + 0.5);
      const double mix = (f_diff + f_retro) + (f_ss - (f_diff + f_retro)) * q.flatness;
      v += (1.0 - st) * co * base / 3.14159265358979323846 * (1.0 - dt) * mix;
      if (q.sheen > 0.0) {
        const double c_sheen = 1.0 + (tint - 1.0) * q.sheen_tint;
        v += q.sheen * (1.0 - st) * schlick_weight(std::fabs(cos_d)) * c_sheen * (1.0 - dt) * std::fabs(co);
      }
    }
    if (refract && st < 1.0 && dt > 0.0) v += (1.0 - st) * dt * base / 3.14159265358979323846 * std::fabs(co);
    value[size_t(c)] = v;
  }
  return value;
}
}  // namespace principled_ref

// principled.h against that reference, for random parameters (η on both
// sides of 1, some metallic 0 or 1, spec_trans 1) and random directions on
// the whole sphere, in both transport modes: f(v, l) |l.z| must match in
// every channel, to 1e-4 relative plus its float conditioning. The same for
// principledthin.
TEST(BsdfModels, PrincipledMatchesMitsubaFormulas) {
  uint64_t checked = 0, nonzero = 0;
  for (uint64_t i = 0; i < 40000; ++i) {
    auto u = [&](int k) { return chi2::rand01(71, i, k); };
    PrincipledParams q;
    q.base_color = {u(0), u(1), u(2)};
    if (i % 7 == 0) q.base_color = {0.f, 0.f, 0.f};
    q.roughness = i % 13 == 0 ? 0.05f * u(3) : 0.1f + 0.9f * u(3);  // below 0.032: α at its floor, 0.001
    q.anisotropic = i % 2 ? u(4) : 0.f;
    q.metallic = i % 4 == 0 ? 0.f : (i % 4 == 1 ? 1.f : u(5));
    q.spec_tint = u(6), q.sheen = u(7), q.sheen_tint = u(8), q.flatness = i % 3 ? u(9) : 0.f;
    q.clearcoat = i % 3 == 1 ? 0.f : u(10), q.clearcoat_gloss = u(11);
    q.eta = i % 5 == 0 ? 0.6f + 0.35f * u(12) : 1.05f + 1.5f * u(12);
    const bool trans = i % 2 == 0;
    if (i % 11 == 1 && !trans) q.eta = 1.f;  // no main reflection at all, even for metals
    q.spec_trans = trans ? (i % 8 == 0 ? 1.f : u(13)) : 0.f;
    const Bsdf b = Bsdf::make_principled(q, trans);
    Vec3 v = square_to_uniform_sphere(chi2::rand2(71, i, 14)), l = square_to_uniform_sphere(chi2::rand2(71, i, 15));
    if (!trans) v.z = std::fabs(v.z), l.z = std::fabs(l.z);
    if (!(std::fabs(v.z) > 1e-3f && std::fabs(l.z) > 1e-3f)) continue;
    for (TransportMode mode : {TransportMode::Radiance, TransportMode::Importance}) {
      const principled_ref::D3 r =
          principled_ref::eval(q, trans, principled_ref::v3(v), principled_ref::v3(l), mode == TransportMode::Radiance);
      const Color f = b.f(v, l, mode) * std::fabs(l.z);
      // Float conditioning, as in Reciprocity: 4 times the change of f when
      // either direction moves by ~4 roundings (F near the critical angle).
      const Color fp = b.f(normalize(v + Vec3{0x1p-21f, 0x1p-21f, 0.f}), l, mode) * std::fabs(l.z),
                  fq = b.f(v, normalize(l + Vec3{0x1p-21f, -0x1p-21f, 0.f}), mode) * std::fabs(l.z);
      for (int k = 0; k < 3; ++k) {
        const double sens = 4.0 * std::max(std::fabs(fp[k] - f[k]), std::fabs(fq[k] - f[k]));
        ASSERT_NEAR(f[k], r[size_t(k)], 1e-4 * r[size_t(k)] + sens + 1e-7) << "pair " << i << " channel " << k;
      }
      nonzero += !is_black(f);
    }
    ++checked;
  }
  EXPECT_GT(checked, 39000u);
  EXPECT_GT(nonzero, 40000u);
  // principledthin, on both sides (the same in both transport modes).
  uint64_t thin_checked = 0;
  for (uint64_t i = 0; i < 20000; ++i) {
    auto u = [&](int k) { return chi2::rand01(73, i, k); };
    PrincipledThinBsdf q;
    q.base_color = {u(0), u(1), u(2)};
    q.roughness = i % 13 == 0 ? 0.05f * u(3) : 0.1f + 0.9f * u(3);
    q.anisotropic = i % 2 ? u(4) : 0.f;
    q.spec_trans = i % 4 == 0 ? 0.f : (i % 4 == 1 ? 1.f : u(5));
    q.diff_trans = i % 3 == 0 ? 0.f : 2.f * u(6);
    q.spec_tint = u(7), q.sheen = i % 2 ? u(8) : 0.f, q.sheen_tint = u(9), q.flatness = i % 3 ? u(10) : 0.f;
    q.eta = 1.f + 1.5f * u(11);
    const Bsdf b = Bsdf::make_principled_thin(q);
    const Vec3 v = square_to_uniform_sphere(chi2::rand2(73, i, 14)), l = square_to_uniform_sphere(chi2::rand2(73, i, 15));
    if (!(std::fabs(v.z) > 1e-3f && std::fabs(l.z) > 1e-3f)) continue;
    const principled_ref::D3 r = principled_ref::eval_thin(q, principled_ref::v3(v), principled_ref::v3(l));
    const Color f = b.f(v, l) * std::fabs(l.z), fi = b.f(v, l, TransportMode::Importance) * std::fabs(l.z);
    const Color fp = b.f(normalize(v + Vec3{0x1p-21f, 0x1p-21f, 0.f}), l) * std::fabs(l.z),
                fq = b.f(v, normalize(l + Vec3{0x1p-21f, -0x1p-21f, 0.f})) * std::fabs(l.z);
    for (int k = 0; k < 3; ++k) {
      const double sens = 4.0 * std::max(std::fabs(fp[k] - f[k]), std::fabs(fq[k] - f[k]));
      ASSERT_NEAR(f[k], r[size_t(k)], 1e-4 * r[size_t(k)] + sens + 1e-7) << "thin pair " << i << " channel " << k;
      ASSERT_EQ(fi[k], f[k]) << "thin pair " << i;
    }
    ++thin_checked;
  }
  EXPECT_GT(thin_checked, 19000u);
  // Metallic 1 is the Disney (and glTF) metal: Schlick's Fresnel of the base
  // colour over isotropic GGX with separable masking, α = roughness².
  for (uint64_t i = 0; i < 2000; ++i) {
    PrincipledParams q;
    q.base_color = {chi2::rand01(72, i, 0), chi2::rand01(72, i, 1), chi2::rand01(72, i, 2)};
    q.metallic = 1.f;
    q.roughness = 0.1f + 0.9f * chi2::rand01(72, i, 3);
    const Bsdf p = Bsdf::make_principled(q, false), g = Bsdf::make_gltf_pbr(q.base_color, 1.f, q.roughness);
    const Vec3 v = square_to_cosine_hemisphere(chi2::rand2(72, i, 4)), l = square_to_cosine_hemisphere(chi2::rand2(72, i, 5));
    const Color fp = p.f(v, l), fg = g.f(v, l);
    for (int k = 0; k < 3; ++k) ASSERT_NEAR(fp[k], fg[k], 1e-5f * fg[k] + 1e-9f) << i;
  }
}

// Rough plastic's tables in the smooth limit (α = 1e-3): the coat's
// transmittance T(μ) at the table's own nodes is 1 - F(μ) and R_int is the
// smooth coat's F_dr seen from inside, up to O(α²) (the facets' normals
// spread by ~α; first-order changes of F cancel) and the table's 16-bit
// rounding; bound 1e-3. Grazing nodes (μ < 0.2), where masking acts even
// for tiny α, are left out. Also prints R_int before and after its cap.
TEST(BsdfModels, RoughPlasticTablesInTheSmoothLimit) {
  for (float eta : {1.49f, 2.4f, 1.1f}) {
    Bsdf b = Bsdf::make_rough_plastic(MicrofacetType::Beckmann, 1e-3f, kWhite, kWhite, eta, 1.f);
    const RoughPlasticBsdf& p = b.rough_plastic;
    for (int i = 0; i < RoughPlasticBsdf::kTableSize; ++i) {
      float mu = float(i) / (RoughPlasticBsdf::kTableSize - 1);
      if (mu < 0.2f) continue;
      EXPECT_NEAR(p.external_transmittance(mu), 1.f - fresnel_dielectric(mu, eta).F, 1e-3f) << eta << " μ " << mu;
    }
    EXPECT_NEAR(p.internal_reflectance, fresnel_diffuse_reflectance(1.f / eta), 1e-3f) << eta;
  }
  for (MicrofacetType t : {MicrofacetType::Beckmann, MicrofacetType::GGX})
    for (float a : {.01f, .3f})
      for (float eta : {1.49f, 2.4f}) {
        Bsdf b = Bsdf::make_rough_plastic(t, a, kWhite, kWhite, eta, 1.f);
        std::printf("roughplastic %s α %.2f η %.2f: R_int quadrature %.5f, used %.5f\n",
                    t == MicrofacetType::GGX ? "ggx" : "beckmann", a, eta,
                    rough_coat_internal_reflectance(t, a, b.rough_plastic.eta), b.rough_plastic.internal_reflectance);
      }
}
