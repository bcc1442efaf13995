// Light selection (light/light_sampler.h, light/light_bvh.h,
// sampling/distribution.h's AliasTable).
//
//  * The alias table: its pmfs are the weights over their sum (to float
//    rounding), and so is the probability its columns imply; sample
//    frequencies by χ²; the remapped u uniform given the choice, by χ²;
//    degenerate weights (one, zeros, ratios of 1e60).
//  * Both light samplers on the bundled box with hundreds of random lights of
//    every kind, at random shading points (with and without a normal): pmfs
//    sum to 1 (with the BVH's "no light" mass, where no light emits toward
//    the point) to the float rounding of the tree's depth; (light, remapped u)
//    frequencies match pmf(light)·uniform by χ²; pmf(ctx, sampled) equals the
//    pmf sample() returned, bit for bit; a light that can light the point
//    has pmf > 0 and one without power has pmf 0.
//  * Rendering: the many-light box with the BVH has the same image mean as
//    with power selection, per channel, within the error bars of the
//    per-pixel variances (independent seeds, z-test, Šidák).
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <vector>

#include "chi2.h"
#include "luz/device/cpu/render.h"
#include "luz/io/load.h"

using namespace luz;

namespace {

// χ² tests in this program: 4 alias-table ones, 2 × 12 light-sampler contexts.
constexpr int kChi2Tests = 4 + 24;
const double kThreshold = chi2::sidak(chi2::kAlpha, kChi2Tests);

// ------------------------------------------------------------- alias table

struct Built {
  std::vector<AliasEntry> entries;
  std::vector<float> pmfs;
  bool ok = false;
  AliasTable table() const { return {entries.data(), pmfs.data(), uint32_t(pmfs.size())}; }
};

Built build(const std::vector<double>& w) {
  Built b;
  b.ok = build_alias_table(w.data(), uint32_t(w.size()), b.entries, b.pmfs);
  return b;
}

// The probability the table's columns give item i: its own part of column i
// and the alias parts that name it, each column 1/n.
std::vector<double> implied(const Built& b) {
  const size_t n = b.pmfs.size();
  std::vector<double> p(n, 0.0);
  for (size_t c = 0; c < n; ++c) {
    p[c] += double(b.entries[c].q) / n;
    p[b.entries[c].alias] += (1.0 - double(b.entries[c].q)) / n;
  }
  return p;
}

std::vector<double> random_weights(uint64_t seed, size_t n, double zero_fraction) {
  std::vector<double> w(n);
  for (size_t i = 0; i < n; ++i)
    w[i] = chi2::rand01(seed, i, 0) < zero_fraction ? 0.0 : std::exp(8.0 * chi2::rand01(seed, i, 1));
  return w;
}

TEST(AliasTable, PmfsAreWeightsOverTotal) {
  for (double zeros : {0.0, 0.3}) {
    const std::vector<double> w = random_weights(7, 1000, zeros);
    double total = 0;
    for (double x : w) total += x;
    const Built b = build(w);
    ASSERT_TRUE(b.ok);
    const std::vector<double> p = implied(b);
    for (size_t i = 0; i < w.size(); ++i) {
      const double exact = w[i] / total;
      EXPECT_EQ(b.pmfs[i], float(exact)) << i;
      // Each column's q is one float rounding; an item gets its own column
      // and a few alias parts.
      EXPECT_NEAR(p[i], exact, 4e-7 / double(w.size()) + 1e-6 * exact) << i;
      if (w[i] == 0.0) EXPECT_EQ(p[i], 0.0) << "zero weight, item " << i;
    }
  }
}

TEST(AliasTable, FrequenciesAndRemappedU) {
  const std::vector<double> w = random_weights(11, 60, 0.2);
  const Built b = build(w);
  const AliasTable t = b.table();
  const uint64_t n = 400000;
  constexpr int kUBins = 8;
  std::vector<double> count(w.size(), 0.0), u_count(w.size() * kUBins, 0.0);
  for (uint64_t i = 0; i < n; ++i) {
    const AliasSample s = t.sample(chi2::rand01(3, i, 0));
    ASSERT_LT(s.index, w.size());
    ASSERT_GT(w[s.index], 0.0) << "an item without weight";
    ASSERT_EQ(s.pmf, b.pmfs[s.index]);
    ASSERT_TRUE(s.u >= 0.f && s.u < 1.f) << s.u;
    count[s.index] += 1;
    u_count[s.index * kUBins + std::min(int(s.u * kUBins), kUBins - 1)] += 1;
  }
  std::vector<double> expected(w.size());
  for (size_t i = 0; i < w.size(); ++i) expected[i] = n * double(b.pmfs[i]);
  const chi2::Result r = chi2::chi2_test(count, expected);
  EXPECT_TRUE(r.passes(kThreshold)) << r.summary();
  // Given the item, u uniform: per item, its count spread evenly; the
  // statistics summed over items, (bins - 1) degrees of freedom each.
  double stat = 0;
  int dof = 0;
  for (size_t i = 0; i < w.size(); ++i) {
    if (count[i] < 20 * kUBins) continue;
    for (int k = 0; k < kUBins; ++k) {
      const double e = count[i] / kUBins, o = u_count[i * kUBins + k];
      stat += (o - e) * (o - e) / e;
    }
    dof += kUBins - 1;
  }
  ASSERT_GT(dof, 100);
  EXPECT_GE(chi2::chi2_survival(stat, dof), kThreshold) << "chi2 " << stat << ", dof " << dof;
}

TEST(AliasTable, Degenerate) {
  {  // one weight: always it, u untouched
    const Built b = build({2.5});
    for (float u : {0.f, 0.3f, kOneMinusEpsilon}) {
      const AliasSample s = b.table().sample(u);
      EXPECT_EQ(s.index, 0u);
      EXPECT_EQ(s.pmf, 1.f);
      EXPECT_EQ(s.u, u);
    }
  }
  {  // all zero: nothing to sample
    const Built b = build({0.0, 0.0, 0.0});
    EXPECT_FALSE(b.ok);
    for (float p : b.pmfs) EXPECT_EQ(p, 0.f);
  }
  {  // zeros between, and ratios far beyond float: on a fine grid of u,
     // only positive weights, and the huge one almost always
    const std::vector<double> w = {0.0, 1e30, 0.0, 1.0, 1e-30, 0.0};
    const Built b = build(w);
    ASSERT_TRUE(b.ok);
    EXPECT_EQ(b.pmfs[1], 1.f);
    EXPECT_EQ(b.pmfs[3], float(1e-30));
    const std::vector<double> p = implied(b);
    EXPECT_NEAR(p[1], 1.0, 1e-7);
    for (size_t i : {0, 2, 5}) EXPECT_EQ(p[i], 0.0);
    const uint32_t grid = 1u << 20;
    for (uint32_t k = 0; k < grid; ++k) {
      const AliasSample s = b.table().sample(float(k) / grid);
      ASSERT_GT(w[s.index], 0.0) << "u = " << float(k) / grid;
      ASSERT_TRUE(s.u >= 0.f && s.u < 1.f);
    }
  }
  {  // equal weights: every column its own
    const Built b = build(std::vector<double>(5, 3.0));
    for (const AliasEntry& e : b.entries) EXPECT_EQ(e.q, 1.f);
    EXPECT_EQ(b.table().sample(0.5f).index, 2u);
  }
}

TEST(AliasTable, ChiSquareOfSkewedWeights) {
  // One heavy item among many light ones: most columns alias to it.
  std::vector<double> w(200, 1.0);
  w[17] = 5000.0;
  const Built b = build(w);
  const uint64_t n = 300000;
  std::vector<double> count(w.size(), 0.0), expected(w.size());
  for (uint64_t i = 0; i < n; ++i) count[b.table().sample(chi2::rand01(5, i, 0)).index] += 1;
  for (size_t i = 0; i < w.size(); ++i) expected[i] = n * double(b.pmfs[i]);
  const chi2::Result r = chi2::chi2_test(count, expected);
  EXPECT_TRUE(r.passes(kThreshold)) << r.summary();
}

// ---------------------------------------------------------- light samplers

Vec3 random_unit(uint64_t seed, uint64_t i, uint32_t dim) {
  const float z = 1.f - 2.f * chi2::rand01(seed, i, dim), phi = 2.f * kPi * chi2::rand01(seed, i, dim + 1);
  const float r = std::sqrt(std::max(0.f, 1.f - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// The bundled box (walls from 0 to about 556) with `n_tri` small emissive
// triangles of radiance over four decades (one in ten black), a quad, spheres
// (one emitting inward), point lights, spot lights (one under a non-uniform
// scale) and, if asked, a directional light and a constant environment.
Scene many_light_box(uint64_t seed, int n_tri, bool infinite, int res = 16) {
  Scene s = load_scene(LUZ_SOURCE_DIR "/scenes/cornell-box.xml", {{"res", std::to_string(res)}});
  auto r = [&](uint64_t i, uint32_t d) { return chi2::rand01(seed, i, d); };
  auto in_box = [&](uint64_t i, uint32_t d) { return Vec3{20 + 516 * r(i, d), 20 + 508 * r(i, d + 1), 20 + 519 * r(i, d + 2)}; };
  for (int k = 0; k < n_tri; ++k) {
    const Vec3 c = in_box(k, 0);
    const float size = 3 + 25 * r(k, 3);
    std::vector<Vec3> pos = {c + random_unit(seed, k, 4) * size, c + random_unit(seed, k, 6) * size,
                             c + random_unit(seed, k, 8) * size};
    const float level = r(k, 10) < 0.1f ? 0.f : std::pow(10.f, 4.f * r(k, 11) - 2.f);
    const Color e{level * (0.5f + r(k, 12)), level * (0.5f + r(k, 13)), level * (0.5f + r(k, 14))};
    s.add_mesh(pos, {}, {0, 1, 2}, 0, &e);
  }
  const Color quad_e{3, 3, 3};
  s.add_mesh({{200, 540, 200}, {300, 540, 200}, {300, 540, 300}, {200, 540, 300}}, {}, {0, 1, 2, 0, 2, 3}, 0, &quad_e);
  for (int k = 0; k < 8; ++k) {
    const Color e{1.f + k, 2.f, 1.f};
    s.add_sphere(in_box(1000 + k, 0), 2 + 10 * r(1000 + k, 3), 0, &e, k == 7);
  }
  for (int k = 0; k < 12; ++k) {
    PointLight l;
    l.position = in_box(2000 + k, 0);
    l.intensity = Color{1, 1, 1} * (k == 0 ? 0.f : 100.f * r(2000 + k, 3));
    s.lights.push_back(l);
  }
  for (int k = 0; k < 12; ++k) {
    SpotLight l;
    l.position = in_box(3000 + k, 0);
    l.intensity = Color{1, 1, 1} * (300.f * r(3000 + k, 3));
    const Vec3 z = random_unit(seed, 3000 + k, 4);
    const Vec3 x = normalize(cross(std::fabs(z.x) < 0.9f ? Vec3{1, 0, 0} : Vec3{0, 1, 0}, z)), y = cross(z, x);
    const float sx = k == 0 ? 3.f : 1.f;  // a non-uniform scale: every direction is bounded
    l.inv_x = x * (1.f / sx);
    l.inv_y = y;
    l.inv_z = z;
    l.cutoff = 0.2f + 1.2f * r(3000 + k, 6);
    l.beam = l.cutoff * r(3000 + k, 7);
    l.cos_cutoff = std::cos(l.cutoff);
    l.cos_beam = std::cos(l.beam);
    l.inv_transition = l.beam < l.cutoff ? 1.f / (l.cutoff - l.beam) : 0.f;
    s.lights.push_back(l);
  }
  if (infinite) {
    DirectionalLight d;
    d.direction = normalize(Vec3{0.2f, -0.3f, 1.f});
    d.irradiance = {0.5f, 0.5f, 0.5f};
    s.lights.push_back(d);
    ConstantLight c;
    c.radiance = {0.05f, 0.06f, 0.07f};
    s.lights.push_back(c);
  }
  s.compile();
  return s;
}

// Shading contexts: points in and around the box, with a random normal, or
// none (every fourth: a BSDF-sampled vertex's context).
LightSampleContext random_ctx(uint64_t i) {
  const Vec3 p{-100 + 760 * chi2::rand01(99, i, 0), -100 + 750 * chi2::rand01(99, i, 1), -100 + 760 * chi2::rand01(99, i, 2)};
  const Vec3 n = i % 4 == 3 ? Vec3{} : random_unit(99, i, 3);
  return {p, n, n};
}

LightSampler sampler_of(Scene& s, LightSamplerType type) {
  s.settings.light_sampler = type;
  return s.view().lights.sampler;
}

int tree_depth(const LightBvhData& d) {
  int depth = 0;
  for (uint64_t t : d.trails) {
    if (t & (kTrailInfinite | kTrailNone)) continue;
    depth = std::max(depth, 64 - __builtin_clzll(t | 1));
  }
  return depth + 1;
}

// The probability that the BVH's walk ends at an inner node whose children
// both have importance 0 at ctx (sample() then returns no light), or at a
// one-light root without importance.
double none_mass(const BvhLightSampler& b, const LightSampleContext& ctx) {
  if (b.num_nodes == 0) return 1.0 - b.p_infinite;
  double none = 0;
  std::vector<std::pair<uint32_t, double>> stack = {{0u, 1.0 - double(b.p_infinite)}};
  while (!stack.empty()) {
    const auto [k, mass] = stack.back();
    stack.pop_back();
    if (b.nodes[k].leaf) {
      if (k == 0 && !(b.nodes[0].bounds.importance(ctx.p, ctx.ns) > 0.f)) none += mass;
      continue;
    }
    const float p0 = b.first_child_p(k, ctx.p, ctx.ns);
    if (p0 < 0.f) {
      none += mass;
      continue;
    }
    stack.push_back({k + 1, mass * p0});
    stack.push_back({b.nodes[k].child, mass * (1.0 - p0)});
  }
  return none;
}

class LightSamplers : public ::testing::TestWithParam<LightSamplerType> {
 protected:
  static void SetUpTestSuite() { scene_ = new Scene(many_light_box(1, 400, true)); }
  static void TearDownTestSuite() { delete scene_; }
  static Scene* scene_;
};
Scene* LightSamplers::scene_ = nullptr;

TEST_P(LightSamplers, PmfsSumToOne) {
  const LightSampler ls = sampler_of(*scene_, GetParam());
  const uint32_t n = uint32_t(scene_->lights.size());
  ASSERT_EQ(ls.n, n);
  ASSERT_GT(n, 400u);
  const int depth = GetParam() == LightSamplerType::Bvh ? tree_depth(scene_->light_bvh) : 1;
  // Per level, the complement 1 - p and the product each round once.
  const double tol = (2.0 * depth + 4.0) * 0x1p-24;
  double worst = 0, worst_none = 0;
  for (uint64_t i = 0; i < 300; ++i) {
    const LightSampleContext ctx = random_ctx(i);
    double sum = 0;
    for (uint32_t l = 0; l < n; ++l) {
      const float p = ls.pmf(ctx, l);
      ASSERT_TRUE(p >= 0.f && p <= 1.f) << p;
      sum += p;
    }
    const double none = GetParam() == LightSamplerType::Bvh ? none_mass(ls.bvh, ctx) : 0.0;
    worst_none = std::max(worst_none, none);
    worst = std::max(worst, std::fabs(sum + none - 1.0));
    ASSERT_NEAR(sum + none, 1.0, tol) << "context " << i << ", no-light mass " << none;
  }
  std::printf("depth %d, worst |sum - 1| %.3g (tolerance %.3g), largest no-light mass %.3g\n", depth, worst, tol,
              worst_none);
}

TEST_P(LightSamplers, SamplesMatchPmf) {
  const LightSampler ls = sampler_of(*scene_, GetParam());
  const uint32_t n = ls.n;
  constexpr int kUBins = 4;
  const uint64_t samples = 60000;
  for (uint64_t c = 0; c < 12; ++c) {
    const LightSampleContext ctx = random_ctx(1000 + c);
    // Bins: (light, quarter of the remapped u), then "no light".
    std::vector<double> observed(size_t(n) * kUBins + 1, 0.0), expected(observed.size(), 0.0);
    double sum = 0;
    for (uint32_t l = 0; l < n; ++l) {
      const double p = ls.pmf(ctx, l);
      sum += p;
      for (int k = 0; k < kUBins; ++k) expected[l * kUBins + k] = samples * p / kUBins;
    }
    expected.back() = samples * std::max(0.0, 1.0 - sum);
    for (uint64_t i = 0; i < samples; ++i) {
      float u = chi2::rand01(17 + c, i, 0);
      const SampledLight s = ls.sample(ctx, u);
      if (s.pmf == 0.f) {
        observed.back() += 1;
        continue;
      }
      ASSERT_LT(s.light, n);
      ASSERT_EQ(ls.pmf(ctx, s.light), s.pmf) << "light " << s.light << ", context " << c;
      ASSERT_TRUE(u >= 0.f && u < 1.f) << u;
      observed[s.light * kUBins + std::min(int(u * kUBins), kUBins - 1)] += 1;
    }
    const chi2::Result r = chi2::chi2_test(observed, expected);
    EXPECT_TRUE(r.passes(kThreshold)) << "context " << c << ": " << r.summary();
  }
}

TEST_P(LightSamplers, LightsThatCanLightThePointHavePmf) {
  const LightSampler ls = sampler_of(*scene_, GetParam());
  const LightsView& lights = scene_->view().lights;
  const float radius = 0.5f * length(scene_->bounds_max - scene_->bounds_min);
  int lit = 0;
  for (uint64_t i = 0; i < 150; ++i) {
    const LightSampleContext ctx = random_ctx(2000 + i);
    for (uint32_t l = 0; l < ls.n; ++l) {
      const float p = ls.pmf(ctx, l);
      if (!(phi(lights[l], radius) > 0.0)) {
        EXPECT_EQ(p, 0.f) << "light " << l << " has no power";
        continue;
      }
      bool can = false;
      for (uint64_t k = 0; k < 6 && !can; ++k) {
        const LightSample s = sample_li(lights[l], ctx, chi2::rand2(23, i * 64 + k, l), lights.data);
        const bool facing = ctx.ns.x == 0.f && ctx.ns.y == 0.f && ctx.ns.z == 0.f ? true : dot(s.wi, ctx.ns) != 0.f;
        can = s.pdf > 0.f && !is_black(s.radiance) && facing;
      }
      if (can) {
        ++lit;
        ASSERT_GT(p, 0.f) << "light " << l << " (type " << int(lights[l].type) << ") lights context " << i;
      }
    }
  }
  EXPECT_GT(lit, 10000);
}

INSTANTIATE_TEST_SUITE_P(, LightSamplers, ::testing::Values(LightSamplerType::Power, LightSamplerType::Bvh),
                         [](const auto& info) { return info.param == LightSamplerType::Bvh ? "Bvh" : "Power"; });

TEST(LightSamplerTypes, OneLightIsChosenWithoutTables) {
  Scene s = load_scene(LUZ_SOURCE_DIR "/scenes/cornell-box.xml", {{"res", "8"}});
  ASSERT_EQ(s.lights.size(), 1u);
  for (LightSamplerType t : {LightSamplerType::Power, LightSamplerType::Bvh}) {
    const LightSampler ls = sampler_of(s, t);
    for (uint64_t i = 0; i < 100; ++i) {
      float u = chi2::rand01(1, i, 0);
      const float u0 = u;
      const SampledLight sl = ls.sample(random_ctx(i), u);
      EXPECT_EQ(sl.light, 0u);
      EXPECT_EQ(sl.pmf, 1.f);
      EXPECT_EQ(u, u0);
      EXPECT_EQ(ls.pmf(random_ctx(i), 0), 1.f);
    }
  }
}

// The many-light box rendered with each sampler: the same expected image.
TEST(LightSamplerRender, BvhMeanMatchesPower) {
  Scene s = many_light_box(2, 150, true, 24);
  s.settings.spp = 128;
  s.settings.sampler = SamplerType::Independent;  // per-pixel variance: unbiased for the mean's
  double mean[2][3] = {}, var[2][3] = {};
  int v = 0;
  for (LightSamplerType t : {LightSamplerType::Power, LightSamplerType::Bvh}) {
    s.settings.light_sampler = t;
    s.settings.seed = 100 + v;
    CpuRenderOptions opt;
    opt.threads = 2;
    RenderStats stats;
    const Film f = render_cpu(s, opt, stats);
    EXPECT_EQ(stats.discarded, 0u);
    const std::vector<float> m = f.mean();
    const std::vector<double> vm = f.variance_of_mean();
    const double pixels = double(f.count.size());
    for (size_t i = 0; i < f.count.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        mean[v][k] += m[3 * i + k] / pixels;
        var[v][k] += vm[3 * i + k] / (pixels * pixels);
      }
    ++v;
  }
  const double zmax = chi2::normal_two_sided_quantile(chi2::sidak(1e-3, 3));
  for (int k = 0; k < 3; ++k) {
    const double z = (mean[1][k] - mean[0][k]) / std::sqrt(var[0][k] + var[1][k]);
    std::printf("channel %d: power %.5f ± %.5f, bvh %.5f ± %.5f, z = %.2f (|z| < %.2f)\n", k, mean[0][k],
                std::sqrt(var[0][k]), mean[1][k], std::sqrt(var[1][k]), z, zmax);
    EXPECT_LT(std::fabs(z), zmax) << "channel " << k;
  }
}

}  // namespace

