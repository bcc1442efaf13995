// The seam between kernels.cu (compiled by nvcc) and render_cuda.cpp (the host
// side, compiled by the C++ compiler against the CUDA runtime API). Internal
// to the CUDA backend.
#pragma once

#include <cuda_runtime_api.h>

#include "luz/device/cuda/batch.h"
#include "luz/device/cuda/pass.h"
#include "luz/device/cuda/wavefront.h"

namespace luz::cuda {

inline constexpr int kBlockX = 16, kBlockY = 8;  // 128 threads, four warps, per block

// Enqueues one pass on `stream`; `rays` (device) gains the pass's ray count.
cudaError_t launch_render_pass(const PassParams& params, unsigned long long* rays, cudaStream_t stream);

// Splatting's pass (pass.h): the squares' kernel, then the gather's, on `stream`.
cudaError_t launch_splat_pass(const PassParams& params, unsigned long long* rays, cudaStream_t stream);

// Attributes of the pass kernel; fails with cudaErrorNoKernelImageForDevice
// (or cudaErrorInvalidDeviceFunction) when this build has no code for the
// current device's architecture.
cudaError_t render_pass_attributes(cudaFuncAttributes* attributes);

// The wavefront variant of one pass (wavefront.h), its stages enqueued on
// `stream` until no path is alive (each round reads the live count back into
// the pinned *alive_host: the call returns with the pass enqueued up to its
// accumulate kernel). `rays` gains the pass's ray count.
cudaError_t launch_wavefront_pass(const WavefrontParams& params, unsigned long long* rays,
                                  unsigned long long* alive_dev, unsigned long long* alive_host, cudaStream_t stream);

// The batch queries of batch.h, one item per thread, enqueued on `stream`.
cudaError_t launch_bsdf_samples(const BsdfBatchParams& params, cudaStream_t stream);
cudaError_t launch_trace_rays(const RayBatchParams& params, cudaStream_t stream);

}  // namespace luz::cuda
