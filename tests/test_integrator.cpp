// Integrator-level tests on the Cornell box (DESIGN.md, validation layer 3).
//
//  * Estimator agreement: the bsdf, light and path (MIS) estimators compute
//    the same integral, so their images agree within their confidence
//    intervals. Compared on 8×8-pixel block means, per channel, z-test with
//    the variance of each block mean summed from the per-pixel variances,
//    Šidák-corrected over all blocks, channels and pairs (family level 1e-3).
//    Each estimator has its own seed, so the two images are independent and
//    var(A - B) = var(A) + var(B). A negative control shows that a 3% change
//    of the light's radiance is detected by the same check.
//  * Efficiency variants (samplers, Russian roulette's start, the constant
//    environment's guide) converge to the same image, on the box and on
//    Sponza's atrium under the sky; a 3% brighter light is told apart.
//  * Determinism: threads = 1 and threads = 2 give bit-identical film sums;
//    another seed gives another image.
//  * max_depth, Mitsuba's semantics: 1 shows only emitters, 2 is direct light
//    only (the ceiling, lit only through bounces, is black), 3 lights the
//    ceiling.
//  * No non-finite samples in any of these renders.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <string>
#include <vector>

#include "luz/device/cpu/render.h"
#include "luz/io/load.h"
#include "stat_helpers.h"
#include "sanitizer.h"

using namespace luz;
using luz_test::Blocks;
using luz_test::sidak_z;

namespace {

constexpr double kFamilyAlpha = 1e-3;
constexpr int kBlock = 8;

const std::string kCornell = LUZ_SOURCE_DIR "/scenes/cornell-box.xml";
const std::string kBitterli = LUZ_SHARED_DIR "/scenes/cornell-box-bitterli/mitsuba3/scene_v3.xml";

Scene load(const std::string& path, int res, const std::string& integrator = "path", int max_depth = 65) {
  Defines d{{"integrator", integrator}, {"max_depth", std::to_string(max_depth)}};
  if (path == kCornell)
    d["res"] = std::to_string(res);
  else {
    d["resx"] = std::to_string(res);
    d["resy"] = std::to_string(res);
  }
  Scene s = load_scene(path, d);
  EXPECT_EQ(s.camera.width, res);
  EXPECT_EQ(s.camera.height, res);
  EXPECT_EQ(s.settings.integrator.max_depth, max_depth);
  // Independent samples: the per-pixel sample variance is then an unbiased
  // estimate of the variance of the pixel mean (with a low-discrepancy
  // sampler it would only be an upper bound).
  s.settings.sampler = SamplerType::Independent;
  luz_test::independent_pixels(s);
  return s;
}

Film render(const Scene& s, int threads = 2) {
  CpuRenderOptions opt;
  opt.threads = threads;
  RenderStats stats;
  Film f = render_cpu(s, opt, stats);
  EXPECT_EQ(stats.discarded, 0u) << "non-finite samples";
  return f;
}

// Largest |z| over blocks and channels between two independent images.
struct Agreement {
  double worst_z = 0, median_rel_sigma = 0;
  int worst_bx = 0, worst_by = 0, worst_c = 0;
};

Agreement compare(const Film& a, const Film& b) {
  Blocks A = luz_test::make_blocks(a, kBlock), B = luz_test::make_blocks(b, kBlock);
  Agreement r;
  std::vector<double> rel;
  for (int by = 0; by < A.bh; ++by)
    for (int bx = 0; bx < A.bw; ++bx)
      for (int c = 0; c < 3; ++c) {
        double d = A.m(bx, by, c) - B.m(bx, by, c);
        double m = 0.5 * (A.m(bx, by, c) + B.m(bx, by, c));
        double floor = luz_test::rounding_floor(m);
        double sigma = std::sqrt(A.v(bx, by, c) + B.v(bx, by, c) + 2 * floor * floor);
        double z = std::fabs(d) / sigma;
        if (m > 0) rel.push_back(sigma / m);
        if (z > r.worst_z) {
          r.worst_z = z;
          r.worst_bx = bx;
          r.worst_by = by;
          r.worst_c = c;
        }
      }
  std::sort(rel.begin(), rel.end());
  r.median_rel_sigma = rel.empty() ? 0 : rel[rel.size() / 2];
  return r;
}

void estimators_agree(const std::string& path, int res, uint32_t spp, int max_depth) {
  const char* names[] = {"path", "bsdf", "light"};
  Film films[3];
  for (int k = 0; k < 3; ++k) {
    Scene s = load(path, res, names[k], max_depth);
    s.settings.spp = spp;
    s.settings.seed = 100 + k;  // independent images
    films[k] = render(s);
  }
  const int blocks = (res / kBlock) * (res / kBlock);
  const double thr = sidak_z(kFamilyAlpha, 3.0 * 3 * blocks);
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) {
      Agreement g = compare(films[i], films[j]);
      std::printf("[agree %s depth %d] %s vs %s: worst block z %.2f at (%d,%d) ch %d, threshold %.2f, median block "
                  "sigma %.2f%%\n",
                  path.substr(path.rfind('/') + 1).c_str(), max_depth, names[i], names[j], g.worst_z, g.worst_bx,
                  g.worst_by, g.worst_c, thr, 100 * g.median_rel_sigma);
      EXPECT_LE(g.worst_z, thr) << names[i] << " vs " << names[j] << " on " << path;
    }
}

}  // namespace

TEST(Integrator, EstimatorsAgreeCornellBox) { estimators_agree(kCornell, 64, 512, 65); }

TEST(Integrator, EstimatorsAgreeBitterliCornellBox) { estimators_agree(kBitterli, 64, 512, 65); }

// Direct light only (max_depth 2): the three estimators must agree there too.
TEST(Integrator, EstimatorsAgreeDirectLightOnly) { estimators_agree(kCornell, 64, 256, 2); }

// Negative control: the agreement check must see a 3% brighter light.
TEST(Integrator, AgreementCheckDetectsBrighterLight) {
  Scene a = load(kCornell, 64, "path");
  a.settings.spp = 256;
  a.settings.seed = 1;
  Scene b = load(kCornell, 64, "light");
  b.settings.spp = 256;
  b.settings.seed = 2;
  for (Light& l : b.lights) {
    ASSERT_EQ(l.type, LightType::Parallelogram);
    l.parallelogram.radiance = l.parallelogram.radiance * 1.03f;
  }
  b.compile();
  Agreement g = compare(render(a), render(b));
  const double thr = sidak_z(kFamilyAlpha, 3.0 * 3 * 64);
  std::printf("[agree negative control] path vs light with 1.03× light: worst block z %.1f (threshold %.2f)\n",
              g.worst_z, thr);
  EXPECT_GT(g.worst_z, thr);
}

// The variants bench/efficiency compares (issue 20) converge to the same
// image: the sobol and stratified samplers and Russian roulette from depth
// 2, each against an independent-sampler render with Mitsuba's roulette
// (another seed), on the box (area light) and Sponza inside (constant sky,
// sampled over the hemisphere). For a low-discrepancy image the per-pixel
// sample variance bounds the variance of its mean from above (Owen-scrambled
// nets and stratification only remove variance for these integrands), so the
// z-test is conservative; the negative control shows it still sees a 3%
// brighter light in a sobol image.
const std::string kSponzaInside = LUZ_SOURCE_DIR "/bench/scenes/sponza-inside.xml";

static Scene variant(const std::string& path, SamplerType sampler, int rr_depth, uint64_t seed, bool guide = false) {
  Scene s = path == kSponzaInside ? load_scene(path, {{"res", "64"}, {"max_depth", "10"}}) : load(path, 64);
  luz_test::independent_pixels(s);
  s.settings.sampler = sampler;
  s.settings.env_guide = guide;
  s.settings.integrator.rr_depth = rr_depth;
  s.settings.spp = path == kSponzaInside ? 128 : 256;
  s.settings.seed = seed;
  return s;
}

// The compared renders take sanitized_count's samples; the negative control keeps its own.
static Scene with_sanitized_count(Scene s) {
  s.settings.spp = luz_test::sanitized_count(s.settings.spp);
  return s;
}

TEST(Integrator, EfficiencyVariantsConvergeToTheSameImage) {
  struct Variant {
    const char* name;
    SamplerType sampler;
    int rr_depth;
    bool guide;  // the constant environment's (Sponza's sky)
  };
  const Variant variants[] = {{"sobol", SamplerType::Sobol, 5, false},
                              {"stratified", SamplerType::Stratified, 5, false},
                              {"independent, roulette from depth 2", SamplerType::Independent, 2, false},
                              {"sobol, roulette from depth 2", SamplerType::Sobol, 2, false},
                              {"independent, environment guide", SamplerType::Independent, 5, true},
                              {"sobol, environment guide", SamplerType::Sobol, 5, true}};
  // The guide only where there is a constant sky (the box has none).
  const double compared = 2.0 * std::size(variants) - std::count_if(std::begin(variants), std::end(variants),
                                                                    [](const Variant& v) { return v.guide; });
  const double thr = sidak_z(kFamilyAlpha, compared * 3 * 64);
  for (const std::string& path : {kCornell, kSponzaInside}) {
    const Film ref = render(with_sanitized_count(variant(path, SamplerType::Independent, 5, 11)));
    for (const Variant& v : variants) {
      if (v.guide && path != kSponzaInside) continue;
      Agreement g = compare(ref, render(with_sanitized_count(variant(path, v.sampler, v.rr_depth, 12, v.guide))));
      std::printf("[variants %s] %s vs independent: worst block z %.2f at (%d,%d) ch %d, threshold %.2f\n",
                  path.substr(path.rfind('/') + 1).c_str(), v.name, g.worst_z, g.worst_bx, g.worst_by, g.worst_c, thr);
      EXPECT_LE(g.worst_z, thr) << v.name << " on " << path;
    }
  }
  // Negative control: a sobol image of a 3% brighter light is told apart.
  Scene bright = variant(kCornell, SamplerType::Sobol, 5, 12);
  for (Light& l : bright.lights) l.parallelogram.radiance = l.parallelogram.radiance * 1.03f;
  bright.compile();
  Agreement g = compare(render(variant(kCornell, SamplerType::Independent, 5, 11)), render(bright));
  std::printf("[variants negative control] sobol with a 1.03x light: worst block z %.1f (threshold %.2f)\n", g.worst_z,
              thr);
  EXPECT_GT(g.worst_z, thr);
}

TEST(Integrator, DeterministicAcrossThreadCounts) {
  for (SamplerType st : {SamplerType::Independent, SamplerType::Sobol}) {
    Scene s = load(kBitterli, 32);
    s.settings.sampler = st;
    s.settings.spp = 16;
    s.settings.seed = 5;
    Film one = render(s, 1), two = render(s, 2);
    EXPECT_TRUE(one.sum == two.sum) << "sampler " << int(st);
    EXPECT_TRUE(one.sum_sq == two.sum_sq) << "sampler " << int(st);
    EXPECT_TRUE(one.count == two.count) << "sampler " << int(st);
    s.settings.seed = 6;
    Film other = render(s, 2);
    EXPECT_EQ(other.count, one.count);
    size_t differing = 0;
    for (size_t i = 0; i < one.sum.size(); ++i) differing += one.sum[i] != other.sum[i];
    // Pixels that see only the light (every sample the same) are equal; the rest differ.
    EXPECT_GT(differing, one.sum.size() * 9 / 10) << "sampler " << int(st);
  }
}

// max_depth 1: every sample is either the light's radiance (17, 12, 4) or
// zero, so every pixel is t·(17, 12, 4) with t in [0, 1]; pixels entirely
// inside the light have t = 1, and only a few pixels are non-black. (Both
// boxes at 128 pixels: their lights, seen nearly edge-on, are then about 4–5
// pixels tall, so some pixels' whole ±1-pixel tent footprint lies inside; at
// 64 pixels that held or failed by the luck of the sample positions.)
TEST(Integrator, MaxDepth1ShowsOnlyEmitters) {
  for (const std::string& path : {kCornell, kBitterli}) {
    Scene s = load(path, 128, "path", 1);
    s.settings.spp = 64;
    Film f = render(s);
    std::vector<double> m = luz_test::pixel_means(f);
    int lit = 0, full = 0;
    for (size_t i = 0; i < f.count.size(); ++i) {
      double t = m[3 * i] / 17.0;
      EXPECT_NEAR(m[3 * i + 1], 12.0 * t, 1e-4 * (1 + t)) << path << " pixel " << i;
      EXPECT_NEAR(m[3 * i + 2], 4.0 * t, 1e-4 * (1 + t)) << path << " pixel " << i;
      EXPECT_LE(t, 1.0 + 1e-6);
      lit += t > 0;
      full += t > 1.0 - 1e-6;
    }
    std::printf("[max_depth 1 %s] %d pixels see the light, %d only the light\n",
                path.substr(path.rfind('/') + 1).c_str(), lit, full);
    EXPECT_GT(full, 0);
    EXPECT_LT(lit, int(f.count.size()) / 20);
  }
}

// hide_emitters (Mitsuba's): the emission the camera sees directly goes, and
// nothing else. Each sample is the shown image's sample without its depth-1
// term, so with the same samples: where no sample reaches an emitter
// directly (the max_depth 1 image is 0) hidden and shown are bit-identical;
// elsewhere hidden + direct = shown up to float rounding of the terms'
// order; and hidden at max_depth 1 is black.
TEST(Integrator, HideEmittersRemovesOnlyWhatTheCameraSeesDirectly) {
  Scene shown = load(kCornell, 64);
  shown.settings.spp = 16;
  Scene hidden = shown, direct = shown;
  hidden.settings.integrator.hide_emitters = true;
  direct.settings.integrator.max_depth = 1;
  const Film fs = render(shown), fh = render(hidden), fd = render(direct);
  size_t lit = 0;
  for (size_t i = 0; i < fs.sum.size(); ++i) {
    if (fd.sum[i] == 0) {
      EXPECT_EQ(fh.sum[i], fs.sum[i]) << "value " << i;
    } else {
      ++lit;
      EXPECT_LT(fh.sum[i], fs.sum[i]) << "value " << i;
      EXPECT_NEAR(fh.sum[i] + fd.sum[i], fs.sum[i], 1e-5 * fs.sum[i]) << "value " << i;
    }
  }
  EXPECT_GT(lit, 0u);
  hidden.settings.integrator.max_depth = 1;
  const Film black = render(hidden);
  for (double v : black.sum) ASSERT_EQ(v, 0.0);
}

// max_depth 2 is direct light only. The ceiling of the Cornell box is above
// the plane of its downward-facing light, so it receives no direct light:
// black at depth 2, lit at depth 3. Ceiling pixels are found geometrically:
// the whole tent footprint (±1 pixel) must hit the ceiling rectangle
// (y = 548.8, 10 mm inside its edges), and the pixel must be 2 pixels away
// from any pixel that sees the light at depth 1.
TEST(Integrator, MaxDepth2IsDirectLightOnly) {
  const int res = 64;
  Scene s1 = load(kCornell, res, "path", 1);
  s1.settings.spp = 64;
  std::vector<double> light = luz_test::pixel_means(render(s1));
  auto sees_light = [&](int x, int y) {
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) {
        int u = x + dx, v = y + dy;
        if (u >= 0 && v >= 0 && u < res && v < res && light[3 * (size_t(v) * res + u)] > 0) return true;
      }
    return false;
  };
  const Camera& cam = s1.camera;
  auto on_ceiling = [&](float fx, float fy) {
    Ray r = cam.generate_ray(fx, fy);
    if (r.d.y <= 0) return false;
    float t = (548.8f - r.o.y) / r.d.y;
    float x = r.o.x + t * r.d.x, z = r.o.z + t * r.d.z;
    return x > 10.f && x < 546.f && z > 10.f && z < 549.f;
  };
  std::vector<int> ceiling;
  for (int y = 0; y < res; ++y)
    for (int x = 0; x < res; ++x) {
      float cx = x + 0.5f, cy = y + 0.5f;
      if (on_ceiling(cx - 1, cy - 1) && on_ceiling(cx + 1, cy - 1) && on_ceiling(cx - 1, cy + 1) &&
          on_ceiling(cx + 1, cy + 1) && !sees_light(x, y))
        ceiling.push_back(y * res + x);
    }
  std::printf("[max_depth] %zu ceiling pixels\n", ceiling.size());
  ASSERT_GT(ceiling.size(), 100u);

  for (const char* integ : {"path", "bsdf", "light"}) {
    Scene s2 = load(kCornell, res, integ, 2), s3 = load(kCornell, res, integ, 3);
    s2.settings.spp = s3.settings.spp = 64;
    Film f2 = render(s2), f3 = render(s3);
    std::vector<double> m2 = luz_test::pixel_means(f2), m3 = luz_test::pixel_means(f3);
    std::vector<double> v3 = f3.variance_of_mean();
    int black2 = 0, lit3 = 0;
    double floor_sum = 0, ceil3 = 0, ceil3_var = 0;
    for (int i : ceiling) {
      ceil3 += m3[3 * i + 2];  // blue, the weakest channel of the light
      ceil3_var += v3[3 * i + 2];
      bool b2 = true, l3 = true;
      for (int c = 0; c < 3; ++c) {
        b2 &= m2[3 * i + c] == 0.0;
        l3 &= m3[3 * i + c] > 0.0;
      }
      black2 += b2;
      lit3 += l3;
    }
    // The rest of the image is lit at depth 2 (e.g. the floor).
    for (size_t i = 0; i < f2.count.size(); ++i) floor_sum += m2[3 * i];
    double z3 = ceil3 / std::sqrt(ceil3_var);
    std::printf("[max_depth %s] ceiling: %d/%zu black at depth 2; at depth 3 %d/%zu lit, mean blue %.4f (z %.1f)\n",
                integ, black2, ceiling.size(), lit3, ceiling.size(), ceil3 / ceiling.size(), z3);
    EXPECT_EQ(black2, int(ceiling.size())) << integ;
    EXPECT_GT(z3, sidak_z(kFamilyAlpha, 1)) << integ;
    // With next-event estimation every ceiling pixel gets light at depth 3;
    // the bsdf estimator must hit the small light by chance, so only its
    // ceiling as a whole is tested.
    if (std::string(integ) != "bsdf") EXPECT_EQ(lit3, int(ceiling.size())) << integ;
    EXPECT_GT(floor_sum, 0.0);
  }
}
