// Rendering on an NVIDIA GPU through CUDA: the shared integrator (path.h) over
// Luz's own BVH (accel/bvh.h), one megakernel thread per pixel, one launch per
// pass of a few samples. Host-only header, no CUDA types: it is included by
// the CLI and the tests whether or not the build has CUDA (without it,
// render_cuda_stub.cpp answers "built without CUDA").
//
// The image is the CPU's, sample for sample: pixel (x, y) takes sample s with
// the same Sampler::start / set_sample / filter-first order as render_cpu, so
// the random numbers are identical and the two films differ only by float
// rounding (FMA contraction, device sqrt/pow/exp) and by the rare path whose
// branch that rounding flips.
#pragma once

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "luz/film/film.h"
#include "luz/render/render.h"  // RenderStats
#include "luz/scene/scene.h"

namespace luz {

// Every CUDA failure, as one line (no line breaks). kind says what the CLI
// makes of it: Unavailable (no driver, driver too old, no GPU, no kernel image
// for this GPU, or a build without CUDA) is the user's setup, exit status 2;
// OutOfMemory and Failure (a failed launch, an illegal address...) exit 1.
class CudaError : public std::runtime_error {
 public:
  enum class Kind { Unavailable, OutOfMemory, Failure };
  CudaError(Kind kind, const std::string& message);
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

struct CudaRenderOptions {
  int device = 0;                 // CUDA device ordinal
  bool progress = false;          // progress bar on stderr
  uint32_t samples_per_pass = 0;  // samples per pixel per launch; 0: chosen from the image size
  uint32_t threads_per_pixel = 0;  // threads sharing a pixel's pass; 0: chosen from the image size
  bool wavefront = false;          // the wavefront variant (wavefront.h) instead of the megakernel
  // Sample indices [first_sample, end_sample) of every pixel (end 0: the
  // scene's spp), added onto `start`'s sums when given (else an empty film).
  uint32_t first_sample = 0, end_sample = 0;
  const Film* start = nullptr;
  // Polled before each pass is launched: true ends the render after the
  // passes already launched (whole passes only).
  std::function<bool()> stop;
  // After each pass joins the film: the film and the stats so far (samples,
  // spp, passes, discarded; rays and seconds only at the end).
  std::function<void(const Film&, const RenderStats&)> pass_done;
};

// Whether render_cuda can run: a driver new enough for this build's runtime,
// a GPU, and kernels compiled for its architecture. When not, *why (if not
// null) gets the reason as one line, e.g. "no NVIDIA driver found (libcuda.so
// is not installed)" or "built without CUDA".
bool cuda_available(std::string* why);

// "NVIDIA H100 80GB HBM3 (sm_90, 79.1 GiB)", or "" when cuda_available() is false.
std::string cuda_device_name();

// Renders samples [first_sample, end_sample) of every pixel (by default the
// scene's spp). Film sums are double, reduced on the host from each pass's
// float sums (per pixel: sums, sums of squares, finite-sample count). stats
// as render()'s: seconds of the sample loop (BVH build and uploads excluded,
// like the CPU's Embree build), samples, rays (camera + bounce + shadow),
// non-finite samples discarded, passes and spp done.
// Throws CudaError.
Film render_cuda(const Scene& scene, const CudaRenderOptions& options, RenderStats& stats);

// bsdf.sample() for items 0..n-1 on the GPU (device/cuda/batch.h,
// bsdf_sample_item: random numbers a function of (seed, i)). Fills wi and ok
// (valid and not delta) with n entries each. Throws CudaError.
void sample_bsdf_cuda(const Bsdf& bsdf, Vec3 wo, uint64_t seed, uint32_t n, std::vector<Vec3>& wi,
                      std::vector<uint8_t>& ok);

// Traces `rays` on the GPU through Luz's BVH of `scene` (shadow[i] != 0: an
// occlusion query, else closest hit), in `repeat` timed rounds of enough
// back-to-back launches to trace ≥ 2^23 rays. Returns the best round's time
// per launch over all rays (seconds, by CUDA events: upload and build
// excluded) and, in *hits, how many rays hit / were occluded. Throws CudaError.
double trace_rays_cuda(const Scene& scene, const std::vector<Ray>& rays, const std::vector<uint8_t>& shadow,
                       int repeat, uint64_t* hits);

}  // namespace luz
