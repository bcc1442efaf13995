// Batch queries for the GPU, written once for the device and the host: one
// item per thread in kernels.cu, and the same functions looped over host
// arrays in tests/test_cuda.cpp, so the item logic is tested on machines
// without a GPU.
//
//   - bsdf_sample_item: Bsdf::sample for item i with random numbers that are a
//     pure function of (seed, i), the GPU's half of the χ² test of BSDF
//     sampling (the host bins the directions against pdf()).
//   - trace_ray_item: one recorded ray through Luz's BVH, closest hit or
//     occlusion (the GPU ray-throughput benchmark).
#pragma once

#include "luz/accel/bvh.h"
#include "luz/bsdf/bsdf.h"
#include "luz/math/hash.h"

namespace luz {

// Uniform [0, 1) number `dim` of item i: the formula of the tests' χ²
// harness (chi2::rand01), so host and device items draw the same numbers.
LUZ_INLINE float batch_uniform(uint64_t seed, uint64_t i, uint32_t dim) {
  return to_unit_float(hash_combine(hash_combine(mix64(seed), i), dim));
}

struct BsdfBatchParams {
  const Bsdf* bsdf = nullptr;  // one BSDF (device memory on the device)
  Vec3 wo;                     // local frame, +z the shading normal
  uint64_t seed = 0;
  uint32_t n = 0;
  Vec3* wi = nullptr;       // n sampled directions
  uint8_t* ok = nullptr;    // n flags: a valid, non-delta sample
};

// sample(wo, u1, (u2, u3)) with u_k = batch_uniform(seed, i, k), k = 0, 2, 3
// (chi2::rand01(seed, i, 0) and chi2::rand2(seed, i, 1)).
LUZ_INLINE void bsdf_sample_item(const BsdfBatchParams& p, uint32_t i) {
  BsdfSample s = p.bsdf->sample(p.wo, batch_uniform(p.seed, i, 0),
                                Vec2{batch_uniform(p.seed, i, 2), batch_uniform(p.seed, i, 3)});
  p.wi[i] = s.wi;
  p.ok[i] = (s.valid && !s.delta) ? 1 : 0;
}

struct RayBatchParams {
  BvhTracer tracer;
  const Ray* rays = nullptr;
  const uint8_t* shadow = nullptr;  // 1: occlusion query, 0: closest hit
  uint32_t n = 0;
  uint8_t* hit = nullptr;  // 1: the ray hit something (closest) / is occluded
};

// kFull false: a plain() tracer's (BvhQueries).
template <bool kFull = true>
LUZ_INLINE void trace_ray_item(const RayBatchParams& p, uint32_t i) {
  Hit h;
  const BvhQueries<kFull> t{p.tracer};
  p.hit[i] = (p.shadow[i] ? t.occluded(p.rays[i]) : t.intersect(p.rays[i], h)) ? 1 : 0;
}

}  // namespace luz
