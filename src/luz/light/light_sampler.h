// Light selection for next-event estimation: sample(ctx, u) picks a light,
// pmf(ctx, light) is the probability it would have picked that one. Two
// strategies, chosen by RenderSettings::light_sampler: in proportion to power
// (Light::phi) by an alias table, or by a light BVH (light_bvh.h) that also
// weighs each light's distance and orientation from the shading point. Both
// read ctx.p and ctx.ns only (ns zero: no surface). Both reuse u: it comes
// back rescaled to [0, 1) within the choice, to place the point on the light.
#pragma once

#include "luz/light/light_bvh.h"
#include "luz/sampling/distribution.h"

namespace luz {

enum class LightSamplerType : uint32_t { Power, Bvh };

struct PowerLightSampler {
  AliasTable table;  // over every light; pmf 0 for those without power

  LUZ_INLINE SampledLight sample(const LightSampleContext&, float& u) const {
    const AliasSample s = table.sample(u);
    u = s.u;
    return {s.index, s.pmf};
  }
  LUZ_INLINE float pmf(const LightSampleContext&, uint32_t light) const { return table.pmf(light); }
};

struct LightSampler {
  LightSamplerType type = LightSamplerType::Power;
  // The number of lights; 0: nothing to sample (no light, or none with
  // power). With one light, both strategies choose it with pmf 1 and leave
  // u as it is, without asking their tables.
  uint32_t n = 0;
  PowerLightSampler power;
  BvhLightSampler bvh;

  LUZ_INLINE SampledLight sample(const LightSampleContext& ctx, float& u) const {
    if (n == 1) return {0, 1.f};
    if (type != LightSamplerType::Bvh) return power.sample(ctx, u);
    // A copy for the out-of-line walk, made on this branch only: the caller's
    // context can then stay in registers (the power branch reads none of it).
    const LightSampleContext c = ctx;
    return bvh.sample(c, u);
  }
  LUZ_INLINE float pmf(const LightSampleContext& ctx, uint32_t light) const {
    if (n == 1) return 1.f;
    return type == LightSamplerType::Bvh ? bvh.pmf(ctx, light) : power.pmf(ctx, light);
  }
  // pmf(ctx, light) of an infinite light (an environment, a directional
  // light), from the sum of what sample(ctx) returned at the same context.
  LUZ_INLINE float pmf_infinite(uint32_t light, float sum) const {
    if (n == 1) return 1.f;
    return type == LightSamplerType::Bvh ? bvh.pmf_infinite(light, sum) : power.pmf({}, light);
  }
};

}  // namespace luz
