// Pixel reconstruction filters, applied by filter importance sampling: each
// sample's film position is drawn from the filter's own density, so every
// sample adds with weight one to the pixel it belongs to (no splatting, so
// pixels are independent and results do not depend on scheduling). Radii are
// Mitsuba's: box 0.5, tent 1, gaussian σ = 0.5 truncated at 4σ.
#pragma once

#include "luz/math/vec.h"

namespace luz {

enum class FilterKind : uint32_t { Box, Tent, Gaussian };

// Inverse error function, Giles 2010 single-precision approximation.
LUZ_INLINE float erfinv_approx(float x) {
  float w = -logf((1.f - x) * (1.f + x)), p;
  if (w < 5.f) {
    w = w - 2.5f;
    p = 2.81022636e-08f;
    p = 3.43273939e-07f + p * w;
    p = -3.5233877e-06f + p * w;
    p = -4.39150654e-06f + p * w;
    p = 0.00021858087f + p * w;
    p = -0.00125372503f + p * w;
    p = -0.00417768164f + p * w;
    p = 0.246640727f + p * w;
    p = 1.50140941f + p * w;
  } else {
    w = sqrtf(w) - 3.f;
    p = -0.000200214257f;
    p = 0.000100950558f + p * w;
    p = 0.00134934322f + p * w;
    p = -0.00367342844f + p * w;
    p = 0.00573950773f + p * w;
    p = -0.0076224613f + p * w;
    p = 0.00943887047f + p * w;
    p = 1.00167406f + p * w;
    p = 2.83297682f + p * w;
  }
  return p * x;
}

// One axis of the filter: u in [0,1) to an offset from the pixel centre.
LUZ_INLINE float sample_filter_1d(FilterKind k, float u) {
  switch (k) {
    case FilterKind::Tent:
      return u < 0.5f ? -1.f + sqrtf(2.f * u) : 1.f - sqrtf(2.f - 2.f * u);
    case FilterKind::Gaussian: {
      constexpr float kSigma = 0.5f, kRadius = 2.f;
      // Truncated normal by inverting its CDF: erf(±R/(σ√2)) bounds.
      const float e = erff(kRadius / (kSigma * 1.41421356f));
      float x = (2.f * u - 1.f) * e;
      return clamp(kSigma * 1.41421356f * erfinv_approx(x), -kRadius, kRadius);
    }
    default:
      return u - 0.5f;
  }
}

LUZ_INLINE Vec2 sample_filter(FilterKind k, Vec2 u) { return {sample_filter_1d(k, u.x), sample_filter_1d(k, u.y)}; }

}  // namespace luz
