// Piecewise-constant distributions over a grid of cells, stored in a flat
// float array (valid on the CPU or copied to the GPU as is) and addressed by
// offsets: what environment-map importance sampling uses (light/envmap.h).
//
// A 2-D distribution over nx × ny cells of unit size in (s, t) ∈ [0,nx)×[0,ny)
// with non-negative weights w: density w[j][i] / Σw (the cell's area is 1).
// Sampled as a row j by the marginal CDF, then a column i by row j's
// conditional CDF, each continuous within its cell (the CDF inverted
// linearly), so one uniform 2-D point gives one (s, t).
//
// AliasTable: a discrete distribution over n items by Walker's alias method
// (Vose's O(n) construction, "A linear algorithm for generating random
// numbers with a given distribution", IEEE TSE 1991): O(1) sampling, with
// sample reuse. What power-proportional light selection uses.
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

// One column of an alias table: u within the column below `q` picks the
// column's own item, above it the item `alias`.
struct AliasEntry {
  float q = 1.f;
  uint32_t alias = 0;
};

struct AliasSample {
  uint32_t index = 0;
  float pmf = 0.f;
  float u = 0.f;  // the input u, remapped to [0, 1) uniformly given the choice
};

struct AliasTable {
  const AliasEntry* entries = nullptr;
  const float* pmfs = nullptr;  // pmfs[i] = w[i] / Σw, computed in double
  uint32_t n = 0;               // 0: no weight, nothing to sample

  // u ∈ [0, 1) picks column floor(u n), then the fraction within it picks
  // the column's item or its alias; that fraction, rescaled to the part of
  // the column the choice took, is the remapped u. Each column part mapping
  // to an item is uniform in it, so the remapped u is uniform given the item.
  LUZ_INLINE AliasSample sample(float u) const {
    const float x = u * float(n);
    const uint32_t col = min(uint32_t(x), n - 1);
    const float f = min(x - float(col), kOneMinusEpsilon);
    const AliasEntry e = entries[col];
    AliasSample s;
    if (f < e.q) {
      s.index = col;
      s.u = min(f / e.q, kOneMinusEpsilon);
    } else {
      s.index = e.alias;
      s.u = min((f - e.q) / (1.f - e.q), kOneMinusEpsilon);
    }
    s.pmf = pmfs[s.index];
    return s;
  }

  LUZ_INLINE float pmf(uint32_t i) const { return pmfs[i]; }
};

// Builds the alias table of n non-negative finite weights into entries and
// pmfs (n each, replaced). Returns false, leaving both all-zero pmfs and
// uniform columns, when the weights sum to 0. Zero weights get q = 0 and an
// alias of positive weight: never chosen.
inline bool build_alias_table(const double* w, uint32_t n, std::vector<AliasEntry>& entries,
                              std::vector<float>& pmfs) {
  entries.assign(n, AliasEntry{});
  pmfs.assign(n, 0.f);
  double total = 0.0;
  for (uint32_t i = 0; i < n; ++i) total += w[i];
  if (!(total > 0.0)) {
    for (uint32_t i = 0; i < n; ++i) entries[i].alias = i;
    return false;
  }
  // Scaled so that the mean is 1; columns below 1 take their rest from
  // one above 1 (Vose's small and large work lists).
  std::vector<double> p(n);
  std::vector<uint32_t> small, large;
  uint32_t positive = 0;
  for (uint32_t i = 0; i < n; ++i) {
    pmfs[i] = float(w[i] / total);
    p[i] = w[i] / total * n;
    (p[i] < 1.0 ? small : large).push_back(i);
    if (w[i] > 0.0) positive = i;
  }
  while (!small.empty() && !large.empty()) {
    const uint32_t s = small.back(), l = large.back();
    small.pop_back();
    entries[s] = {float(p[s]), l};
    p[l] -= 1.0 - p[s];
    if (p[l] < 1.0) {
      large.pop_back();
      small.push_back(l);
    }
  }
  // What rounding leaves is (close to) 1: the column is all its own, unless
  // its item has no weight.
  for (const auto* rest : {&small, &large})
    for (uint32_t i : *rest) entries[i] = w[i] > 0.0 ? AliasEntry{1.f, i} : AliasEntry{0.f, positive};
  return true;
}

}  // namespace luz
