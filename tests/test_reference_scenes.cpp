// Whole images of the shared scenes (DESIGN.md, validation layer 4):
//   - against Bitterli's Tungsten references (reference/TungstenRender.exr),
//     beside those elsewhere: the Cornell box's Mitsuba file
//     (test_reference.cpp) and pbrt-v4 file (test_pbrt.cpp), veach-mis's
//     Mitsuba file (test_materials.cpp), the staircase's image mean
//     (test_textures.cpp);
//   - across formats: the same scene in two formats renders the same image.
//
// Every render is small (the reference's size divided by an integer, box
// pixel filter, independent sampler, fixed seed) and compared over blocks of
// b×b Luz pixels, per block and channel:
//
//   |a - b| ≤ z · sqrt(σ²_a + σ²_b + (tol · (a + b) / 2)²)
//
//   σ²   the variance of a block mean: for a Luz render, from its own
//        per-pixel sample variance; for a Tungsten reference, from its
//        neighbour residuals (stat_helpers.h's reference_blocks);
//   tol  the conversion tolerance, relative, stated at each test: what the
//        scene's conversion cannot match exactly (0 where nothing is left);
//   z    Šidák-corrected over the blocks and channels compared and the three
//        image means, family level 1e-3.
//
// Blocks a test cannot compare (a material with no exact Luz equivalent)
// are named by the scene's own geometry (coverage(), below), left out, and
// their difference printed. The same bound holds for each channel's mean over
// the blocks compared. Each comparison prints its worst block, its means and
// the mean z² against the noise alone (about 1 when only noise is left), and
// checks its own power: the Luz image made 5% brighter must fail it.
//
// Tungsten's path length: its max_bounces counts path segments, as Mitsuba's
// max_depth does (PathTracer::traceSample and TraceBase::handleSurface:
// emission is added while bounce < max_bounces, next-event estimation while
// bounce < max_bounces - 1, so max_bounces 2 is direct light only).
// Bitterli's exporter wrote max_bounces + 1 into both the Mitsuba
// (max_depth) and the pbrt-v4 (maxdepth) files, so a reference matches Luz's
// max_depth = the Mitsuba file's - 1 = the pbrt file's maxdepth - 1. Where
// that matters (veach-mis, veach-bidir) the tests set it; the files' own
// depth is asserted as loaded first. (test_materials.cpp found max_depth 2
// for veach-mis by its images; this is why.)
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "luz/bsdf/fresnel.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "luz/render/aov.h"
#include "scene_helpers.h"
#include "stat_helpers.h"
#include "temp_dir.h"

using namespace luz;

namespace {

constexpr double kFamilyAlpha = 1e-3;
const std::string kScenes = LUZ_SHARED_DIR "/scenes/";

// Block means and the variance of each, 3 per block (RGB).
struct BlockImage {
  int nx = 0, ny = 0;
  std::vector<double> mean, var;
};

BlockImage luz_blocks(const Film& film, int b) {
  luz_test::Blocks L = luz_test::make_blocks(film, b);
  return {L.bw, L.bh, std::move(L.mean), std::move(L.var)};
}

// The reference box-averaged onto the Luz grid of width × height, in blocks of b × b.
BlockImage reference_blocks(const std::string& scene_dir, int width, int height, int b) {
  Image ref = read_exr(kScenes + scene_dir + "/reference/TungstenRender.exr");
  const int f = ref.width / width;  // reference pixels per Luz pixel, per axis
  EXPECT_EQ(ref.width, f * width);
  EXPECT_EQ(ref.height, f * height);
  luz_test::ReferenceBlocks R = luz_test::reference_blocks(ref, width / b, height / b, b * f);
  std::printf("[reference] %s: per-pixel noise median %.2f%% relative\n", scene_dir.c_str(),
              100 * R.rel_noise_median);
  return {width / b, height / b, std::move(R.mean), std::move(R.var)};
}

// A shared scene set up for a comparison render: width × height (its field of
// view kept), box filter, independent sampler, path tracer.
Scene load(const std::string& file, int width, int height, uint32_t spp, uint64_t seed,
           const std::vector<std::string>& search = {}) {
  Scene s = load_scene(file.front() == '/' ? file : kScenes + file, {}, search);
  s.set_resolution(width, height);
  s.settings.integrator.type = IntegratorType::Path;
  s.settings.sampler = SamplerType::Independent;
  s.settings.filter = FilterKind::Box;
  s.settings.spp = spp;
  s.settings.seed = seed;
  return s;
}

Film render(const Scene& s, const char* what) {
  auto t0 = std::chrono::steady_clock::now();
  Film film = luz_test::render_finite(s);
  double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[render] %s: %dx%d, %u spp, %.1f s\n", what, s.camera.width, s.camera.height, s.settings.spp, secs);
  return film;
}

// What a comparison leaves out and allows: tol (relative, every block), and
// skip (1 per block; empty: none skipped).
struct Allowance {
  double tol = 0;
  std::vector<char> skip;
};

struct Outcome {
  int failures = 0;
  double worst = 0, noise_z2 = 0;  // worst z; mean z² against the noise alone
};

// The comparison of the header, `a` scaled by `gain` (1: as rendered).
Outcome evaluate(const BlockImage& a, const BlockImage& b, const Allowance& al, double gain, const char* label) {
  const bool print = label != nullptr;
  const size_t nb = size_t(a.nx) * a.ny;
  size_t compared = 0;
  for (size_t k = 0; k < nb; ++k) compared += al.skip.empty() || !al.skip[k];
  const double thr = luz_test::sidak_z(kFamilyAlpha, 3.0 * compared + 3);
  Outcome o;
  size_t worst_at = 0;
  double am[3] = {}, av[3] = {}, bm[3] = {}, bv[3] = {};
  for (size_t i = 0; i < 3 * nb; ++i) {
    if (!al.skip.empty() && al.skip[i / 3]) continue;
    const double ai = gain * a.mean[i], vi = gain * gain * a.var[i];
    const double d = ai - b.mean[i], m = 0.5 * (ai + b.mean[i]);
    const double floor = luz_test::rounding_floor(m), noise = vi + b.var[i] + floor * floor;
    const double t = al.tol * m;
    const double z = std::fabs(d) / std::sqrt(noise + t * t);
    o.noise_z2 += d * d / noise;
    am[i % 3] += ai, av[i % 3] += vi, bm[i % 3] += b.mean[i], bv[i % 3] += b.var[i];
    if (z > o.worst) o.worst = z, worst_at = i;
    if (z > thr) {
      ++o.failures;
      if (print)
        std::printf("  %s block (%2zu,%2zu) ch %zu: %.5f vs %.5f (%+.2f%%), sigma %.5f %.5f, z %.2f\n", label,
                    i / 3 % a.nx, i / 3 / a.nx, i % 3, ai, b.mean[i], 100 * (ai / b.mean[i] - 1), std::sqrt(vi),
                    std::sqrt(b.var[i]), z);
    }
  }
  o.noise_z2 /= 3.0 * compared;
  for (int c = 0; c < 3; ++c) {
    const double n = double(compared), ma = am[c] / n, mb = bm[c] / n, va = av[c] / (n * n), vb = bv[c] / (n * n);
    const double t = al.tol * 0.5 * (ma + mb), z = std::fabs(ma - mb) / std::sqrt(va + vb + t * t);
    if (z > thr) ++o.failures;
    if (print)
      std::printf("[%s] channel %d: mean %.5f vs %.5f, %+.3f%% (sigma %.3f%% %.3f%%), z %.2f\n", label, c, ma, mb,
                  100 * (ma / mb - 1), 100 * std::sqrt(va) / mb, 100 * std::sqrt(vb) / mb, z);
  }
  if (print)
    std::printf("[%s] %zu of %zu blocks, tol %.1f%%: worst z %.2f at (%zu,%zu) ch %zu, threshold %.2f; "
                "mean z² against noise alone %.2f; %d over\n",
                label, compared, nb, 100 * al.tol, o.worst, worst_at / 3 % a.nx, worst_at / 3 / a.nx, worst_at % 3,
                thr, o.noise_z2, o.failures);
  return o;
}

// Compares (printing), and checks the comparison's power; returns the failures.
int compare(const BlockImage& a, const BlockImage& b, const Allowance& al, const char* label) {
  EXPECT_EQ(a.nx, b.nx);
  EXPECT_EQ(a.ny, b.ny);
  EXPECT_GT(evaluate(a, b, al, 1.05, nullptr).failures, 0) << label << ": a 5% brighter image passes";
  return evaluate(a, b, al, 1.0, label).failures;
}

// The share of each block where camera rays first meet a material `pick`
// selects (0..1, 1 per block, b × b pixels each): the albedo AOV of the
// scene with those materials white and every other one black.
template <class Pick>
std::vector<double> coverage(const Scene& scene, Pick pick, int b) {
  Scene s = scene;
  for (Material& m : s.materials) {
    const bool hit = pick(m.bsdf);
    m = Material{};
    m.bsdf = Bsdf::make_diffuse(hit ? Color{1, 1, 1} : Color{0, 0, 0}, true);
  }
  s.texture_bindings.clear();
  const AovImages a = render_aovs(s, 16, 1, 2);
  const int nx = a.width / b, ny = a.height / b;
  std::vector<double> c(size_t(nx) * ny, 0.0);
  for (int y = 0; y < ny * b; ++y)
    for (int x = 0; x < nx * b; ++x)
      c[size_t(y / b) * nx + x / b] += a.albedo[3 * (size_t(y) * a.width + x)] / (double(b) * b);
  return c;
}

// Blocks covered at all, and those within r blocks of them (which see the
// covered surface's reflected light, or its caustics, nearby).
std::vector<char> covered_and_around(const std::vector<double>& cov, int nx, int ny, int r) {
  std::vector<char> skip(cov.size(), 0);
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x)
      if (cov[size_t(y) * nx + x] > 0)
        for (int v = std::max(0, y - r); v <= std::min(ny - 1, y + r); ++v)
          for (int u = std::max(0, x - r); u <= std::min(nx - 1, x + r); ++u) skip[size_t(v) * nx + u] = 1;
  return skip;
}

// Luz's image over the reference, per channel, over the covered blocks
// weighted by their coverage (what a left-out material renders as).
void print_covered(const BlockImage& a, const BlockImage& b, const std::vector<double>& cov, const char* label) {
  double s[2][3] = {};
  for (size_t k = 0; k < cov.size(); ++k)
    for (int c = 0; c < 3; ++c) s[0][c] += cov[k] * a.mean[3 * k + c], s[1][c] += cov[k] * b.mean[3 * k + c];
  std::printf("[%s] left out: luz/reference %.3f %.3f %.3f (coverage-weighted)\n", label, s[0][0] / s[1][0],
              s[0][1] / s[1][1], s[0][2] / s[1][2]);
}

// Heavy-tailed blocks: each block's variance raised to its 3×3
// neighbourhood's mean relative variance times its own mean², where larger.
void pool_variance(BlockImage& a) {
  std::vector<double> v = a.var;
  for (int y = 0; y < a.ny; ++y)
    for (int x = 0; x < a.nx; ++x)
      for (int c = 0; c < 3; ++c) {
        double rel = 0;
        int n = 0;
        for (int j = std::max(0, y - 1); j <= std::min(a.ny - 1, y + 1); ++j)
          for (int i = std::max(0, x - 1); i <= std::min(a.nx - 1, x + 1); ++i) {
            const size_t k = 3 * (size_t(j) * a.nx + i) + c;
            if (a.mean[k] > 0) rel += a.var[k] / (a.mean[k] * a.mean[k]), ++n;
          }
        const size_t k = 3 * (size_t(y) * a.nx + x) + c;
        if (n) v[k] = std::max(v[k], rel / n * a.mean[k] * a.mean[k]);
      }
  a.var = std::move(v);
}

bool same(Color a, Color b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

// The rough conductors: how many, and each as the file gave it.
int rough_conductors(const Scene& s, MicrofacetType d, Color spec) {
  int n = 0;
  for (const Material& m : s.materials)
    if (m.bsdf.type == BsdfType::RoughConductor) {
      ++n;
      EXPECT_EQ(m.bsdf.rough_conductor.distribution, d);
      EXPECT_TRUE(same(m.bsdf.rough_conductor.specular_reflectance, spec));
    }
  return n;
}

// Tungsten's rough conductors where the pbrt-v4 file cannot say them:
// Beckmann (pbrt-v4's conductor is always Trowbridge-Reitz) and a
// reflectance scale (pbrt-v4's conductor has none).
void as_tungsten_conductors(Scene& s, float scale) {
  for (Material& m : s.materials)
    if (m.bsdf.type == BsdfType::RoughConductor) {
      m.bsdf.rough_conductor.distribution = MicrofacetType::Beckmann;
      m.bsdf.rough_conductor.specular_reflectance = m.bsdf.rough_conductor.specular_reflectance * scale;
    }
}

// Tungsten's rough_plastic where Luz's (Mitsuba 3's) roughplastic differs:
// the diffuse base seen through the smooth interface's Fresnel terms,
// T(μ) = 1 - F(μ), and sent back by its internal diffuse reflectance,
// instead of the rough coat's tabulated T(μ) and R_int
// (Tungsten's RoughPlasticBsdf::eval; bsdf/roughplastic.h). Returns how many.
int as_tungsten_rough_plastic(Scene& s) {
  int n = 0;
  for (Material& m : s.materials)
    if (m.bsdf.type == BsdfType::RoughPlastic) {
      RoughPlasticBsdf& p = m.bsdf.rough_plastic;
      for (int i = 0; i < RoughPlasticBsdf::kTableSize; ++i) {
        const float mu = std::max(1e-6f, float(i) / (RoughPlasticBsdf::kTableSize - 1));
        p.transmittance[i] = uint16_t(std::floor((1.f - fresnel_dielectric(mu, p.eta).F) * 65535.f));
      }
      p.internal_reflectance = fresnel_diffuse_reflectance(1.f / p.eta);
      ++n;
    }
  return n;
}

// Tungsten's decoding of 8-bit textures: a gamma of 2.2 through an 8-bit
// table, floor(255 (k/255)^2.2) / 255 (ImageIO's GammaCorrection), where Luz
// decodes sRGB: 1.2% brighter at k = 200, 14% darker at k = 50.
void as_tungsten_textures(Scene& s) {
  ASSERT_EQ(s.srgb_table.size(), 256u);
  for (int k = 0; k < 256; ++k) s.srgb_table[k] = float(std::floor(255.0 * std::pow(k / 255.0, 2.2)) / 255.0);
}

// The staircase's aluminium and steel as Mitsuba's file has them: their
// specular_reflectance 0.578596, which pbrt-v4's conductor cannot say (the
// pbrt-v4 file's are unscaled); found by their eta.
void staircase_metals_as_mitsuba(Scene& s) {
  int n = 0;
  for (Material& m : s.materials) {
    Color* eta = m.bsdf.type == BsdfType::RoughConductor    ? &m.bsdf.rough_conductor.eta
                 : m.bsdf.type == BsdfType::SmoothConductor ? &m.bsdf.smooth_conductor.eta
                                                             : nullptr;
    if (!eta || std::fabs(eta->x - 1.65746f) > 1e-5f) continue;
    Color& r = m.bsdf.type == BsdfType::RoughConductor ? m.bsdf.rough_conductor.specular_reflectance
                                                       : m.bsdf.smooth_conductor.specular_reflectance;
    EXPECT_TRUE(same(r, {1, 1, 1}));
    r = r * 0.578596f;
    ++n;
  }
  EXPECT_EQ(n, 2);  // BrushedAluminium, StainlessSteel
}

}  // namespace

// ---- against Tungsten ----

// The pbrt-v4 file cannot say Tungsten's plates: pbrt-v4's conductor is
// always Trowbridge-Reitz (Tungsten's are Beckmann) and has no reflectance
// scale (Tungsten's albedo 0.3, the Mitsuba file's specular_reflectance).
// Measured with max_depth 2: as loaded (GGX, unscaled) the image mean is
// +34..+56% and 141 blocks and means are over; scaled but GGX, 93. The
// loader's translation is checked as the file says, then the plates are
// made Tungsten's and the whole image must match.
TEST(ReferenceScenes, VeachMisPbrtMatchesTungsten) {
  Scene s = load("veach-mis-bitterli/pbrt-v4/scene-v4.pbrt", 160, 90, 64, 13);
  EXPECT_EQ(s.settings.integrator.max_depth, 4);  // maxdepth 3
  EXPECT_EQ(rough_conductors(s, MicrofacetType::GGX, {1, 1, 1}), 4);
  std::vector<float> alphas;
  for (const Material& m : s.materials)
    if (m.bsdf.type == BsdfType::RoughConductor) alphas.push_back(m.bsdf.rough_conductor.alpha_u);
  std::sort(alphas.begin(), alphas.end());
  EXPECT_EQ(alphas, (std::vector<float>{0.01f, 0.05f, 0.1f, 0.25f}));  // remaproughness false
  s.settings.integrator.max_depth = 2;
  as_tungsten_conductors(s, 0.3f);
  Film f = render(s, "veach-mis pbrt-v4, Tungsten's plates");
  BlockImage ref = reference_blocks("veach-mis-bitterli", 160, 90, 10);
  EXPECT_EQ(compare(luz_blocks(f, 10), ref, {}, "veach-mis pbrt-v4 / tungsten"), 0);
}

// The lamp's conductor made Beckmann as Tungsten's (pbrt-v4 cannot say it;
// with GGX the lamp's blocks are up to 6σ off at 512 spp) and the depth
// Tungsten's (maxdepth 7: 6 segments; Luz's 8 is +1.1% on the image mean at
// 512 spp, 6 is within 0.2%). The reference was rendered bidirectionally:
// the glass egg's caustics (light through glass onto the table; sparkles in
// the egg) are rare, bright paths for a path tracer, so a block there that
// misses them understates both its mean and its variance (measured: the
// egg's top block -25% at 1024 spp, -16% at 2048, z ≈ -6 each time, while
// two Luz renders agree with each other). The egg and the blocks around it
// are left out. Rarer caustic paths reach the rest of the room too, so each
// block's variance is pooled with its neighbours' (pool_variance). Measured
// over 12 seeds at these settings: mean z² 0.5–1.4, and one seed of the 12
// over, by z 4.57 against 4.52, in a dark corner of the ceiling.
TEST(ReferenceScenes, VeachBidirPbrtMatchesTungsten) {
  Scene s = load("veach-bidir/pbrt-v4/scene-v4.pbrt", 64, 64, 256, 14);
  EXPECT_EQ(s.settings.integrator.max_depth, 8);  // maxdepth 7
  EXPECT_EQ(rough_conductors(s, MicrofacetType::GGX, {1, 1, 1}), 1);
  s.settings.integrator.max_depth = 6;
  as_tungsten_conductors(s, 1.f);
  Film f = render(s, "veach-bidir pbrt-v4");
  const int b = 8, n = 64 / b;
  const std::vector<double> egg = coverage(s, [](const Bsdf& m) { return m.type == BsdfType::SmoothDielectric; }, b);
  BlockImage ref = reference_blocks("veach-bidir", 64, 64, b), L = luz_blocks(f, b);
  pool_variance(L);
  Allowance al;
  al.skip = covered_and_around(egg, n, n, 1);
  print_covered(L, ref, egg, "veach-bidir egg");
  EXPECT_EQ(compare(L, ref, al, "veach-bidir pbrt-v4 / tungsten"), 0);
}

namespace {

// The test ball against Tungsten with the ball's material left out: the
// floor, the stand, the environment and the ball's shadow must match.
// `ball` picks the ball's material as Luz loaded it.
template <class Pick>
void testball_matches_tungsten(Scene& s, Pick ball, const char* label) {
  EXPECT_EQ(s.num_triangles(), 80770u);
  Film f = render(s, label);
  const int b = 10;
  const std::vector<double> cov = coverage(s, ball, b);
  BlockImage ref = reference_blocks("material-testball", 160, 90, b), L = luz_blocks(f, b);
  Allowance al;
  al.skip = covered_and_around(cov, 160 / b, 90 / b, 2);
  print_covered(L, ref, cov, label);
  EXPECT_EQ(compare(L, ref, al, label), 0);
}

}  // namespace

// The ball is a smooth dielectric coat (index 1.7, absorbing: sigma_a
// (0.1, 0.2, 0.5), thickness 5) over rough copper, the Mitsuba file's
// `coating`. Luz has no layered model: its reader renders the copper seen
// through the coat at normal incidence (io/mitsuba/bsdfs.cpp), without the
// coat's own reflection of the environment (6.7% at normal incidence, all of
// it at grazing), which is most of the ball's blue in the reference (Luz's
// is ~exp(-5) of the copper's). Measured over the ball (coverage-weighted):
// luz/reference 0.93, 0.59, 0.28. The ball and the blocks within two of it
// (the floor there sees the ball's light) are left out: the floor, the
// environment and the ball's shadow remain. The file's OBJ meshes were not
// shipped: the pbrt-v4 folder's PLY meshes of the same names stand in.
TEST(ReferenceScenes, MaterialTestballMitsubaMatchesTungsten) {
  Scene s = load("material-testball/mitsuba/scene.xml", 160, 90, 64, 16, {kScenes + "material-testball/pbrt-v4"});
  EXPECT_TRUE(luz_test::has_warning(s, "coating over a conductor is rendered as the conductor seen through the coat"));
  EXPECT_EQ(s.settings.integrator.max_depth, 65);
  testball_matches_tungsten(s, [](const Bsdf& m) { return m.type == BsdfType::RoughConductor; }, "testball mitsuba");
}

// The pbrt-v4 file's ball is another material: `coateddiffuse` of an orange
// reflectance under a smooth coat, which Bitterli's exporter wrote for the
// coated copper (pbrt-v4 has no absorbing coat over a conductor in one
// material); Luz renders it as rough plastic (io/pbrt/scene.cpp). Measured
// over the ball: luz/reference 0.63, 0.73, 0.81. Its light on the floor is
// diffuse and reaches farther than the copper's: leaving out one block
// around the ball, the red image mean is -0.73% (z 5.9); two, as here,
// -0.45%. The environment map is the .hdr beside the missing .pfm, read as
// latitude-longitude (the loader's documented fallback).
TEST(ReferenceScenes, MaterialTestballPbrtMatchesTungsten) {
  Scene s = load("material-testball/pbrt-v4/scene-v4.pbrt", 160, 90, 64, 17);
  EXPECT_TRUE(luz_test::has_warning(s, "envmap.pfm' not found: using 'textures/envmap.hdr'"));
  EXPECT_EQ(s.settings.integrator.max_depth, 66);
  testball_matches_tungsten(s, [](const Bsdf& m) { return m.type == BsdfType::RoughPlastic; }, "testball pbrt-v4");
}

// The staircase against Tungsten, per block, three blocks left out (below).
// Tungsten's wood and paints are its
// rough_plastic, which Luz's roughplastic (Mitsuba 3's) does not match:
// Tungsten sees the diffuse base through the smooth interface's Fresnel terms
// and returns light to it by the smooth internal diffuse reflectance (0.596
// inside an index 1.5), where Luz tabulates the rough coat's (R_int 0.560
// for GGX α 0.1, 0.495 for 0.2), so Tungsten's nonlinear base
// 1 / (1 - ρ R_int) is brighter, most for the red of the wood. And Tungsten
// decodes the JPEG textures by a 2.2 gamma table, not sRGB. Both are given to
// the loaded scene (as_tungsten_rough_plastic, as_tungsten_textures), then
// tol 0. Measured at 90×160, 64 spp, Mitsuba file (pbrt-v4 file): as loaded,
// image mean -3.6% (-3.5%) red, -1.9% (-1.7%) green, -0.5% (-0.3%) blue,
// 33 (35) blocks and means over, the worst -8.2% red (z 10.7) on the stairs;
// with Tungsten's rough_plastic only, -1.1% (-0.9%) red, 3 (3) over; with
// both, image means within 0.4% and every block within noise (mean z² 1.5
// at 256 spp) but (3,10), under the table's front: Luz -15% green, -21% blue
// at 256 spp (z 8.4, 11.0), the same in both formats and every seed tried.
// Its neighbours under the stairs are heavy-tailed (caustics through the
// chandelier's glass, as test_textures.cpp notes): at 45×80 with blocks of
// 5, (4,9) is -29% at 256 spp and +6% at 2048; but (3,10) stays -14% green,
// -17% blue (16384 spp). Not noise, and not a model of Luz's: it is one
// highlight on the block's top edge. The table's gold trim (a smooth
// conductor) mirrors the ceiling light in a band about 0.3 reference pixels
// tall at reference row 799.5, the last row of (3,9), and
//   - Tungsten's pixel filter is a tent of radius one reference pixel
//     (ReconstructionFilter's default, "tent", width 1; the Mitsuba file's
//     rfilter is tent too), which carries part of the band into row 800, the
//     first of (3,10), where Luz's box pixels, eight reference pixels wide,
//     cannot. Rendered by Luz at the reference's resolution with the tent,
//     (3,10) is -5% green, -6% blue, all of it in row 800: rows 801-879 agree
//     within 0.3%.
//   - The band itself differs: Tungsten's is 15-17% dimmer over rows 797-801
//     and spread more into rows 798 and 800 (green over the block's width:
//     0.21, 1.66, 0.40 against Luz's 0.17, 2.28, 0.30 with the tent), while
//     the chandelier's highlights of the same light match pixel for pixel.
//     The reflected rays sweep ~20° across the band (2 mm of trim), whose
//     edges are where the staircase's underside and the chandelier's arms
//     cut them off the light; a fraction of a millimetre moves them. Not
//     settled: no Tungsten scene file is at hand. (3,9) has the other side,
//     Luz +15% green (4096 spp, σ 2.2%), within noise at these settings.
// The comparison cannot allow for either without rendering at the
// reference's resolution, so (3,9) and (3,10), the blocks the band
// straddles at these settings, are left out. So is (4,9), under the stairs:
// caustics through the chandelier's glass, which a path tracer finds
// rarely: 2 seeds in 16 had it 30-35% low (z 5-6) at 64 spp, and at 1024
// spp it is within noise. Each block's variance is pooled with its
// neighbours' (pool_variance: the same heavy tails, rarer, reach other
// dark blocks: without it 2 of 24 seeds failed a block in a dark corner).
// Measured over seeds 1-24 at these settings, both files: no block over,
// mean z² 0.57-0.89. The pbrt-v4 file's
// metals are given their reflectance scale too (staircase_metals_as_mitsuba).
void staircase_matches_tungsten(const std::string& file, bool pbrt, const char* label) {
  Scene s = load(file, 90, 160, 64, pbrt ? 19 : 18);
  EXPECT_EQ(s.num_triangles(), 262663u);  // SOURCES.md's count
  EXPECT_EQ(s.settings.integrator.max_depth, pbrt ? 66 : 65);
  if (pbrt) staircase_metals_as_mitsuba(s);
  EXPECT_EQ(as_tungsten_rough_plastic(s), 6);
  as_tungsten_textures(s);
  Film f = render(s, label);
  const int b = 10, nx = 90 / b, ny = 160 / b;
  Allowance al;
  al.skip.assign(size_t(nx) * ny, 0);
  al.skip[size_t(9) * nx + 3] = al.skip[size_t(10) * nx + 3] = al.skip[size_t(9) * nx + 4] = 1;
  BlockImage L = luz_blocks(f, b);
  pool_variance(L);
  EXPECT_EQ(compare(L, reference_blocks("staircase", 90, 160, b), al, label), 0);
}

TEST(ReferenceScenes, StaircaseMitsubaMatchesTungsten) {
  staircase_matches_tungsten("staircase/mitsuba/scene.xml", false, "staircase mitsuba / tungsten");
}
TEST(ReferenceScenes, StaircasePbrtMatchesTungsten) {
  staircase_matches_tungsten("staircase/pbrt-v4/scene-v4.pbrt", true, "staircase pbrt-v4 / tungsten");
}

// ---- across formats ----

namespace {

// Two Luz renders of one scene in two formats, compared with `al`.
void same_image(const Scene& a, const Scene& b, int block, const Allowance& al, const char* label) {
  ASSERT_EQ(a.camera.width, b.camera.width);
  ASSERT_EQ(a.camera.height, b.camera.height);
  Film fa = render(a, label), fb = render(b, label);
  EXPECT_EQ(compare(luz_blocks(fa, block), luz_blocks(fb, block), al, label), 0);
}

}  // namespace

// Bitterli's box, pbrt-v4 against Mitsuba 3: trianglemesh against rectangles
// and cubes, pbrt's camera frame and fov against Mitsuba's. Nothing to allow
// for (max_depth 66 against 65: a ~0.7^65 difference).
TEST(CrossFormat, CornellBoxPbrtMatchesMitsuba) {
  Scene p = load("cornell-box-bitterli/pbrt-v4/scene-v4.pbrt", 64, 64, 256, 21);
  Scene m = load("cornell-box-bitterli/mitsuba3/scene_v3.xml", 64, 64, 256, 22);
  same_image(p, m, 4, {}, "cornell-box pbrt-v4 / mitsuba3");
}

// pbrt-v4 with 774 PLY meshes against Mitsuba 0.5 with the same 774 OBJs:
// coateddiffuse against roughplastic (the pbrt reader's mapping), the .tga
// textures read from the Mitsuba folder's .jpg (its documented fallback), two
// light triangles against a rectangle. What the files say differently is made
// the same first: the pbrt-v4 file cannot scale a conductor's reflectance
// (staircase_metals_as_mitsuba). The aluminium's bump map is pbrt's
// displacement on one side and Mitsuba's bumpmap on the other.
TEST(CrossFormat, StaircasePbrtPlyMatchesMitsubaObj) {
  Scene p = load("staircase/pbrt-v4/scene-v4.pbrt", 45, 80, 64, 23);
  Scene m = load("staircase/mitsuba/scene.xml", 45, 80, 64, 24);
  EXPECT_EQ(p.num_triangles(), 262663u);  // SOURCES.md's count
  EXPECT_EQ(m.num_triangles(), 262663u);
  staircase_metals_as_mitsuba(p);
  for (const Scene* s : {&p, &m})
    EXPECT_EQ(std::count_if(s->materials.begin(), s->materials.end(), [](const Material& mat) { return mat.bump_map >= 0; }),
              1);
  same_image(p, m, 5, {}, "staircase pbrt-v4 / mitsuba");
}

namespace {

class CrossFormatFiles : public TempDirTest {};

// Box.gltf's buffer (its data URI), so that the test's glTF uses its mesh.
std::string box_buffer_uri() {
  std::ifstream in(kScenes + "gltf/Box/glTF-Embedded/Box.gltf");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str(), key = "\"data:application/octet-stream;base64,";
  const size_t a = text.find(key), b = a == std::string::npos ? a : text.find('"', a + 1);
  EXPECT_NE(b, std::string::npos);
  return b == std::string::npos ? "" : text.substr(a + 1, b - a - 1);
}

}  // namespace

// glTF against Mitsuba: Box.gltf's mesh and node matrix (its Y-up turn),
// placed under a rotated and moved node (a quaternion), seen by a glTF
// camera (yfov, aspectRatio) and made an emitter (emissiveFactor ×
// KHR_materials_emissive_strength); the Mitsuba scene says the same with a
// cube, a transform chain, an area emitter and a perspective sensor.
// The glTF metallic-roughness BRDF has no Mitsuba equivalent, so the scene
// leaves it no part: one convex emitter and nothing else, whose faces cannot
// see each other, so nothing is reflected and the two images are equal
// (up to the pixel-coverage noise of the edges).
TEST_F(CrossFormatFiles, GltfBoxMatchesMitsuba) {
  const std::string gltf = write("box.gltf", R"({
  "asset": {"version": "2.0"},
  "extensionsUsed": ["KHR_materials_emissive_strength"],
  "scene": 0,
  "scenes": [{"nodes": [2, 3]}],
  "nodes": [
    {"children": [1], "matrix": [1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1]},
    {"mesh": 0},
    {"children": [0], "rotation": [0.24184476, 0.24184476, 0, 0.93969262], "translation": [0.1, -0.05, 0]},
    {"camera": 0, "translation": [0, 0, 3.2]}
  ],
  "cameras": [{"type": "perspective", "perspective": {"yfov": 0.6, "aspectRatio": 1.5, "znear": 0.01}}],
  "materials": [{
    "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]},
    "emissiveFactor": [1, 0.6, 0.3],
    "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2}}
  }],
  "meshes": [{"primitives": [{"attributes": {"NORMAL": 1, "POSITION": 2}, "indices": 0, "mode": 4, "material": 0}]}],
  "accessors": [
    {"bufferView": 0, "componentType": 5123, "count": 36, "type": "SCALAR"},
    {"bufferView": 1, "componentType": 5126, "count": 24, "type": "VEC3", "max": [1, 1, 1], "min": [-1, -1, -1]},
    {"bufferView": 1, "byteOffset": 288, "componentType": 5126, "count": 24, "type": "VEC3",
     "max": [0.5, 0.5, 0.5], "min": [-0.5, -0.5, -0.5]}
  ],
  "bufferViews": [
    {"buffer": 0, "byteOffset": 576, "byteLength": 72, "target": 34963},
    {"buffer": 0, "byteOffset": 0, "byteLength": 576, "target": 34962}
  ],
  "buffers": [{"byteLength": 648, "uri": ")" + box_buffer_uri() + R"("}]
})");
  // fov: 0.6 rad; the cube is [-1, 1]³, the box [-0.5, 0.5]³; the matrix is
  // the glTF root node's (columns there, rows here).
  const std::string xml = write("box.xml", R"(<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="34.37746770784939"/>
    <string name="fov_axis" value="y"/>
    <transform name="to_world"><lookat origin="0, 0, 3.2" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="96"/><integer name="height" value="64"/></film>
  </sensor>
  <shape type="cube">
    <transform name="to_world">
      <scale value="0.5"/>
      <matrix value="1 0 0 0  0 0 1 0  0 -1 0 0  0 0 0 1"/>
      <rotate x="1" y="1" z="0" angle="40"/>
      <translate x="0.1" y="-0.05" z="0"/>
    </transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0, 0, 0"/></bsdf>
    <emitter type="area"><rgb name="radiance" value="2, 1.2, 0.6"/></emitter>
  </shape>
</scene>
)");
  Scene g = load(gltf, 96, 64, 16, 31), m = load(xml, 96, 64, 16, 32);
  EXPECT_EQ(g.num_triangles(), 12u);
  EXPECT_TRUE(g.warnings.empty());
  same_image(g, m, 4, {}, "gltf box / mitsuba");
}
