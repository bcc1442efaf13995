// Statistics shared by the integrator-level tests (test_furnace,
// test_integrator, test_reference): Šidák-corrected normal thresholds, and
// per-pixel / per-block means with the variance of those means, all taken
// from a Film's own sums (value, square, count).
#pragma once

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <vector>

#include "luz/film/film.h"

namespace luz_test {

// Two-sided normal threshold z such that m independent tests all pass with
// probability 1 - alpha (Šidák): P(|Z| > z) = 1 - (1 - alpha)^(1/m).
inline double sidak_z(double alpha, double m) {
  double a = -std::expm1(std::log1p(-alpha) / m);  // per-test level, accurate for tiny values
  double lo = 0, hi = 40;
  for (int i = 0; i < 200; ++i) {
    double mid = 0.5 * (lo + hi);
    if (std::erfc(mid / std::sqrt(2.0)) > a)
      lo = mid;
    else
      hi = mid;
  }
  return 0.5 * (lo + hi);
}

// A film reduced to blocks of b×b pixels: mean of the pixel means and the
// variance of that mean (pixels are independent: variances add).
struct Blocks {
  int bw = 0, bh = 0, b = 1;
  std::vector<double> mean, var;  // 3 per block, RGB
  double& m(int bx, int by, int c) { return mean[3 * (size_t(by) * bw + bx) + c]; }
  double& v(int bx, int by, int c) { return var[3 * (size_t(by) * bw + bx) + c]; }
};

// Pixel means in double straight from the sums (Film::mean() rounds to float).
inline std::vector<double> pixel_means(const luz::Film& f) {
  std::vector<double> out(f.sum.size());
  for (size_t i = 0; i < f.count.size(); ++i)
    for (int k = 0; k < 3; ++k) out[3 * i + k] = f.count[i] ? f.sum[3 * i + k] / f.count[i] : 0.0;
  return out;
}

inline Blocks make_blocks(const luz::Film& f, int b) {
  Blocks r;
  r.b = b;
  r.bw = f.width / b;
  r.bh = f.height / b;
  r.mean.assign(size_t(r.bw) * r.bh * 3, 0.0);
  r.var.assign(size_t(r.bw) * r.bh * 3, 0.0);
  std::vector<double> pm = pixel_means(f), pv = f.variance_of_mean();
  const double n2 = double(b) * b;
  for (int y = 0; y < r.bh * b; ++y)
    for (int x = 0; x < r.bw * b; ++x)
      for (int c = 0; c < 3; ++c) {
        size_t i = 3 * (size_t(y) * f.width + x) + c;
        r.m(x / b, y / b, c) += pm[i] / n2;
        r.v(x / b, y / b, c) += pv[i] / (n2 * n2);
      }
  return r;
}

// Standard deviation floor for an estimate whose sample variance is ~0 (e.g.
// every sample exactly 1): the float arithmetic of one path (a few dozen
// operations, each within FLT_EPSILON/2 relative) can move a sample by at most
// ~64 FLT_EPSILON of its magnitude, and so its mean.
inline double rounding_floor(double magnitude) { return 64.0 * FLT_EPSILON * std::max(std::fabs(magnitude), 1e-3); }

}  // namespace luz_test
