// Whole image against an independent renderer (DESIGN.md, validation layer 4):
// Bitterli's Cornell box, Mitsuba 3 version, rendered by Luz, against the
// Tungsten rendering of the same scene shipped with it (1024×1024 half float).
//
// Luz renders at 128×128 with a box pixel filter, so a Luz pixel estimates the
// plain average of the image over its square; the reference is box-averaged
// 8×8 down to the same grid. (Its own tent filter is 1/1024 of the image wide,
// 1/8 of a Luz pixel: a blur that moves no block mean measurably, so no block
// on a hard edge needs excluding.) Both are reduced to 8×8-Luz-pixel blocks
// (256 blocks) and compared per block and channel:
//
//   |luz - ref| ≤ z · sqrt(σ²_luz + σ²_ref)
//
//   σ²_luz  variance of Luz's block mean, from its per-pixel sample variance;
//   σ²_ref  the reference's own Monte Carlo noise, measured from the reference
//           (robust residual estimate, below) / 4096 reference pixels per
//           block. This is the only allowance for the reference; measured:
//           per-pixel noise ≈ 0.9% (median), so σ_ref is ≈ 4% of σ_luz for the
//           median block (it is printed);
//   z       Šidák-corrected two-sided threshold over all blocks and channels
//           plus the three image-mean tests, family level 1e-3.
//
// The half-float storage of the reference rounds each value by at most 2^-11
// (0.05%) relative; with pixel noise ≈ 20× larger the rounding is dithered,
// unbiased, and its variance is already inside the measured σ²_ref, so it gets
// no separate term. The conversions (Tungsten quad ↔ Mitsuba rectangle, Tungsten
// max_bounces 64 (path segments, as Mitsuba's max_depth counts them:
// test_reference_scenes.cpp) ↔ the file's max_depth 65, whose extra bounce
// carries ~0.7^64 here, both one-sided area lights, tent filter ↔ box) need
// no further tolerance: the worst block z against Luz's σ alone is printed
// and stays well inside the threshold.
//
// The same bound is applied to the image mean per channel; its relative
// difference is printed.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "luz/io/image.h"
#include "luz/io/load.h"
#include "scene_helpers.h"
#include "stat_helpers.h"

using namespace luz;

namespace {

constexpr int kRes = 128;
constexpr int kBlock = 8;
constexpr uint32_t kSpp = 1024;
constexpr double kFamilyAlpha = 1e-3;
constexpr double kHalfUlp = 1.0 / 2048.0;  // half-float rounding, relative: 2^-11

const std::string kScene = LUZ_SHARED_DIR "/scenes/cornell-box-bitterli/mitsuba3/scene_v3.xml";
const std::string kReference = LUZ_SHARED_DIR "/scenes/cornell-box-bitterli/reference/TungstenRender.exr";

}  // namespace

TEST(Reference, BitterliCornellBoxMatchesTungsten) {
  Image ref = read_exr(kReference);
  ASSERT_EQ(ref.width, 1024);
  ASSERT_EQ(ref.height, 1024);
  const int f = ref.width / kRes;  // reference pixels per Luz pixel, per axis

  Scene s = load_scene(kScene, {{"resx", std::to_string(kRes)}, {"resy", std::to_string(kRes)}});
  s.settings.integrator.type = IntegratorType::Path;
  ASSERT_EQ(s.settings.integrator.max_depth, 65);  // Tungsten: max_bounces 64
  s.settings.sampler = SamplerType::Independent;
  s.settings.spp = kSpp;
  s.settings.seed = 2024;
  s.settings.filter = FilterKind::Box;
  auto t0 = std::chrono::steady_clock::now();
  Film film = luz_test::render_finite(s);
  double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // Reference: f×f reference pixels per Luz pixel, 8×8 Luz pixels per block;
  // its own noise per block from neighbour residuals (stat_helpers.h).
  luz_test::Blocks L = luz_test::make_blocks(film, kBlock);
  const int nb = kRes / kBlock, bpx = kBlock * f;  // reference pixels per block, per axis
  const luz_test::ReferenceBlocks R = luz_test::reference_blocks(ref, nb, nb, bpx);
  const std::vector<double>& Rm = R.mean;
  const std::vector<double>& Rv = R.var;

  // Diagnostics: the reference's per-pixel relative noise (median over
  // blocks), its share of the block sigma, and the worst block z-score if the
  // reference were taken as exact.
  {
    double worst_luz_only = 0;
    std::vector<double> ratio;
    for (int by = 0; by < nb; ++by)
      for (int bx = 0; bx < nb; ++bx)
        for (int c = 0; c < 3; ++c) {
          size_t b = 3 * (size_t(by) * nb + bx) + c;
          worst_luz_only = std::max(worst_luz_only, std::fabs(L.m(bx, by, c) - Rm[b]) / std::sqrt(L.v(bx, by, c)));
          ratio.push_back(std::sqrt(Rv[b] / L.v(bx, by, c)));
        }
    std::sort(ratio.begin(), ratio.end());
    std::printf("[reference] reference per-pixel noise: median %.2f%% relative (half-float half-ulp: %.3f%%); "
                "block sigma ref/luz: median %.2f, max %.2f; worst block z against Luz's sigma alone %.2f\n",
                100 * R.rel_noise_median, 100 * kHalfUlp, ratio[ratio.size() / 2], ratio.back(),
                worst_luz_only);
  }

  const double thr = luz_test::sidak_z(kFamilyAlpha, 3.0 * nb * nb + 3);
  double worst = -1e30, sum_luz_var = 0, sum_ref_var = 0;
  int wbx = 0, wby = 0, wc = 0, failures = 0;
  for (int by = 0; by < nb; ++by)
    for (int bx = 0; bx < nb; ++bx)
      for (int c = 0; c < 3; ++c) {
        size_t b = 3 * (size_t(by) * nb + bx) + c;
        double lv = L.v(bx, by, c), rv = Rv[b];
        double floor = luz_test::rounding_floor(Rm[b]);
        double sigma = std::sqrt(lv + rv + floor * floor);
        double z = std::fabs(L.m(bx, by, c) - Rm[b]) / sigma;
        sum_luz_var += lv;
        sum_ref_var += rv;
        if (z > thr) {
          ++failures;
          std::printf("  block (%2d,%2d) ch %d: luz %.5f ref %.5f (%.2f%%), sigma luz %.5f ref %.5f, z %.2f\n", bx, by,
                      c, L.m(bx, by, c), Rm[b], 100 * (L.m(bx, by, c) / Rm[b] - 1), std::sqrt(lv), std::sqrt(rv), z);
        }
        if (z > worst) {
          worst = z;
          wbx = bx;
          wby = by;
          wc = c;
        }
      }

  // Image means.
  double img_z = 0;
  for (int c = 0; c < 3; ++c) {
    double lm = 0, lv = 0, rm = 0, rv = 0;
    for (size_t b = c; b < Rm.size(); b += 3) {
      lm += L.mean[b];
      lv += L.var[b];
      rm += Rm[b];
      rv += Rv[b];
    }
    double nbb = double(nb) * nb;
    lm /= nbb;
    rm /= nbb;
    lv /= nbb * nbb;
    rv /= nbb * nbb;
    double z = std::fabs(lm - rm) / std::sqrt(lv + rv);
    img_z = std::max(img_z, z);
    // Negative control: a Luz image 0.5% too bright must fail this same test.
    EXPECT_GT(std::fabs(1.005 * lm - rm) / std::sqrt(1.005 * 1.005 * lv + rv), thr) << "test has no power, channel " << c;
    std::printf("[reference] channel %d: image mean luz %.5f tungsten %.5f, relative difference %+.3f%% "
                "(sigma luz %.3f%%, ref %.3f%%), z %.2f\n",
                c, lm, rm, 100 * (lm / rm - 1), 100 * std::sqrt(lv) / rm, 100 * std::sqrt(rv) / rm, z);
    EXPECT_LE(z, thr) << "image mean, channel " << c;
  }
  std::printf("[reference] %dx%d, %u spp, %.1f s; worst block z %.2f at (%d,%d) ch %d, threshold %.2f; "
              "rms block sigma luz %.3g, reference noise %.3g; %d blocks over\n",
              kRes, kRes, kSpp, secs, worst, wbx, wby, wc, thr, std::sqrt(sum_luz_var / (3.0 * nb * nb)),
              std::sqrt(sum_ref_var / (3.0 * nb * nb)), failures);
  EXPECT_EQ(failures, 0);
}
