// The chi-square harness itself (tests/chi2.h): its p-values against closed
// forms, its pooling, and its calibration under the null hypothesis (a correct
// sampler must pass at the advertised rate, no more, no less).
#include <gtest/gtest.h>

#include <cmath>

#include "chi2.h"
#include "luz/sampling/warp.h"

namespace {

// P(χ²_k ≥ x) in closed form (long double, log-space terms): for even k the
// Poisson sum, for odd k erfc plus the half-integer series.
double chi2_sf_closed_form(double x, int k) {
  long double y = 0.5L * x, s = 0.0L;
  if (k % 2 == 0) {
    for (int j = 0; j < k / 2; ++j) s += std::exp(-y + j * std::log(y) - std::lgamma((long double)j + 1.0L));
    return double(s);
  }
  s = std::erfc(std::sqrt(y));
  for (int j = 0; j < (k - 1) / 2; ++j)
    s += std::exp(-y + (j + 0.5L) * std::log(y) - std::lgamma((long double)j + 1.5L));
  return double(s);
}

}  // namespace

TEST(Chi2Harness, SurvivalFunctionMatchesClosedForms) {
  const int dofs[] = {1, 2, 3, 4, 7, 10, 25, 99, 100, 399, 800};
  for (int k : dofs)
    for (double f : {0.05, 0.3, 0.8, 1.0, 1.3, 2.0, 3.0}) {
      double x = f * k + (f > 1.0 ? 3.0 * std::sqrt(2.0 * k) * (f - 1.0) : 0.0);
      double want = chi2_sf_closed_form(x, k), got = chi2::chi2_survival(x, k);
      EXPECT_NEAR(got, want, 1e-12 + 1e-9 * want) << "dof " << k << " x " << x;
    }
  // Textbook critical values.
  EXPECT_NEAR(chi2::chi2_survival(3.841458820694124, 1), 0.05, 1e-12);
  EXPECT_NEAR(chi2::chi2_survival(18.307038053275146, 10), 0.05, 1e-12);
  EXPECT_NEAR(chi2::chi2_survival(124.34211340400407, 100), 0.05, 1e-10);
  EXPECT_NEAR(chi2::sidak(0.01, 1), 0.01, 1e-15);
  EXPECT_NEAR(chi2::sidak(0.01, 20), 5.0237e-4, 1e-7);
  EXPECT_NEAR(chi2::normal_two_sided_quantile(0.05), 1.959963984540054, 1e-9);
}

TEST(Chi2Harness, PoolsSmallBinsAndFlagsImpossibleSamples) {
  // Two bins below 5 pool into one: 3 effective bins, dof 2.
  chi2::Result r = chi2::chi2_test({2, 3, 50, 45}, {2.5, 2.5, 50, 45});
  EXPECT_EQ(r.pooled, 2);
  EXPECT_EQ(r.dof, 2);
  EXPECT_NEAR(r.statistic, 0.0, 1e-12);
  EXPECT_TRUE(r.passes(0.01));
  // Samples where the expected count is zero fail whatever the statistic.
  chi2::Result z = chi2::chi2_test({10, 50, 40}, {0, 55, 45});
  EXPECT_FALSE(z.passes(0.01)) << z.summary();
}

TEST(Chi2Harness, AdaptiveCubatureHandlesDiscontinuities) {
  // Smooth: ∫ sin θ over a hemisphere, to the tolerance asked.
  double hemi =
      chi2::integrate_2d([](double t, double) { return std::sin(t); }, 0, chi2::kPi / 2, 0, 2 * chi2::kPi, 1e-10);
  EXPECT_NEAR(hemi, 2 * chi2::kPi, 1e-9);
  // A jump along a curve: the quarter disk in the unit square (one 5×5 rule
  // is off by ~1e-2).
  double quarter = chi2::integrate_2d([](double x, double y) { return x * x + y * y <= 1.0 ? 1.0 : 0.0; }, 0, 1, 0, 1,
                                      1e-5, 1e-12, 8, 6);
  EXPECT_NEAR(quarter, chi2::kPi / 4.0, 1e-4);
  // A sliver of width 1e-2 across the square at an angle: wider than the node
  // spacing of the initial cells, so it must be found.
  double sliver = chi2::integrate_2d([](double x, double y) { return std::fabs(y - 0.3 - 0.4 * x) < 5e-3 ? 1.0 : 0.0; },
                                     0, 1, 0, 1, 1e-5, 1e-12, 8, 6);
  EXPECT_NEAR(sliver, 1e-2, 1e-4);
}

// Under the null hypothesis the p-values are uniform: out of M independent
// tests of a correct sampler (uniform sphere), the number with p < 0.1 is
// Binomial(M, 0.1). Reject if it falls outside the central 99.9% of that law;
// too many failures means the harness is anticonservative (e.g. wrong
// expected counts), too few that it is blind.
TEST(Chi2Harness, CalibratedUnderTheNull) {
  const int M = 100;
  int below = 0;
  double mean_stat_over_dof = 0.0;
  for (int m = 0; m < M; ++m) {
    chi2::SphereGrid g;
    auto sample = [&](uint64_t i, luz::Vec3& w) {
      w = luz::square_to_uniform_sphere(chi2::rand2(1000 + m, i, 0));
      return true;
    };
    auto pdf = [](chi2::D3) { return double(luz::uniform_sphere_pdf()); };
    chi2::Outcome o = chi2::run_sphere(g, 20000, sample, pdf);
    ASSERT_TRUE(o.result.error.empty()) << o.describe(0.0);
    if (o.result.p_value < 0.1) ++below;
    mean_stat_over_dof += o.result.statistic / o.result.dof / M;
  }
  // Binomial(100, 0.1) two-sided 99.9% range, from its exact CDF.
  auto cdf = [&](int k) {
    double s = 0.0;
    for (int j = 0; j <= k; ++j)
      s += std::exp(std::lgamma(M + 1.0) - std::lgamma(j + 1.0) - std::lgamma(M - j + 1.0) + j * std::log(0.1) +
                    (M - j) * std::log(0.9));
    return s;
  };
  int lo = 0, hi = M;
  while (cdf(lo) < 0.0005) ++lo;
  while (hi > 0 && cdf(hi - 1) > 0.9995) --hi;
  std::printf("calibration: %d of %d tests with p < 0.1 (accepted range [%d, %d]); mean chi2/dof = %.4f\n", below, M,
              lo, hi, mean_stat_over_dof);
  EXPECT_GE(below, lo);
  EXPECT_LE(below, hi);
}
