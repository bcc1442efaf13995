// Light selection for next-event estimation: sample(ctx, u) picks a light,
// pmf(ctx, light) is the probability it would have picked that one. Today in
// proportion to power (Light::phi) by inverting a CDF; the shading point
// does not enter it yet.
#pragma once

#include "luz/light/light.h"
#include "luz/sampling/distribution.h"

namespace luz {

struct SampledLight {
  uint32_t light = 0;
  float pmf = 0.f;
};

struct PowerLightSampler {
  // cdf: n + 1 entries from 0 to 1 (distribution.h); pmfs[k] = P(choose k).
  // n = 0: no light has power, nothing is sampled.
  const float* cdf = nullptr;
  const float* pmfs = nullptr;
  uint32_t n = 0;

  // Sample reuse (as Mitsuba 3's DiscreteDistribution::sample_reuse): selects
  // a light by u and rescales u to [0,1) within the chosen interval, so one
  // 2D draw both picks the light and places the point on it. With one light
  // u is left as it is.
  LUZ_INLINE SampledLight sample(const LightSampleContext&, float& u) const {
    if (n == 1) return {0, pmfs[0]};
    const uint32_t e = cdf_find(cdf, n, u);
    u = cdf_remap(cdf, e, u);
    return {e, pmfs[e]};
  }

  LUZ_INLINE float pmf(const LightSampleContext&, uint32_t light) const { return pmfs[light]; }
};

using LightSampler = PowerLightSampler;

}  // namespace luz
