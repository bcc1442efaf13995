// Pixel reconstruction filters. Radii are Mitsuba's: box 0.5, tent 1,
// gaussian σ = 0.5 truncated at 4σ. Two ways to apply one
// (Reconstruction): filter importance sampling draws each sample's film
// position from the filter's own density around its pixel and adds it to
// that pixel alone (pbrt-v4's way: pixels' noise independent); splatting
// (Mitsuba's way, film/splat.h) takes samples uniform over each pixel's
// square and weighs each into every pixel the filter reaches: the same
// expected image, 2-3x less variance per pixel for the tent and gaussian.
#pragma once

#include "luz/math/special.h"
#include "luz/math/vec.h"

namespace luz {

enum class FilterKind : uint32_t { Box, Tent, Gaussian };
// How samples make pixels (above). Splat is the default; for the box filter
// the two are the same estimator and filter sampling is used.
enum class Reconstruction : uint32_t { Splat, FilterSampling };

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

// The filter's value at offset d from a pixel's centre, one axis,
// normalised to integrate to 1 (the density sample_filter_1d draws from).
LUZ_INLINE float filter_weight_1d(FilterKind k, float d) {
  d = fabsf(d);
  switch (k) {
    case FilterKind::Tent:
      return d < 1.f ? 1.f - d : 0.f;
    case FilterKind::Gaussian: {
      constexpr float kSigma = 0.5f, kRadius = 2.f;
      // 1 / (σ √(2π) erf(R / (σ √2))): the truncated normal's normalisation.
      constexpr float kNorm = 0.7978845608f / 0.9999366575f;
      return d < kRadius ? kNorm * expf(-d * d * (0.5f / (kSigma * kSigma))) : 0.f;
    }
    default:
      return d < 0.5f ? 1.f : 0.f;
  }
}

// How many pixels beyond its own a sample uniform over a pixel's square
// can reach: a pixel at offset j (|j| ≤ reach) from the sample's own.
LUZ_INLINE int filter_reach(FilterKind k) { return k == FilterKind::Tent ? 1 : k == FilterKind::Gaussian ? 2 : 0; }

// Whether a render splats: asked for, and a filter wider than a pixel.
LUZ_INLINE bool splats(Reconstruction r, FilterKind k) { return r == Reconstruction::Splat && filter_reach(k) > 0; }

}  // namespace luz
