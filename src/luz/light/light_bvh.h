// Light selection by a light BVH (Conty Estevez and Kulla 2018, as pbrt-v4's
// BVHLightSampler): the finite lights with power in a tree of light bounds,
// walked from the root choosing each child in proportion to its importance
// at the shading point (pbrt-v4's LightBounds::Importance), so nearby lights
// facing the point are chosen more often than the power alone would choose
// them. The infinite lights (environments, directional) with power stand
// beside the tree's root, each weighed by the irradiance it gives an
// unoccluded surface (Light::irradiance_estimate), the tree by the sum of its
// root's importances at the point, which estimate irradiance too (as
// Cycles' light tree weighs its distant lights against the local ones;
// pbrt-v4 gives the infinite lights a fixed share, which spends half the
// samples of a dim sky over a bright lamp on the sky).
//
// The tree is 8 wide (a binary SAH tree collapsed three levels at a time, as
// Embree's BVH8): a node holds its children's bounds as arrays of 8, so one
// pass of SIMD lanes (AVX2 on the CPU) weighs all of them, and about a third
// of the binary tree's levels are walked; a child is a node or a light (the
// leaves: a node may hold up to 8 lights). Nodes are stored depth first.
// pmf(ctx, light) walks the light's path again from its trail (3 bits per
// level: the child slot taken), computing the same products in the same
// order as sample(), so both give the same float.
#pragma once

#include <algorithm>
#include <cfloat>
#include <vector>

#include "luz/light/light.h"

namespace luz {

inline constexpr int kLightBvhWidth = 8;
inline constexpr int kLightBvhSlotBits = 3;
inline constexpr uint32_t kLightBvhLeaf = 1u << 31;      // child: a light's index, not a node's
inline constexpr uint32_t kLightBvhTwoSided = 1u << 30;  // child: its lights emit on both sides
inline constexpr uint32_t kLightBvhIndex = kLightBvhTwoSided - 1;

// 8 children's bounds (LightBounds, as centre and bounding-sphere radius),
// one array per field for the SIMD lanes. An empty slot has phi 0.
struct alignas(32) LightBvhNode {
  float cx[kLightBvhWidth], cy[kLightBvhWidth], cz[kLightBvhWidth];  // the box's centre
  float radius[kLightBvhWidth];                                      // half its diagonal
  float wx[kLightBvhWidth], wy[kLightBvhWidth], wz[kLightBvhWidth];  // the normals' cone axis
  float phi[kLightBvhWidth];
  float cos_o[kLightBvhWidth], sin_o[kLightBvhWidth], cos_e[kLightBvhWidth];
  uint32_t child[kLightBvhWidth];  // node index, or light index | kLightBvhLeaf; | kLightBvhTwoSided
};
static_assert(sizeof(LightBvhNode) == 6 * 64, "LightBvhNode: 12 arrays of 8, six cache lines");

struct SampledLight {
  uint32_t light = 0;
  float pmf = 0.f;  // 0: no light chosen (none emits toward the point)
  // The light BVH's: the sum of the weights it chose among at the point
  // (the infinite lights' and the tree's), from which pmf_infinite gives an
  // infinite light's pmf there without computing them again.
  float sum = 0.f;
};

// Trails: at most kLightTrailLevels levels of kLightBvhSlotBits; the top bits
// mark the lights outside the tree.
inline constexpr uint64_t kTrailInfinite = uint64_t(1) << 63;  // an infinite light with power | its index among them
inline constexpr uint64_t kTrailNone = uint64_t(1) << 62;      // no power: never chosen
inline constexpr int kLightTrailLevels = 20;

// The importance of light bounds at a shading point, written once over a
// lane type F: a float (CUDA, and compilers without GCC's vector extensions)
// or, on the CPU, 8 floats (M: the mask type of F's comparisons). Branch-free:
// every operand is computed before the selects that pick among them.
namespace light_lanes {

#if !defined(__CUDACC__) && defined(__GNUC__)  // GCC and clang
#define LUZ_LIGHT_LANES_SIMD 1
typedef float LaneF __attribute__((vector_size(4 * kLightBvhWidth)));
typedef uint32_t LaneU __attribute__((vector_size(4 * kLightBvhWidth)));

inline LaneF load(const float* a) {
  LaneF v;
  __builtin_memcpy(&v, a, sizeof v);
  return v;
}
inline LaneU load(const uint32_t* a) {
  LaneU v;
  __builtin_memcpy(&v, a, sizeof v);
  return v;
}
inline LaneF lane_sqrt(LaneF x) {
#ifdef __AVX__
  return __builtin_ia32_sqrtps256(x);
#else
  LaneF r;
  for (int i = 0; i < kLightBvhWidth; ++i) r[i] = __builtin_sqrtf(x[i]);
  return r;
#endif
}
#else
#define LUZ_LIGHT_LANES_SIMD 0
#endif
LUZ_FORCE_INLINE float lane_sqrt(float x) { return sqrtf(x); }

template <class F, class M>
LUZ_FORCE_INLINE F select(M m, F a, F b) {
  return m ? a : b;
}
template <class F>
LUZ_FORCE_INLINE F lane_min(F a, F b) {
  return select(a < b, a, b);
}
template <class F>
LUZ_FORCE_INLINE F lane_max(F a, F b) {
  return select(a > b, a, b);
}

// The sine of the angle between d and a unit vector a, from d², d·a and
// 1/|d|: √(d² - (d·a)²) / |d|, whose root starts beside |d|'s instead of
// after the division (the walk waits on this chain). 0 where d is 0. With
// r for d·a: cos θb, the bounding sphere's half-angle.
template <class F>
LUZ_FORCE_INLINE F sine(F d2, F da, F inv_d) {
  return lane_sqrt(lane_max(d2 - da * da, d2 - d2)) * inv_d;
}

// cx..cz: the box's centre; r: its bounding sphere's radius; w, cos_o,
// sin_o: the normals' cone; two_sided: a mask; p, n, h: the context's point, shading normal and
// hemisphere (zero: none); no_n: 2 where n is zero, else 0.
template <class F, class M>
LUZ_FORCE_INLINE F importance(F cx, F cy, F cz, F r, F wx, F wy, F wz, F phi, F cos_o, F sin_o, F cos_e, M two_sided,
                              Vec3 p, Vec3 n, Vec3 h, float no_n) {
  const F zero = cx - cx, one = zero + 1.f;
  const F dx = p.x - cx, dy = p.y - cy, dz = p.z - cz;  // from the lights toward p
  const F dc2 = dx * dx + dy * dy + dz * dz;
  // pbrt's clamp of the distance, so points inside the box are not
  // infinitely important: max(d², |diagonal| / 2).
  const F d2 = lane_max(dc2, r);
  const F inv_d2 = 1.f / (d2 + FLT_MIN);  // beside the chain below, which then ends in a product
  // (at the centre d = 0, so the cosines below are 0 as with no direction)
  const F inv_d = 1.f / lane_sqrt(dc2 + FLT_MIN);
  const F dw = wx * dx + wy * dy + wz * dz, dn = dx * n.x + dy * n.y + dz * n.z;
  const F cos_w0 = lane_min(lane_max(dw * inv_d, zero - 1.f), one);
  const F cos_w = select(two_sided, select(cos_w0 < 0.f, -cos_w0, cos_w0), cos_w0);
  const F sin_w = sine(dc2, dw, inv_d);
  // The cone the bounding sphere subtends from p (every direction from inside).
  const auto inside = dc2 < r * r;
  const F sin_b0 = lane_min(r * inv_d, one), cos_b0 = sine(dc2, r, inv_d);
  const F sin_b = select(inside, zero, sin_b0), cos_b = select(inside, zero - 1.f, cos_b0);
  // θ' = max(0, θw - θo - θb), by cosines of clamped differences.
  const auto in_o = cos_w > cos_o;
  const F cos_x = select(in_o, one, cos_w * cos_o + sin_w * sin_o);
  const F sin_x = select(in_o, zero, sin_w * cos_o - cos_w * sin_o);
  const F cos_p = select(cos_x > cos_b, one, cos_x * cos_b + sin_x * sin_b);
  // θi: the lights' direction against the surface normal, less θb.
  const F cos_i = lane_min(select(dn < 0.f, -dn, dn) * inv_d, one);
  const F sin_i = sine(dc2, dn, inv_d);
  const F f_i = select(cos_i + no_n > cos_b, one, cos_i * cos_b + sin_i * sin_b);
  const F v = phi * cos_p * f_i * inv_d2;
  // Below the tangent plane by more than the radius (and a rounding margin);
  // never without a hemisphere (h zero: 0 > margin is false).
  const F margin = 1.0001f * r + 1e-4f * dc2 * inv_d;
  const auto above = dx * h.x + dy * h.y + dz * h.z <= margin;
  const auto lit = (phi > 0.f) & (d2 > 0.f) & (cos_p > cos_e) & above & (v > 0.f);
  return select(lit, v, zero);
}

}  // namespace light_lanes

struct BvhLightSampler {
  const LightBvhNode* nodes = nullptr;  // empty: no finite light with power
  uint32_t num_nodes = 0;
  const uint64_t* trails = nullptr;        // per light
  const uint32_t* infinite = nullptr;      // the infinite lights with power
  const float* infinite_weight = nullptr;  // each one's irradiance estimate (> 0)
  uint32_t num_infinite = 0;
  float infinite_total = 0.f;  // their sum
  // The tree's light where it holds only one (else -1): chosen without the
  // walk. With no infinite light beside it, with pmf 1 and without its
  // importance (as the walk gives wherever that importance is positive;
  // where it is 0 the light's sample brings nothing either way and no BSDF
  // sample finds its emission, so the estimate is unchanged); beside them,
  // with the tree's share, which its importance sets.
  int32_t only = -1;

  // The importance of each of a node's children at the context's point:
  // pbrt-v4's LightBounds::Importance term by term (light_lanes::importance),
  // and 0 for a child whose bounding sphere lies wholly below the surface's
  // tangent plane (ctx.hemisphere: no light from there reaches a reflecting
  // surface). On the CPU all 8 children at once, in one AVX register;
  // elsewhere (CUDA) importances_by_lane.
  LUZ_FORCE_INLINE static void importances(const LightBvhNode& nd, const LightSampleContext& ctx,
                                           float imp[kLightBvhWidth]) {
#if LUZ_LIGHT_LANES_SIMD
    using namespace light_lanes;
    const LaneF v = importance(load(nd.cx), load(nd.cy), load(nd.cz), load(nd.radius), load(nd.wx), load(nd.wy),
                               load(nd.wz), load(nd.phi), load(nd.cos_o), load(nd.sin_o), load(nd.cos_e),
                               (load(nd.child) & kLightBvhTwoSided) != 0u, ctx.p, ctx.ns, ctx.hemisphere,
                               missing_normal(ctx));
    __builtin_memcpy(imp, &v, sizeof v);
#else
    importances_by_lane(nd, ctx, imp);
#endif
  }

  // The same, one child at a time, the empty slots skipped (their importance
  // is 0 either way), in a loop kept rolled and out of line in CUDA, so that
  // sample() and pmf()'s three call sites share one copy of one lane: the 8
  // lanes unrolled at each doubled the megakernel's hot code, which then
  // waited on instruction fetches most of its time.
  LUZ_DEVICE_NOINLINE static void importances_by_lane(const LightBvhNode& nd, const LightSampleContext& ctx,
                                                      float imp[kLightBvhWidth]) {
    const float no_n = missing_normal(ctx);
#if defined(__CUDACC__)
#pragma unroll 1
#endif
    for (int i = 0; i < kLightBvhWidth; ++i)
      imp[i] = nd.phi[i] > 0.f ? light_lanes::importance(nd.cx[i], nd.cy[i], nd.cz[i], nd.radius[i], nd.wx[i], nd.wy[i],
                                                         nd.wz[i], nd.phi[i], nd.cos_o[i], nd.sin_o[i], nd.cos_e[i],
                                                         (nd.child[i] & kLightBvhTwoSided) != 0u, ctx.p, ctx.ns,
                                                         ctx.hemisphere, no_n)
                               : 0.f;
  }

  // Without a normal, the normal's factor is 1: its cosine is raised above
  // every cos θb (importance's no_n).
  LUZ_FORCE_INLINE static float missing_normal(const LightSampleContext& ctx) {
    const Vec3 n = ctx.ns;
    return n.x != 0.f || n.y != 0.f || n.z != 0.f ? 0.f : 2.f;
  }

  // The root's importances and their sum, the tree's weight against the
  // infinite lights' (0 without a tree).
  LUZ_FORCE_INLINE float root_importances(const LightSampleContext& ctx, float imp[kLightBvhWidth]) const {
    if (num_nodes == 0) return 0.f;
    importances(nodes[0], ctx, imp);
    float total = 0.f;
    for (int i = 0; i < kLightBvhWidth; ++i) total += imp[i];
    return total;
  }

  // Sample reuse: u is rescaled to [0, 1) within each choice. The result's
  // sum: as the pmfs' denominator, also where no light is chosen.
  LUZ_INLINE SampledLight sample(const LightSampleContext& ctx, float& u) const {
    if (only >= 0 && num_infinite == 0) return {uint32_t(only), 1.f};
    float imp[kLightBvhWidth], c[kLightBvhWidth];  // c: where each child's stretch of [0, total) starts
    const float tree = root_importances(ctx, imp), all = infinite_total + tree;
    if (!(all > 0.f)) return {};
    if (num_infinite > 0) {  // (without, u stays as it is)
      const float t_all = u * all;
      if (t_all < infinite_total || !(tree > 0.f)) {
        uint32_t i = 0;
        float start = 0.f;
        while (i + 1 < num_infinite && start + infinite_weight[i] <= t_all) start += infinite_weight[i++];
        u = min((t_all - start) / infinite_weight[i], kOneMinusEpsilon);
        return {infinite[i], infinite_weight[i] / all, all};
      }
      u = min((t_all - infinite_total) / tree, kOneMinusEpsilon);
    }
    float pmf = tree / all;
    if (only >= 0) return {uint32_t(only), pmf, all};  // the walk's one child: total = its importance
    uint32_t k = 0;
    for (int level = 0; level < kLightTrailLevels; ++level) {
      if (level > 0) importances(nodes[k], ctx, imp);
      float total = 0.f;
      for (int i = 0; i < kLightBvhWidth; ++i) c[i] = total, total += imp[i];
      if (!(total > 0.f)) return {0, 0.f, all};
      // The child whose stretch holds u·total: the last with importance
      // starting at or below it (the first with importance, if rounding puts
      // u·total below every start). Each lane's test stands alone, so the
      // compiler selects (a branch per lane would be a coin toss).
      const float t = u * total;
      int j = -1, first = -1;
      for (int i = 0; i < kLightBvhWidth; ++i) {
        j = ((imp[i] > 0.f) & (c[i] <= t)) ? i : j;
        first = imp[kLightBvhWidth - 1 - i] > 0.f ? kLightBvhWidth - 1 - i : first;
      }
      j = j >= 0 ? j : first;
      const float start = c[j], chosen = imp[j];
      pmf *= chosen / total;
      u = min((t - start) / chosen, kOneMinusEpsilon);
      const uint32_t child = nodes[k].child[j];
      if (child & kLightBvhLeaf) return {child & kLightBvhIndex, pmf, all};
      k = child & kLightBvhIndex;
    }
    return {0, 0.f, all};
  }

  // pmf(ctx, light) of an infinite light, from the sum sample(ctx) gave
  // (pmf() computes that sum, then this).
  LUZ_INLINE float pmf_infinite(uint32_t light, float sum) const {
    const uint64_t t = trails[light];
    if (t & kTrailNone) return 0.f;
    if (!(sum > 0.f)) return 0.f;
    return infinite_weight[uint32_t(t)] / sum;
  }

  LUZ_INLINE float pmf(const LightSampleContext& ctx, uint32_t light) const {
    uint64_t t = trails[light];
    if (t & kTrailNone) return 0.f;
    if (only >= 0 && num_infinite == 0) return 1.f;
    float imp[kLightBvhWidth];
    const float tree = root_importances(ctx, imp), all = infinite_total + tree;
    if (!(all > 0.f)) return 0.f;
    if (t & kTrailInfinite) return pmf_infinite(light, all);
    float pmf = tree / all;
    if (only >= 0) return pmf;
    uint32_t k = 0;
    for (int level = 0; level < kLightTrailLevels; ++level) {
      if (level > 0) importances(nodes[k], ctx, imp);
      float total = 0.f;
      for (int i = 0; i < kLightBvhWidth; ++i) total += imp[i];
      const uint32_t slot = uint32_t(t) & (kLightBvhWidth - 1);
      float chosen = 0.f;
      for (int i = 0; i < kLightBvhWidth; ++i) chosen = uint32_t(i) == slot ? imp[i] : chosen;
      if (!(chosen > 0.f)) return 0.f;
      pmf *= chosen / total;
      const uint32_t child = nodes[k].child[slot];
      if (child & kLightBvhLeaf) return pmf;
      k = child & kLightBvhIndex;
      t >>= kLightBvhSlotBits;
    }
    return 0.f;
  }
};

// What the host builds and the sampler points into.
struct LightBvhData {
  std::vector<LightBvhNode> nodes;
  std::vector<uint64_t> trails;
  std::vector<uint32_t> infinite;
  std::vector<float> infinite_weight;
  float infinite_total = 0.f;

  BvhLightSampler view() const {
    BvhLightSampler s;
    s.nodes = nodes.empty() ? nullptr : nodes.data();
    s.num_nodes = uint32_t(nodes.size());
    s.trails = trails.data();
    s.infinite = infinite.data();
    s.infinite_weight = infinite_weight.data();
    s.num_infinite = uint32_t(infinite.size());
    s.infinite_total = infinite_total;
    // One light in the tree: a lone root whose one child with power is it.
    const auto powered = [](float phi) { return phi > 0.f; };
    if (nodes.size() == 1 && std::count_if(nodes[0].phi, nodes[0].phi + kLightBvhWidth, powered) == 1) {
      const int i = int(std::find_if(nodes[0].phi, nodes[0].phi + kLightBvhWidth, powered) - nodes[0].phi);
      s.only = int32_t(nodes[0].child[i] & kLightBvhIndex);
    }
    return s;
  }
};

// Builds the tree over `lights` (power[k]: Light k's phi; zero: left out):
// a binary tree by pbrt-v4's SAH with orientation (the
// surface-area-orientation heuristic of Conty Estevez and Kulla §4.4), 12
// buckets per axis, one light per leaf, then collapsed to 8 wide.
LightBvhData build_light_bvh(const Light* lights, const double* power, uint32_t n);

}  // namespace luz
