// Where a constant environment is seen from a point: a per-region
// distribution of directions, so that next-event estimation aims at the sky
// that is visible (through a roof's opening, a window) rather than over the
// whole hemisphere, most of which a wall or ceiling blocks indoors. It plays
// the part of Cycles' and pbrt-v4's portals, found automatically.
//
// Regions are the cells of a uniform grid over the scene's lit vertices,
// split six ways by the side light arrives from (the dominant axis and sign
// of LightSampleContext::hemisphere). Each region with data holds a
// piecewise-constant density over kRows × kCols equal-area bins of the world
// sphere (rows by z, columns by φ): the cosine-weighted fraction of each
// bin's directions that escapes to the environment, as traced from the
// region's points by env_guide_build.h before the render. The environment
// samples it with probability `mix` and the cosine about the hemisphere's
// pole otherwise, its pdf the mixture's (so unbiased however poor the
// distribution: every direction the cosine reaches keeps a density).
#pragma once

#include "luz/math/vec.h"

namespace luz {

struct EnvGuide {
  static constexpr int kRows = 8, kCols = 16, kBins = kRows * kCols;
  static constexpr int kSides = 6;

  // Null: no guide (every point samples the cosine alone).
  const int32_t* regions = nullptr;  // [(cell z, y, x) * kSides + side]: a distribution, or -1
  const float* cdf = nullptr;        // kBins per distribution: P(bin <= i), the last exactly 1
  Vec3 lo{}, inv_cell{};             // the grid's corner, and cells per unit length
  int nx = 0, ny = 0, nz = 0;
  float mix = 0.f;                   // the probability of sampling a distribution where there is one

  // The distribution of the region holding p for light arriving from the
  // side of `pole`, or -1 (none; or pole zero: light from every side).
  LUZ_INLINE int find(Vec3 p, Vec3 pole) const {
    if (!regions) return -1;
    const float ax = fabsf(pole.x), ay = fabsf(pole.y), az = fabsf(pole.z);
    if (ax == 0.f && ay == 0.f && az == 0.f) return -1;
    const int side = ax >= ay && ax >= az ? (pole.x < 0.f) : ay >= az ? 2 + (pole.y < 0.f) : 4 + (pole.z < 0.f);
    const Vec3 c = (p - lo) * inv_cell;
    // Cells by truncation, clamped: points beyond the grid take its edge.
    const int x = c.x > 0.f ? min(int(c.x), nx - 1) : 0;
    const int y = c.y > 0.f ? min(int(c.y), ny - 1) : 0;
    const int z = c.z > 0.f ? min(int(c.z), nz - 1) : 0;
    return regions[((size_t(z) * ny + y) * nx + x) * kSides + side];
  }

  LUZ_INLINE static int bin_of(Vec3 w) {
    const int row = min(int((w.z + 1.f) * (0.5f * kRows)), kRows - 1);
    float phi = atan2f(w.y, w.x);
    if (phi < 0.f) phi += 2.f * kPi;
    const int col = min(int(phi * (kCols / (2.f * kPi))), kCols - 1);
    return max(row, 0) * kCols + max(col, 0);
  }

  // The solid-angle density of distribution d toward w.
  LUZ_INLINE float pdf(int d, Vec3 w) const {
    const float* c = cdf + size_t(d) * kBins;
    const int b = bin_of(w);
    return (c[b] - (b > 0 ? c[b - 1] : 0.f)) * (kBins * kInv4Pi);
  }

  // A direction from distribution d and its density.
  LUZ_INLINE Vec3 sample(int d, Vec2 u, float& pdf_out) const {
    const float* c = cdf + size_t(d) * kBins;
    int lo_i = 0, hi_i = kBins - 1;  // the first bin whose cdf exceeds u.x
    while (lo_i < hi_i) {
      const int mid = (lo_i + hi_i) / 2;
      if (c[mid] > u.x) hi_i = mid;
      else lo_i = mid + 1;
    }
    const float c0 = lo_i > 0 ? c[lo_i - 1] : 0.f, p = c[lo_i] - c0;
    const float v = p > 0.f ? min((u.x - c0) / p, kOneMinusEpsilon) : 0.5f;
    const int row = lo_i / kCols, col = lo_i % kCols;
    const float z = -1.f + (float(row) + v) * (2.f / kRows);
    const float phi = (float(col) + u.y) * (2.f * kPi / kCols);
    const float r = sqrtf(fmaxf(0.f, 1.f - z * z));
    pdf_out = p * (kBins * kInv4Pi);
    return {r * cosf(phi), r * sinf(phi), z};
  }
};

}  // namespace luz
