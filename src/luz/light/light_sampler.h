// Light selection for next-event estimation: sample(ctx, u) picks a light,
// pmf(ctx, light) is the probability it would have picked that one. Today in
// proportion to power (Light::phi) by inverting a CDF; the shading point
// does not enter it yet.
#pragma once

#include "luz/light/light.h"

namespace luz {

struct SampledLight {
  uint32_t light = 0;
  float pmf = 0.f;
};

struct PowerLightSampler {
  // cdf[k] = P(choose one of 0..k); pmf_[k] = P(choose k). n = 0: no light
  // has power, nothing is sampled.
  const float* cdf = nullptr;
  const float* pmfs = nullptr;
  uint32_t n = 0;

  // Index of the light selected by u: the first k with u < cdf[k], by a
  // branch-free binary search (the answer stays in [base, base + len); the
  // loop runs ceil(log2 n) times whatever u is, and the comparison, a coin
  // flip for the branch predictor, becomes a conditional move).
  LUZ_INLINE uint32_t select(float u) const {
    uint32_t base = 0, len = n;
    while (len > 1) {
      uint32_t half = len / 2;
      base += cdf[base + half - 1] <= u ? half : 0u;
      len -= half;
    }
    return base;
  }

  // Sample reuse (as Mitsuba 3's DiscreteDistribution::sample_reuse): selects
  // a light by u and rescales u to [0,1) within the chosen interval, so one
  // 2D draw both picks the light and places the point on it. With one light
  // u is left as it is.
  LUZ_INLINE SampledLight sample(const LightSampleContext&, float& u) const {
    if (n == 1) return {0, pmfs[0]};
    uint32_t e = select(u);
    float lo = e > 0 ? cdf[e - 1] : 0.f, width = cdf[e] - lo;
    u = width > 0.f ? min(max((u - lo) / width, 0.f), kOneMinusEpsilon) : 0.f;
    return {e, pmfs[e]};
  }

  LUZ_INLINE float pmf(const LightSampleContext&, uint32_t light) const { return pmfs[light]; }
};

using LightSampler = PowerLightSampler;

}  // namespace luz
