// Piecewise-constant distributions over a grid of cells, stored in a flat
// float array (valid on the CPU or copied to the GPU as is) and addressed by
// offsets: what environment-map importance sampling uses (light/envmap.h).
//
// A 2-D distribution over nx × ny cells of unit size in (s, t) ∈ [0,nx)×[0,ny)
// with non-negative weights w: density w[j][i] / Σw (the cell's area is 1).
// Sampled as a row j by the marginal CDF, then a column i by row j's
// conditional CDF, each continuous within its cell (the CDF inverted
// linearly), so one uniform 2-D point gives one (s, t).
#pragma once

#include <cstdint>
#include <vector>

#include "luz/math/vec.h"

namespace luz {

// The largest i in [0, n) with cdf[i] <= u, for cdf[0] = 0 <= u: a
// branch-free binary search (ceil(log2 n) steps whatever u is). Empty cells
// (cdf[i] = cdf[i + 1]) are never returned when u < cdf[n].
LUZ_INLINE uint32_t cdf_find(const float* cdf, uint32_t n, float u) {
  uint32_t base = 0, len = n;
  while (len > 1) {
    uint32_t half = len / 2;
    base += cdf[base + half] <= u ? half : 0u;
    len -= half;
  }
  return base;
}

// u's position within [cdf[i], cdf[i + 1]), in [0, 1).
LUZ_INLINE float cdf_remap(const float* cdf, uint32_t i, float u) {
  const float lo = cdf[i], width = cdf[i + 1] - lo;
  return width > 0.f ? min(max((u - lo) / width, 0.f), kOneMinusEpsilon) : 0.f;
}

struct Distribution2D {
  uint32_t nx = 0, ny = 0;
  // Offsets into the data array: density per cell (ny rows of nx), the
  // marginal CDF over rows (ny + 1), the rows' conditional CDFs (ny × (nx + 1)).
  uint32_t density = 0, marginal = 0, conditional = 0;

  // A point (s, t) with density `pdf` (per unit of s·t); pdf 0 only if every
  // weight is 0.
  LUZ_INLINE Vec2 sample(const float* data, Vec2 u, float& pdf) const {
    const float* m = data + marginal;
    const uint32_t j = cdf_find(m, ny, u.y);
    const float fy = cdf_remap(m, j, u.y);
    const float* c = data + conditional + size_t(j) * (nx + 1);
    const uint32_t i = cdf_find(c, nx, u.x);
    const float fx = cdf_remap(c, i, u.x);
    pdf = data[density + size_t(j) * nx + i];
    return {float(i) + fx, float(j) + fy};
  }

  LUZ_INLINE float pdf(const float* data, Vec2 st) const {
    const uint32_t i = min(uint32_t(max(st.x, 0.f)), nx - 1), j = min(uint32_t(max(st.y, 0.f)), ny - 1);
    return data[density + size_t(j) * nx + i];
  }
};

// Appends the CDF of n non-negative weights summing to `sum` (n + 1 entries,
// from 0 to exactly 1); each zero weight leaves an empty step, which
// cdf_find skips. sum = 0: a uniform CDF.
inline void append_cdf(const double* weights, uint32_t n, double sum, std::vector<float>& out) {
  double acc = 0.0;
  out.push_back(0.f);
  for (uint32_t k = 0; k < n; ++k) {
    acc += weights[k];
    out.push_back(sum > 0.0 ? float(acc / sum) : float(double(k + 1) / n));
  }
  out.back() = 1.f;
}

// Appends a distribution over `w` (ny rows of nx weights, non-negative and
// finite) to data. All-zero weights give an all-zero density (and uniform
// CDFs, so that sampling still returns points in range).
inline Distribution2D build_distribution2d(const std::vector<double>& w, uint32_t nx, uint32_t ny,
                                           std::vector<float>& data) {
  Distribution2D d;
  d.nx = nx;
  d.ny = ny;
  std::vector<double> row_sum(ny, 0.0);
  double total = 0.0;
  for (uint32_t j = 0; j < ny; ++j) {
    for (uint32_t i = 0; i < nx; ++i) row_sum[j] += w[size_t(j) * nx + i];
    total += row_sum[j];
  }
  d.density = uint32_t(data.size());
  for (size_t k = 0; k < size_t(nx) * ny; ++k) data.push_back(total > 0.0 ? float(w[k] / total) : 0.f);
  d.marginal = uint32_t(data.size());
  append_cdf(row_sum.data(), ny, total, data);
  d.conditional = uint32_t(data.size());
  for (uint32_t j = 0; j < ny; ++j) append_cdf(w.data() + size_t(j) * nx, nx, row_sum[j], data);
  return d;
}

}  // namespace luz
