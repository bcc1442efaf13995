// Light selection by a light BVH (Conty Estevez and Kulla 2018, as pbrt-v4's
// BVHLightSampler): the finite lights with power in a binary tree of
// LightBounds, walked from the root choosing each child in proportion to
// its importance at the shading point, so nearby lights facing the point are
// chosen more often than the power alone would choose them. The infinite
// lights (environments, directional) with power are chosen apart, uniformly,
// each as likely as the whole tree (pbrt's pInfinite).
//
// Nodes are stored depth first: a node's first child follows it, the second
// is at `child`. pmf(ctx, light) walks the light's path again from its bit
// trail (bit k: the child taken at depth k, 1 = second), computing the same
// products in the same order as sample(), so both give the same float.
#pragma once

#include <vector>

#include "luz/light/light.h"

namespace luz {

struct LightBvhNode {
  LightBounds bounds;
  uint32_t child = 0;  // inner node: the second child's index; leaf: the light's index
  uint32_t leaf = 0;
};

struct SampledLight {
  uint32_t light = 0;
  float pmf = 0.f;  // 0: no light chosen (none emits toward the point)
};

// Bit trails: depth at most kLightTrailDepth; the top bits mark the lights
// outside the tree.
inline constexpr uint64_t kTrailInfinite = uint64_t(1) << 63;  // an infinite light with power
inline constexpr uint64_t kTrailNone = uint64_t(1) << 62;      // no power: never chosen
inline constexpr int kLightTrailDepth = 62;

struct BvhLightSampler {
  const LightBvhNode* nodes = nullptr;  // empty: no finite light with power
  uint32_t num_nodes = 0;
  const uint64_t* trails = nullptr;    // per light
  const uint32_t* infinite = nullptr;  // the infinite lights with power
  uint32_t num_infinite = 0;
  float p_infinite = 0.f;  // num_infinite / (num_infinite + (tree ? 1 : 0))

  // The probability of the first child at an inner node; 1 - it for the
  // second. Negative: neither child emits toward p.
  LUZ_INLINE float first_child_p(uint32_t k, Vec3 p, Vec3 n) const {
    const float a = nodes[k + 1].bounds.importance(p, n), b = nodes[nodes[k].child].bounds.importance(p, n);
    return a + b > 0.f ? a / (a + b) : -1.f;
  }

  // Sample reuse: u is rescaled to [0, 1) within each choice.
  LUZ_INLINE SampledLight sample(const LightSampleContext& ctx, float& u) const {
    if (u < p_infinite) {
      const float x = u / p_infinite * float(num_infinite);
      const uint32_t i = min(uint32_t(x), num_infinite - 1);
      u = min(x - float(i), kOneMinusEpsilon);
      return {infinite[i], p_infinite / float(num_infinite)};
    }
    if (num_nodes == 0) return {};
    u = min((u - p_infinite) / (1.f - p_infinite), kOneMinusEpsilon);
    float pmf = 1.f - p_infinite;
    uint32_t k = 0;
    while (!nodes[k].leaf) {
      const float p0 = first_child_p(k, ctx.p, ctx.ns);
      if (p0 < 0.f) return {};
      if (u < p0) {
        u = min(u / p0, kOneMinusEpsilon);
        pmf *= p0;
        k = k + 1;
      } else {
        u = min((u - p0) / (1.f - p0), kOneMinusEpsilon);
        pmf *= 1.f - p0;
        k = nodes[k].child;
      }
    }
    // A tree of one light: the root's own importance decides.
    if (k == 0 && !(nodes[0].bounds.importance(ctx.p, ctx.ns) > 0.f)) return {};
    return {nodes[k].child, pmf};
  }

  LUZ_INLINE float pmf(const LightSampleContext& ctx, uint32_t light) const {
    uint64_t t = trails[light];
    if (t & kTrailInfinite) return p_infinite / float(num_infinite);
    if (t & kTrailNone) return 0.f;
    float pmf = 1.f - p_infinite;
    uint32_t k = 0;
    while (!nodes[k].leaf) {
      const float p0 = first_child_p(k, ctx.p, ctx.ns);
      if (p0 < 0.f) return 0.f;
      const bool second = t & 1u;
      pmf *= second ? 1.f - p0 : p0;
      k = second ? nodes[k].child : k + 1;
      t >>= 1;
    }
    if (k == 0 && !(nodes[0].bounds.importance(ctx.p, ctx.ns) > 0.f)) return 0.f;
    return pmf;
  }
};

// What the host builds and the sampler points into.
struct LightBvhData {
  std::vector<LightBvhNode> nodes;
  std::vector<uint64_t> trails;
  std::vector<uint32_t> infinite;
  float p_infinite = 0.f;

  BvhLightSampler view() const {
    BvhLightSampler s;
    s.nodes = nodes.empty() ? nullptr : nodes.data();
    s.num_nodes = uint32_t(nodes.size());
    s.trails = trails.data();
    s.infinite = infinite.data();
    s.num_infinite = uint32_t(infinite.size());
    s.p_infinite = p_infinite;
    return s;
  }
};

// Builds the tree over `lights` (power[k]: Light k's phi; zero: left out),
// by pbrt-v4's SAH with orientation (the surface-area-orientation heuristic
// of Conty Estevez and Kulla §4.4), 12 buckets per axis, one light per leaf.
LightBvhData build_light_bvh(const Light* lights, const double* power, uint32_t n);

}  // namespace luz
