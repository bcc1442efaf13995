// Pixel reconstruction filters, applied by filter importance sampling: each
// sample's film position is drawn from the filter's own density, so every
// sample adds with weight one to the pixel it belongs to (no splatting, so
// pixels are independent and results do not depend on scheduling). Radii are
// Mitsuba's: box 0.5, tent 1, gaussian σ = 0.5 truncated at 4σ.
#pragma once

#include "luz/math/special.h"
#include "luz/math/vec.h"

namespace luz {

enum class FilterKind : uint32_t { Box, Tent, Gaussian };

// One axis of the filter: u in [0,1) to an offset from the pixel centre.
LUZ_INLINE float sample_filter_1d(FilterKind k, float u) {
  switch (k) {
    case FilterKind::Tent: {
      // -1 + sqrt(2u) below the middle, 1 - sqrt(2 - 2u) above: one square
      // root and two selects (the half is a coin toss: no branch to mispredict).
      const float x = 1.f - sqrtf(select_lt(u, 0.5f, 2.f * u, 2.f - 2.f * u));
      return select_lt(u, 0.5f, -x, x);
    }
    case FilterKind::Gaussian: {
      constexpr float kSigma = 0.5f, kRadius = 2.f;
      // Truncated normal by inverting its CDF: erf(±R/(σ√2)) bounds.
      const float e = erff(kRadius / (kSigma * 1.41421356f));
      float x = (2.f * u - 1.f) * e;
      return clamp(kSigma * 1.41421356f * erfinv(x), -kRadius, kRadius);
    }
    default:
      return u - 0.5f;
  }
}

LUZ_INLINE Vec2 sample_filter(FilterKind k, Vec2 u) { return {sample_filter_1d(k, u.x), sample_filter_1d(k, u.y)}; }

}  // namespace luz
