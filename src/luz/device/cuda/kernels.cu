// The CUDA megakernel: T threads per pixel (pass.h) run render_pixel_pass
// (or, splatting, T per square render_square_pass, then gather_pixel_pass),
// i.e. the shared path tracer (integrator/path.h) over Luz's own BVH
// (accel/bvh.h, BvhTracer: Aila-Laine stack traversal; its intersect() is
// OptiX's closest-hit query, occluded() the any-hit shadow query). Everything
// else (memory, passes, the film) is host code in render_cuda.cpp.
#include "luz/device/cuda/launch.h"

namespace luz::cuda {

// The megakernels' bounds: 128 threads a block, and for all but the plain
// splatting kernel registers fitted to 5 blocks a multiprocessor: 96
// registers and more spills than the 128 ptxas picks alone, but 20 warps
// resident instead of 16, which hide more of the wait for instructions
// (bench/RESULTS.md, 2026-12-04: material spheres, Sponza, the staircase).
// The plain splatting kernel (the bundled box) ran faster with its 128.
// A minimum of 0 blocks emits none (an explicit 1 makes ptxas take 255).
#define LUZ_MEGAKERNEL_BOUNDS(min_blocks) __launch_bounds__(kBlockX * kBlockY, min_blocks)

// kFull: pass.h's two variants, chosen per scene by pass_is_plain.
template <bool kFull>
__global__ void LUZ_MEGAKERNEL_BOUNDS(5) render_pass_kernel(PassParams p, unsigned long long* rays) {
  const uint32_t x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  uint64_t n = 0;
  if (x < uint32_t(p.scene.camera.width) && y < uint32_t(p.scene.camera.height))
    n = render_pixel_pass<kFull>(p, x, y, blockIdx.z);  // blockIdx.z: the thread's share of the pixel's samples
  // One atomic per warp: every lane reaches the reduction (no early return).
  for (int offset = 16; offset > 0; offset /= 2) n += __shfl_down_sync(0xffffffffu, n, offset);
  if (((threadIdx.y * blockDim.x + threadIdx.x) & 31u) == 0 && n != 0) atomicAdd(rays, (unsigned long long)n);
}

cudaError_t launch_render_pass(const PassParams& params, unsigned long long* rays, cudaStream_t stream) {
  const dim3 block(kBlockX, kBlockY);
  const dim3 grid((unsigned(params.scene.camera.width) + kBlockX - 1) / kBlockX,
                  (unsigned(params.scene.camera.height) + kBlockY - 1) / kBlockY, params.threads_per_pixel);
  if (pass_is_plain(params)) render_pass_kernel<false><<<grid, block, 0, stream>>>(params, rays);
  else render_pass_kernel<true><<<grid, block, 0, stream>>>(params, rays);
  return cudaGetLastError();
}

// Splatting (pass.h): the squares of the bordered image, then every pixel's gather.
template <bool kFull>
__global__ void LUZ_MEGAKERNEL_BOUNDS(kFull ? 5 : 0) render_squares_kernel(PassParams p, unsigned long long* rays) {
  const uint32_t x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  const uint32_t cw = uint32_t(p.scene.camera.width + 2 * p.reach), ch = uint32_t(p.scene.camera.height + 2 * p.reach);
  uint64_t n = 0;
  if (x < cw && y < ch) n = render_square_pass<kFull>(p, x, y, blockIdx.z);
  for (int offset = 16; offset > 0; offset /= 2) n += __shfl_down_sync(0xffffffffu, n, offset);
  if (((threadIdx.y * blockDim.x + threadIdx.x) & 31u) == 0 && n != 0) atomicAdd(rays, (unsigned long long)n);
}

__global__ void gather_pixels_kernel(PassParams p) {
  const uint32_t x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x < uint32_t(p.scene.camera.width) && y < uint32_t(p.scene.camera.height)) gather_pixel_pass(p, x, y);
}

cudaError_t launch_splat_pass(const PassParams& params, unsigned long long* rays, cudaStream_t stream) {
  const dim3 block(kBlockX, kBlockY);
  const unsigned cw = unsigned(params.scene.camera.width + 2 * params.reach);
  const unsigned ch = unsigned(params.scene.camera.height + 2 * params.reach);
  const dim3 grid((cw + kBlockX - 1) / kBlockX, (ch + kBlockY - 1) / kBlockY, params.threads_per_pixel);
  if (pass_is_plain(params)) render_squares_kernel<false><<<grid, block, 0, stream>>>(params, rays);
  else render_squares_kernel<true><<<grid, block, 0, stream>>>(params, rays);
  const cudaError_t e = cudaGetLastError();
  if (e != cudaSuccess) return e;
  gather_pixels_kernel<<<dim3((unsigned(params.scene.camera.width) + kBlockX - 1) / kBlockX,
                              (unsigned(params.scene.camera.height) + kBlockY - 1) / kBlockY),
                         block, 0, stream>>>(params);
  return cudaGetLastError();
}

__global__ void bsdf_samples_kernel(BsdfBatchParams p) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < p.n) bsdf_sample_item(p, i);
}

template <bool kFull>
__global__ void trace_rays_kernel(RayBatchParams p) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < p.n) trace_ray_item<kFull>(p, i);
}

constexpr unsigned kBatchBlock = 128;

cudaError_t launch_bsdf_samples(const BsdfBatchParams& params, cudaStream_t stream) {
  if (params.n == 0) return cudaSuccess;
  bsdf_samples_kernel<<<(params.n + kBatchBlock - 1) / kBatchBlock, kBatchBlock, 0, stream>>>(params);
  return cudaGetLastError();
}

cudaError_t launch_trace_rays(const RayBatchParams& params, cudaStream_t stream) {
  if (params.n == 0) return cudaSuccess;
  const unsigned blocks = (params.n + kBatchBlock - 1) / kBatchBlock;
  if (params.tracer.plain()) trace_rays_kernel<false><<<blocks, kBatchBlock, 0, stream>>>(params);
  else trace_rays_kernel<true><<<blocks, kBatchBlock, 0, stream>>>(params);
  return cudaGetLastError();
}

// The wavefront pass (wavefront.h): one kernel per stage.
__global__ void wf_generate_kernel(WavefrontParams p) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < p.num_paths) wf_generate(p, i);
}

// Adds this warp's count to *total with one atomic (every lane takes part).
__device__ void warp_add(unsigned long long n, unsigned long long* total) {
  for (int offset = 16; offset > 0; offset /= 2) n += __shfl_down_sync(0xffffffffu, n, offset);
  if ((threadIdx.x & 31u) == 0 && n != 0) atomicAdd(total, n);
}

template <bool kFull>
__global__ void wf_intersect_kernel(WavefrontParams p, unsigned long long* rays) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  warp_add(i < p.num_paths ? wf_intersect<kFull>(p, i) : 0u, rays);
}

template <bool kFull>
__global__ void wf_shade_kernel(WavefrontParams p, unsigned long long* alive) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  warp_add((i < p.num_paths && wf_shade<kFull>(p, i)) ? 1u : 0u, alive);
}

template <bool kFull>
__global__ void wf_shadow_kernel(WavefrontParams p, unsigned long long* rays) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  warp_add(i < p.num_paths ? wf_shadow<kFull>(p, i) : 0u, rays);
}

// One bounce of every live path: intersect, shade, shadow.
template <bool kFull>
void launch_wavefront_bounce(const WavefrontParams& p, unsigned blocks, unsigned block, unsigned long long* rays,
                             unsigned long long* alive_dev, cudaStream_t stream) {
  wf_intersect_kernel<kFull><<<blocks, block, 0, stream>>>(p, rays);
  wf_shade_kernel<kFull><<<blocks, block, 0, stream>>>(p, alive_dev);
  wf_shadow_kernel<kFull><<<blocks, block, 0, stream>>>(p, rays);
}

__global__ void wf_accumulate_kernel(WavefrontParams p, uint32_t pixels) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < pixels) wf_accumulate(p, i);
}

cudaError_t launch_wavefront_pass(const WavefrontParams& p, unsigned long long* rays, unsigned long long* alive_dev,
                                  unsigned long long* alive_host, cudaStream_t stream) {
  constexpr unsigned kBlock = 128;
  const unsigned blocks = (p.num_paths + kBlock - 1) / kBlock;
  const uint32_t pixels = uint32_t(p.pass.scene.camera.width) * uint32_t(p.pass.scene.camera.height);
  if (p.num_paths == 0) return cudaSuccess;
  wf_generate_kernel<<<blocks, kBlock, 0, stream>>>(p);
  for (;;) {
    cudaError_t e = cudaMemsetAsync(alive_dev, 0, sizeof *alive_dev, stream);
    if (e != cudaSuccess) return e;
    if (pass_is_plain(p.pass)) launch_wavefront_bounce<false>(p, blocks, kBlock, rays, alive_dev, stream);
    else launch_wavefront_bounce<true>(p, blocks, kBlock, rays, alive_dev, stream);
    if ((e = cudaMemcpyAsync(alive_host, alive_dev, sizeof *alive_host, cudaMemcpyDeviceToHost, stream)) != cudaSuccess)
      return e;
    if ((e = cudaStreamSynchronize(stream)) != cudaSuccess) return e;
    if (*alive_host == 0) break;
  }
  wf_accumulate_kernel<<<(pixels + kBlock - 1) / kBlock, kBlock, 0, stream>>>(p, pixels);
  return cudaGetLastError();
}

cudaError_t render_pass_attributes(cudaFuncAttributes* attributes) {
  return cudaFuncGetAttributes(attributes, render_pass_kernel<true>);
}

}  // namespace luz::cuda
