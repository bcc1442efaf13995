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
#include "luz/io/image.h"
#include "luz/scene/scene.h"

namespace luz_test {

// Block statistics (make_blocks) add pixels' variances, which holds when
// their noise is independent: filter sampling. Splatting shares samples
// between neighbouring pixels (film/splat.h); test_render compares it with
// filter sampling across seeds.
inline void independent_pixels(luz::Scene& s) { s.settings.reconstruction = luz::Reconstruction::FilterSampling; }

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

// A reference image's block means and the variance of each block mean, over
// nbx × nby blocks of bpx × bpx reference pixels (3 values per block, RGB).
// The reference's per-pixel noise comes from the residuals
// r = p - (l + r + u + d)/4 against the 4-neighbour average, which cancel
// linear gradients; for independent pixel noise of variance σ²,
// r ~ N(0, 1.25 σ²). The median of |r| (σ_r = 1.4826 · median|r|) keeps the
// few pixels on hard edges (light outlines, silhouettes) from passing for
// noise. rel_noise_median: the median over blocks of the per-pixel relative
// noise (blocks with mean > 1e-3).
struct ReferenceBlocks {
  std::vector<double> mean, var;
  double rel_noise_median = 0;
};

inline ReferenceBlocks reference_blocks(const luz::Image& ref, int nbx, int nby, int bpx) {
  auto at = [&](int x, int y, int c) {
    x = x < 0 ? 1 : (x >= ref.width ? ref.width - 2 : x);  // reflect at the border
    y = y < 0 ? 1 : (y >= ref.height ? ref.height - 2 : y);
    return double(ref.rgb[3 * (size_t(y) * ref.width + x) + c]);
  };
  ReferenceBlocks R;
  R.mean.assign(size_t(nbx) * nby * 3, 0.0);
  R.var.assign(size_t(nbx) * nby * 3, 0.0);
  std::vector<double> absr(size_t(bpx) * bpx), rel_noise;
  for (int by = 0; by < nby; ++by)
    for (int bx = 0; bx < nbx; ++bx)
      for (int c = 0; c < 3; ++c) {
        double s1 = 0;
        size_t k = 0;
        for (int v = by * bpx; v < (by + 1) * bpx; ++v)
          for (int u = bx * bpx; u < (bx + 1) * bpx; ++u) {
            double p = at(u, v, c);
            s1 += p;
            absr[k++] = std::fabs(p - 0.25 * (at(u - 1, v, c) + at(u + 1, v, c) + at(u, v - 1, c) + at(u, v + 1, c)));
          }
        std::nth_element(absr.begin(), absr.begin() + absr.size() / 2, absr.end());
        double sigma_r = 1.4826 * absr[absr.size() / 2];
        double pixel_var = sigma_r * sigma_r / 1.25;
        size_t b = 3 * (size_t(by) * nbx + bx) + c;
        R.mean[b] = s1 / absr.size();
        R.var[b] = pixel_var / absr.size();
        if (R.mean[b] > 1e-3) rel_noise.push_back(std::sqrt(pixel_var) / R.mean[b]);
      }
  std::sort(rel_noise.begin(), rel_noise.end());
  R.rel_noise_median = rel_noise.empty() ? 0 : rel_noise[rel_noise.size() / 2];
  return R;
}

}  // namespace luz_test
