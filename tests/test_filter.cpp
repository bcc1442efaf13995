// Pixel filter importance sampling: the 1D offsets drawn by sample_filter_1d
// follow the normalised filter (box, tent, truncated gaussian σ = 0.5, r = 2),
// checked by a chi-square test against the exact bin integrals of the filter.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

#include "luz/film/filter.h"
#include "luz/math/hash.h"

using namespace luz;

namespace {

// Upper critical value of χ²(dof) at tail probability α, Wilson-Hilferty.
double chi2_critical(double dof, double alpha) {
  // z quantile by bisection on the normal tail.
  double lo = 0, hi = 10;
  for (int i = 0; i < 100; ++i) {
    double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(mid / std::sqrt(2.0)) > alpha ? lo : hi) = mid;
  }
  double z = 0.5 * (lo + hi), h = 2.0 / (9.0 * dof);
  return dof * std::pow(1 - h + z * std::sqrt(h), 3);
}

// cdf: the filter's normalised CDF on [-r, r].
void check_filter(FilterKind kind, double radius, const std::function<double(double)>& cdf, int tests_in_file) {
  const int bins = 64, n = 400000;
  std::vector<double> observed(bins, 0);
  for (int i = 0; i < n; ++i) {
    float u = to_unit_float(mix64(uint64_t(i) * 0x9e3779b97f4a7c15ull + uint64_t(kind)));
    double x = sample_filter_1d(kind, u);
    ASSERT_GE(x, -radius);
    ASSERT_LE(x, radius);
    int b = std::min(bins - 1, int((x + radius) / (2 * radius) * bins));
    observed[size_t(b)]++;
  }
  double chi2 = 0;
  int dof = -1;
  double pooled_obs = 0, pooled_exp = 0;
  for (int b = 0; b < bins; ++b) {
    double a = -radius + 2 * radius * b / bins, c = -radius + 2 * radius * (b + 1) / bins;
    double e = n * (cdf(c) - cdf(a));
    if (e < 5) {  // pool low-expectation bins
      pooled_obs += observed[size_t(b)];
      pooled_exp += e;
      continue;
    }
    chi2 += (observed[size_t(b)] - e) * (observed[size_t(b)] - e) / e;
    ++dof;
  }
  if (pooled_exp > 0) {
    chi2 += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / std::max(pooled_exp, 1e-9);
    ++dof;
  }
  double alpha = 1 - std::pow(1 - 0.01, 1.0 / tests_in_file);  // Šidák
  double crit = chi2_critical(dof, alpha);
  EXPECT_LT(chi2, crit) << "χ² = " << chi2 << " with " << dof << " dof";
}

constexpr int kTests = 4;

}  // namespace

TEST(Filter, BoxIsUniform) {
  check_filter(FilterKind::Box, 0.5, [](double x) { return x + 0.5; }, kTests);
}

TEST(Filter, TentFollowsOneMinusAbsX) {
  check_filter(
      FilterKind::Tent, 1.0, [](double x) { return x < 0 ? 0.5 * (1 + x) * (1 + x) : 1 - 0.5 * (1 - x) * (1 - x); },
      kTests);
}

TEST(Filter, GaussianFollowsTruncatedNormal) {
  const double s = 0.5, r = 2.0, e = std::erf(r / (s * std::sqrt(2.0)));
  check_filter(
      FilterKind::Gaussian, r, [&](double x) { return 0.5 * (1 + std::erf(x / (s * std::sqrt(2.0))) / e); }, kTests);
}

// The same check must reject a wrong filter: box samples tested against a tent.
TEST(Filter, CheckRejectsAWrongDensity) {
  const int bins = 32, n = 100000;
  std::vector<double> observed(bins, 0);
  for (int i = 0; i < n; ++i) {
    double x = sample_filter_1d(FilterKind::Box, to_unit_float(mix64(uint64_t(i) + 77))) * 2.0;  // uniform on [-1,1]
    observed[size_t(std::min(bins - 1, int((x + 1) / 2 * bins)))]++;
  }
  auto tent_cdf = [](double x) { return x < 0 ? 0.5 * (1 + x) * (1 + x) : 1 - 0.5 * (1 - x) * (1 - x); };
  double chi2 = 0;
  int dof = -1;
  for (int b = 0; b < bins; ++b) {
    double e = n * (tent_cdf(-1 + 2.0 * (b + 1) / bins) - tent_cdf(-1 + 2.0 * b / bins));
    if (e < 5) continue;
    chi2 += (observed[size_t(b)] - e) * (observed[size_t(b)] - e) / e;
    ++dof;
  }
  EXPECT_GT(chi2, chi2_critical(dof, 1 - std::pow(0.99, 1.0 / kTests)));
}
