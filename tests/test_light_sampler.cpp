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

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <vector>

#include "chi2.h"
#include "luz/device/cpu/render.h"
#include "luz/io/load.h"
#include "stat_helpers.h"
#include "temp_dir.h"

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
// none (every fourth: a BSDF-sampled vertex's context). Of those with a
// normal, a third transmit (no hemisphere), a third reflect light from the
// normal's side, a third from the side of a geometric normal tilted from it.
LightSampleContext random_ctx(uint64_t i) {
  const Vec3 p{-100 + 760 * chi2::rand01(99, i, 0), -100 + 750 * chi2::rand01(99, i, 1), -100 + 760 * chi2::rand01(99, i, 2)};
  const Vec3 n = i % 4 == 3 ? Vec3{} : random_unit(99, i, 3);
  const Vec3 h = i % 4 == 3 || i % 3 == 0 ? Vec3{} : i % 3 == 1 ? n : normalize(n + random_unit(99, i, 5) * 0.6f);
  return {p, n, n, h};
}

LightSampler sampler_of(Scene& s, LightSamplerType type) {
  s.settings.light_sampler = type;
  return s.view().lights.sampler;
}

// The number of levels of the BVH (its deepest leaf's).
int tree_depth(const LightBvhData& d) {
  int depth = 0;
  std::vector<std::pair<uint32_t, int>> stack = {{0u, 1}};
  while (!d.nodes.empty() && !stack.empty()) {
    const auto [k, level] = stack.back();
    stack.pop_back();
    depth = std::max(depth, level);
    for (int i = 0; i < kLightBvhWidth; ++i)
      if (d.nodes[k].phi[i] > 0.f && !(d.nodes[k].child[i] & kLightBvhLeaf))
        stack.push_back({d.nodes[k].child[i] & kLightBvhIndex, level + 1});
  }
  return depth;
}

// The probability that the BVH's walk ends at a node none of whose children
// has importance at ctx (sample() then returns no light).
double none_mass(const BvhLightSampler& b, const LightSampleContext& ctx) {
  float root[kLightBvhWidth];
  const double tree = b.root_importances(ctx, root), all = double(b.infinite_total) + tree;
  if (!(all > 0)) return 1.0;
  if (b.num_nodes == 0) return 0.0;
  double none = 0;
  std::vector<std::pair<uint32_t, double>> stack = {{0u, tree / all}};
  while (!stack.empty()) {
    const auto [k, mass] = stack.back();
    stack.pop_back();
    float imp[kLightBvhWidth];
    BvhLightSampler::importances(b.nodes[k], ctx, imp);
    double total = 0;
    for (float x : imp) total += x;
    if (!(total > 0)) {
      none += mass;
      continue;
    }
    for (int i = 0; i < kLightBvhWidth; ++i)
      if (imp[i] > 0.f && !(b.nodes[k].child[i] & kLightBvhLeaf))
        stack.push_back({b.nodes[k].child[i] & kLightBvhIndex, mass * imp[i] / total});
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
  // Per level, the sum of the children's importances rounds up to width - 1
  // times, their ratio and the product once each.
  const double tol = ((kLightBvhWidth + 1.0) * depth + 4.0) * 0x1p-24;
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
  std::vector<uint32_t> infinite;  // (a sun and a sky)
  for (uint32_t l = 0; l < n; ++l)
    if (!bounds(scene_->lights[l])) infinite.push_back(l);
  ASSERT_EQ(infinite.size(), 2u);
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
      // What a BSDF-sampled sky hit is weighed by at the next vertex, from
      // the sample's sum (also where no light was chosen).
      if (i % 64 == 0 || s.pmf == 0.f)
        for (uint32_t l : infinite) ASSERT_EQ(ls.pmf_infinite(l, s.sum), ls.pmf(ctx, l)) << "light " << l;
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
        const bool facing = is_black(ctx.ns) || dot(s.wi, ctx.ns) != 0.f;
        const bool above = is_black(ctx.hemisphere) || dot(s.wi, ctx.hemisphere) > 0.f;
        can = s.pdf > 0.f && !is_black(s.radiance) && facing && above;
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

// The GPU's importances (one child at a time, empty slots skipped) against
// the CPU's 8 lanes at once, on every node of a many-light tree at random
// shading points: the same operations on the same floats, so the same bits.
TEST(LightBvh, LaneLoopGivesTheSimdImportances) {
  const Scene s = many_light_box(1, 400, true);
  const LightBvhData& d = s.light_bvh;
  ASSERT_GT(d.nodes.size(), 8u);
  uint64_t lit = 0;
  for (uint64_t i = 0; i < 500; ++i) {
    const LightSampleContext ctx = random_ctx(i);
    for (size_t k = 0; k < d.nodes.size(); ++k) {
      float a[kLightBvhWidth], b[kLightBvhWidth];
      BvhLightSampler::importances(d.nodes[k], ctx, a);
      BvhLightSampler::importances_by_lane(d.nodes[k], ctx, b);
      for (int j = 0; j < kLightBvhWidth; ++j) {
        ASSERT_EQ(std::memcmp(&a[j], &b[j], sizeof(float)), 0)
            << "node " << k << " slot " << j << " context " << i << ": " << a[j] << " against " << b[j];
        lit += a[j] > 0.f;
      }
    }
  }
  EXPECT_GT(lit, 1000u);  // not only zeros compared
}

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

// A tree of one light is sampled without the walk. With no infinite light
// beside it (the box's light beside a point light without power): wherever
// the walk gives the light a pmf, the same light, pmf and remapped u; where
// the walk gives none (the light's importance 0: points above the one-sided
// light, or beside it below a surface's tangent plane), the light with pmf 1,
// but its samples from there bring nothing (no pdf, no radiance, or from
// below the hemisphere), so the estimate is the walk's. Beside a sky: the
// walk's choices and pmfs everywhere (its importance sets the tree's share).
TEST(LightBvh, OneLightTreeIsChosenWithoutTheWalk) {
  for (const bool sky : {false, true}) {
    Scene s = load_scene(LUZ_SOURCE_DIR "/scenes/cornell-box.xml", {{"res", "8"}});
    if (sky) {
      ConstantLight c;
      c.radiance = {0.1f, 0.1f, 0.1f};
      s.lights.push_back(c);
    } else {
      PointLight dark;
      dark.position = {278, 270, 280};
      s.lights.push_back(dark);
    }
    s.compile();
    const LightsView& lights = s.view().lights;
    const BvhLightSampler fast = sampler_of(s, LightSamplerType::Bvh).bvh;
    ASSERT_EQ(s.lights.size(), 2u);
    ASSERT_EQ(fast.only, 0);  // the box's light
    BvhLightSampler walk = fast;
    walk.only = -1;
    int agreed = 0, refused = 0;
    for (uint64_t i = 0; i < 4000; ++i) {
      const LightSampleContext ctx = random_ctx(5000 + i);
      float u_fast = chi2::rand01(3, i, 0), u_walk = u_fast;
      const SampledLight a = fast.sample(ctx, u_fast), b = walk.sample(ctx, u_walk);
      if (sky) ASSERT_EQ(fast.pmf(ctx, 1), walk.pmf(ctx, 1)) << "context " << i;
      else EXPECT_EQ(fast.pmf(ctx, 1), 0.f);
      if (b.pmf > 0.f) {
        ++agreed;
        ASSERT_EQ(a.light, b.light) << "context " << i;
        ASSERT_EQ(a.pmf, b.pmf) << "context " << i;
        ASSERT_NEAR(u_fast, u_walk, 0x1p-23f) << "context " << i;  // u·total/total: two roundings of u < 1
        ASSERT_EQ(fast.pmf(ctx, b.light), walk.pmf(ctx, b.light)) << "context " << i;
        continue;
      }
      ASSERT_FALSE(sky) << "context " << i << ": the walk chose nothing beside a sky";
      ++refused;  // the walk found no importance in the tree
      EXPECT_EQ(fast.pmf(ctx, 0), 1.f);
      ASSERT_EQ(walk.pmf(ctx, 0), 0.f);
      ASSERT_EQ(a.light, 0u);
      ASSERT_EQ(a.pmf, 1.f);
      for (uint64_t k = 0; k < 32; ++k) {
        const LightSample ls = sample_li(lights[0], ctx, chi2::rand2(29, i * 32 + k, 0), lights.data);
        const bool above = is_black(ctx.hemisphere) || dot(ls.wi, ctx.hemisphere) > 0.f;
        ASSERT_FALSE(ls.pdf > 0.f && !is_black(ls.radiance) && above)
            << "context " << i << ": the walk refused a light whose sample can light it";
      }
    }
    EXPECT_GT(agreed, 1000);
    if (!sky) EXPECT_GT(refused, 100);
  }
}

// The infinite lights beside the tree: each weighed by its irradiance
// estimate (a constant sky πL, a directional light E), the tree by its
// root's importances at the point: pmf(infinite i) = w_i / (Σ w + Σ root),
// the tree's lights sharing the rest. So a dim sky over the box's bright
// light takes a small share where the light shines and all of it where the
// light cannot reach (above it), where a fixed share (pbrt-v4's) gives it half
// everywhere.
TEST(LightBvh, InfiniteLightsAreWeighedAgainstTheTreeByIrradiance) {
  Scene s = load_scene(LUZ_SOURCE_DIR "/scenes/cornell-box.xml", {{"res", "8"}});
  ConstantLight sky;
  sky.radiance = {0.01f, 0.02f, 0.03f};
  s.lights.push_back(sky);
  DirectionalLight sun;
  sun.direction = normalize(Vec3{0.3f, -1.f, 0.2f});
  sun.irradiance = {0.1f, 0.1f, 0.05f};
  s.lights.push_back(sun);
  s.compile();
  const BvhLightSampler b = sampler_of(s, LightSamplerType::Bvh).bvh;
  ASSERT_EQ(b.num_infinite, 2u);
  const float w_sky = float(M_PI * 0.02), w_sun = 0.25f / 3.f;
  EXPECT_NEAR(b.infinite_weight[0], w_sky, 1e-6f);
  EXPECT_NEAR(b.infinite_weight[1], w_sun, 1e-6f);
  // Under the light on the floor, facing it; far above the light (its back).
  const LightSampleContext under{{278, 0, 280}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}};
  const LightSampleContext above{{278, 1500, 280}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}};
  float imp[kLightBvhWidth];
  const float tree_under = b.root_importances(under, imp);
  // The light's irradiance there: L · A / d² ≈ 11 · 130 · 105 / 549² ≈ 0.5.
  std::printf("tree's importance under the light %.3f, the infinite lights' weights %.3f + %.3f\n", tree_under, w_sky,
              w_sun);
  EXPECT_GT(tree_under, 2.f * (w_sky + w_sun));
  EXPECT_EQ(b.root_importances(above, imp), 0.f);
  for (const LightSampleContext& ctx : {under, above}) {
    const float tree = b.root_importances(ctx, imp), all = w_sky + w_sun + tree;
    EXPECT_NEAR(b.pmf(ctx, 1), w_sky / all, 1e-6f * w_sky / all);
    EXPECT_NEAR(b.pmf(ctx, 2), w_sun / all, 1e-6f * w_sun / all);
    EXPECT_NEAR(b.pmf(ctx, 0), tree / all, 1e-6f);
  }
  EXPECT_LT(b.pmf(under, 1) + b.pmf(under, 2), 0.34f);
  EXPECT_FLOAT_EQ(b.pmf(above, 1) + b.pmf(above, 2), 1.f);
}

// The collapsed tree's shape, for light sets the SAH splits well, badly or
// not at all (every light at one point): each light with power sits in one
// slot its trail leads to; a node whose subtree holds m lights has min(m, 8)
// children (leaves of several lights); every slot's sphere holds its lights'
// boxes, its phi is their sum and its cone holds their cones; the levels fit
// the trails. And the sampler on it: pmfs sum to 1, sample() agrees with pmf().
struct TreeCase {
  const char* name;
  int n;
  int layout;  // 0: random; 1: all at one point; 2: on a line, alternately facing
};

Scene tree_case_scene(const TreeCase& c) {
  Scene s = load_scene(LUZ_SOURCE_DIR "/scenes/cornell-box.xml", {{"res", "8"}});
  for (int k = 0; k < c.n; ++k) {
    Vec3 o = c.layout == 1 ? Vec3{278, 270, 280} : c.layout == 2 ? Vec3{20.f + 0.05f * k, 270, 280} : Vec3{
        20 + 516 * chi2::rand01(5, k, 0), 20 + 508 * chi2::rand01(5, k, 1), 20 + 519 * chi2::rand01(5, k, 2)};
    const Vec3 a = c.layout == 2 ? Vec3{0, 1, 0} : random_unit(5, k, 3), b0 = random_unit(5, k, 5);
    const Vec3 b = c.layout == 2 ? Vec3{0, 0, k % 2 ? 1.f : -1.f} : normalize(cross(a, b0));
    const float size = c.layout == 1 ? 5.f : 1.f + 10.f * chi2::rand01(5, k, 7);
    const Color e = Color{1, 1, 1} * (0.1f + chi2::rand01(5, k, 8));
    s.add_mesh({o, o + a * size, o + b * size}, {}, {0, 1, 2}, 0, &e);
  }
  s.compile();
  return s;
}

TEST(LightBvh, CollapsedTreeShape) {
  const TreeCase cases[] = {{"two", 1, 0},      {"eight", 7, 0},        {"nine", 8, 0},   {"random 64", 63, 0},
                            {"random 3000", 3000, 0}, {"one point", 300, 1}, {"a line", 500, 2}};
  for (const TreeCase& c : cases) {
    SCOPED_TRACE(c.name);
    Scene s = tree_case_scene(c);
    const LightBvhData& d = s.light_bvh;
    const uint32_t n = uint32_t(s.lights.size());
    ASSERT_EQ(n, uint32_t(c.n) + 1);
    // Follow each light's trail.
    std::vector<std::vector<std::pair<uint32_t, int>>> path(n);  // (node, slot) from the root
    for (uint32_t l = 0; l < n; ++l) {
      uint64_t t = d.trails[l];
      ASSERT_FALSE(t & (kTrailInfinite | kTrailNone));
      uint32_t k = 0;
      for (int level = 0;; ++level) {
        ASSERT_LT(level, kLightTrailLevels);
        ASSERT_LT(k, d.nodes.size());
        const int slot = int(t & (kLightBvhWidth - 1));
        path[l].push_back({k, slot});
        const uint32_t child = d.nodes[k].child[slot];
        ASSERT_GT(d.nodes[k].phi[slot], 0.f);
        if (child & kLightBvhLeaf) {
          ASSERT_EQ(child & kLightBvhIndex, l);
          break;
        }
        k = child & kLightBvhIndex;
        t >>= kLightBvhSlotBits;
      }
    }
    // Per slot: the lights under it.
    std::vector<std::array<std::vector<uint32_t>, kLightBvhWidth>> under(d.nodes.size());
    for (uint32_t l = 0; l < n; ++l)
      for (const auto& [k, slot] : path[l]) under[k][size_t(slot)].push_back(l);
    int several = 0;
    for (size_t k = 0; k < d.nodes.size(); ++k) {
      const LightBvhNode& nd = d.nodes[k];
      size_t lights = 0;
      int used = 0, leaves = 0;
      for (int i = 0; i < kLightBvhWidth; ++i) {
        lights += under[k][size_t(i)].size();
        if (!(nd.phi[i] > 0.f)) {
          EXPECT_TRUE(under[k][size_t(i)].empty());
          continue;
        }
        ++used;
        leaves += (nd.child[i] & kLightBvhLeaf) != 0;
        ASSERT_FALSE(under[k][size_t(i)].empty()) << "node " << k << " slot " << i << " reaches no light";
        const Vec3 centre{nd.cx[i], nd.cy[i], nd.cz[i]}, w{nd.wx[i], nd.wy[i], nd.wz[i]};
        double phi_sum = 0;
        for (uint32_t l : under[k][size_t(i)]) {
          const LightBounds b = *bounds(s.lights[l]);
          phi_sum += b.phi;
          for (int corner = 0; corner < 8; ++corner) {
            const Vec3 q{corner & 1 ? b.hi.x : b.lo.x, corner & 2 ? b.hi.y : b.lo.y, corner & 4 ? b.hi.z : b.lo.z};
            EXPECT_LE(length(q - centre), nd.radius[i] * (1 + 1e-6f)) << "node " << k << " slot " << i << " light " << l;
          }
          // The light's cone in the slot's: the angle between the axes plus
          // the light's spread within the slot's (to float rounding).
          if (nd.cos_o[i] > -1.f) {
            // (the angle between the axes by atan2: acos loses it near 0)
            const double gap = std::atan2(length(cross(w, b.w)), dot(w, b.w)) + std::acos(double(b.cos_theta_o));
            EXPECT_LE(gap, std::acos(double(nd.cos_o[i])) + 1e-5) << "node " << k << " slot " << i << " light " << l;
          }
          EXPECT_GE(nd.cos_e[i], -1.f);
          EXPECT_LE(nd.cos_e[i], b.cos_theta_e);
        }
        EXPECT_NEAR(nd.phi[i], phi_sum, 1e-5 * phi_sum);
      }
      EXPECT_EQ(size_t(used), std::min<size_t>(lights, kLightBvhWidth)) << "node " << k;
      several += leaves >= 2;
    }
    if (n >= 8) EXPECT_GT(several, 0) << "no node holds several lights";
    EXPECT_LE(tree_depth(d), kLightTrailLevels);
    // The sampler on it.
    const LightSampler ls = sampler_of(s, LightSamplerType::Bvh);
    const double tol = ((kLightBvhWidth + 1.0) * tree_depth(d) + 4.0) * 0x1p-24;
    for (uint64_t i = 0; i < 40; ++i) {
      const LightSampleContext ctx = random_ctx(5000 + i);
      double sum = none_mass(ls.bvh, ctx);
      for (uint32_t l = 0; l < n; ++l) sum += ls.pmf(ctx, l);
      EXPECT_NEAR(sum, 1.0, tol) << "context " << i;
      for (uint64_t j = 0; j < 50; ++j) {
        float u = chi2::rand01(31, i * 50 + j, 0);
        const SampledLight sl = ls.sample(ctx, u);
        if (sl.pmf == 0.f) continue;
        ASSERT_EQ(ls.pmf(ctx, sl.light), sl.pmf) << "context " << i;
        ASSERT_TRUE(u >= 0.f && u < 1.f);
      }
    }
  }
}

// `s` rendered on 2 threads with light sampler t and the given seed.
Film render_with(Scene s, LightSamplerType t, uint64_t seed) {
  luz_test::independent_pixels(s);
  s.settings.light_sampler = t;
  s.settings.seed = seed;
  CpuRenderOptions opt;
  opt.threads = 2;
  RenderStats stats;
  Film f = render_cpu(s, opt, stats);
  EXPECT_EQ(stats.discarded, 0u);
  return f;
}

// The many-light box rendered with each sampler: the same expected image.
TEST(LightSamplerRender, BvhMeanMatchesPower) {
  Scene s = many_light_box(2, 150, true, 24);
  s.settings.spp = 128;
  s.settings.sampler = SamplerType::Independent;  // per-pixel variance: unbiased for the mean's
  double mean[2][3] = {}, var[2][3] = {};
  int v = 0;
  for (LightSamplerType t : {LightSamplerType::Power, LightSamplerType::Bvh}) {
    const Film f = render_with(s, t, 100 + v);
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


namespace {

// MIS weighs a BSDF-sampled ray that hits an emitter by the light-selection
// pmf the previous vertex's next-event estimate had (path.h's PathState::
// prev_p, prev_ns, prev_hemisphere). The BVH's pmf depends on the shading
// normal, so a wrong context there biases the image; power selection's pmf
// depends on neither, so its image is the reference. The scene makes the
// BVH's pmf vary strongly with the normal where MIS weighs both strategies:
// the box's light off, the whole ceiling a dim emitter (BSDF sampling finds
// it as often as light sampling does) and a small bright one low on the left
// wall, which the floor sees at grazing angles: with the floor's normal it
// gets a small share of the pmf, without one most of it. Direct light only
// (max_depth 2: every emitter hit after the camera's is weighed by MIS).
// 8×8-pixel block means per channel, z-test with the variances of both
// images, Šidák over blocks and channels.
Scene grazing_and_overhead_lights(LightSamplerType t) {
  Scene s = load_scene(LUZ_SOURCE_DIR "/scenes/cornell-box.xml",
                       {{"res", "64"}, {"integrator", "path"}, {"max_depth", "2"}});
  for (Light& l : s.lights)
    if (l.type == LightType::Parallelogram) l.parallelogram.radiance = {};
    else if (l.type == LightType::Triangle) l.triangle.radiance = {};
  // A square of half-size `half` centred at c on a wall of normal axis
  // `axis`, facing the side `inward` (±1) of it.
  auto quad = [&](Vec3 c, int axis, float inward, float half, Color e) {
    std::vector<Vec3> p(4, c);
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
    const float da[4] = {-1, 1, 1, -1}, db[4] = {-1, -1, 1, 1};
    for (int k = 0; k < 4; ++k) (&p[k].x)[a] += half * da[k], (&p[k].x)[b] += half * db[k];
    Vec3 in{};
    (&in.x)[axis] = inward;
    if (dot(cross(p[1] - p[0], p[2] - p[0]), in) < 0.f) std::swap(p[1], p[3]);
    s.add_mesh(p, {}, {0, 1, 2, 0, 2, 3}, 0, &e);
  };
  quad({278, 547, 280}, 1, -1, 250, {1.5f, 1.5f, 3});  // the ceiling, blue
  quad({2, 45, 280}, 0, 1, 12, {1500, 100, 100});      // low on the left wall, red
  s.compile();
  s.settings.light_sampler = t;
  s.settings.sampler = SamplerType::Independent;  // per-pixel variance: unbiased for the mean's
  return s;
}

TEST(LightSamplerRender, MisUsesThePreviousVertexContext) {
  constexpr int kBlock = 16;
  luz_test::Blocks blocks[2];
  int v = 0;
  for (LightSamplerType t : {LightSamplerType::Power, LightSamplerType::Bvh}) {
    Scene s = grazing_and_overhead_lights(t);
    s.settings.spp = 256;
    blocks[v] = luz_test::make_blocks(render_with(s, t, 300 + v), kBlock);
    ++v;
  }
  luz_test::Blocks& a = blocks[0];
  luz_test::Blocks& b = blocks[1];
  const double zmax = luz_test::sidak_z(1e-3, 3.0 * a.bw * a.bh);
  double worst = 0, sum_z2 = 0;
  std::array<int, 3> worst_at{};
  int n = 0;
  for (int by = 0; by < a.bh; ++by)
    for (int bx = 0; bx < a.bw; ++bx)
      for (int c = 0; c < 3; ++c) {
        const double m = 0.5 * (a.m(bx, by, c) + b.m(bx, by, c)), floor = luz_test::rounding_floor(m);
        const double z = (b.m(bx, by, c) - a.m(bx, by, c)) /
                         std::sqrt(a.v(bx, by, c) + b.v(bx, by, c) + 2 * floor * floor);
        if (std::fabs(z) > worst) worst = std::fabs(z), worst_at = {bx, by, c};
        sum_z2 += z * z;
        ++n;
      }
  std::printf("bvh against power: worst block |z| %.2f (threshold %.2f) at block (%d, %d) channel %d, mean z² %.2f over "
              "%d\n", worst, zmax, worst_at[0], worst_at[1], worst_at[2], sum_z2 / n, n);
  EXPECT_LT(worst, zmax);
}

}  // namespace

namespace {

// The default light sampler: the BVH wherever a scene names none (every
// format), a pbrt-v4 file's "lightsampler" kept. (The CLI's --light-sampler
// over it: test_cli_checkpoint.cpp, by the EXR metadata.)
class LightSamplerDefault : public TempDirTest {};

TEST_F(LightSamplerDefault, BvhUnlessTheSceneNamesOne) {
  EXPECT_EQ(RenderSettings{}.light_sampler, LightSamplerType::Bvh);
  EXPECT_EQ(load_scene(LUZ_SOURCE_DIR "/scenes/cornell-box.xml").settings.light_sampler, LightSamplerType::Bvh);
  write("two.mtl", "newmtl glow\nKd 0.5 0.5 0.5\nKe 4 4 4\n");
  const std::string obj = write("two.obj", "mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nusemtl glow\n"
                                           "f 1 2 3\nf 1 3 4\n");
  EXPECT_EQ(load_scene(obj).settings.light_sampler, LightSamplerType::Bvh);
  const std::string world = "WorldBegin\nAttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [ 4 4 4 ]\n"
                            "Shape \"sphere\" \"float radius\" 0.5\nAttributeEnd\n"
                            "Translate 2 0 0\nAreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ]\n"
                            "Shape \"sphere\" \"float radius\" 0.5\n";
  EXPECT_EQ(load_scene(write("none.pbrt", world)).settings.light_sampler, LightSamplerType::Bvh);
  EXPECT_EQ(load_scene(write("power.pbrt", "Integrator \"path\" \"string lightsampler\" \"power\"\n" + world))
                .settings.light_sampler,
            LightSamplerType::Power);
}

}  // namespace
