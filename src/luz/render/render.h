// The render API under the command line: a RenderRequest (device, threads,
// sample range, progress, time limit, cancellation) in, a Film and its stats
// out. The CLI only turns flags into a request; checkpoints, the MPI driver
// and Python bindings call the same function.
//
// Samples are taken in passes: every pixel gets samples [s, s + n) of the
// range, then the next pass continues at s + n, n doubling as in pbrt-v4's
// ImageTileIntegrator::Render (next_pass_spp). The film after a pass holds exactly
// the samples [first_sample, s + n) of every pixel, added in sample-index
// order, so it is bitwise the same for any thread count and any split of the
// range into passes or into requests (a render of [0, k) continued by one of
// [k, n) equals a render of [0, n)). Host only.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>

#include "luz/film/film.h"
#include "luz/scene/scene.h"

namespace luz {

enum class RenderDevice { Cpu, Cuda };

struct RenderStats {
  double seconds = 0;  // of the passes (scene upload, Embree and BVH builds, the environment guide excluded)
  uint64_t samples = 0;    // pixel-samples in the film from this render (whole passes)
  uint64_t rays = 0;       // every ray traced, abandoned passes included
  uint64_t discarded = 0;  // non-finite samples among `samples`, left out of the film
  uint32_t passes = 0;     // whole passes done
  uint32_t spp = 0;        // samples per pixel added to the film: [first_sample, first_sample + spp)
};

// Where a render stands; handed to RenderRequest::progress.
struct RenderProgress {
  uint64_t samples_done = 0;   // pixel-samples rendered so far, the current pass's included
  uint64_t samples_total = 0;  // pixel-samples the request asks for
  uint32_t spp_done = 0;       // samples per pixel in the film (whole passes)
  uint32_t passes_done = 0;
  double seconds = 0;
};

struct RenderRequest {
  RenderDevice device = RenderDevice::Cpu;
  int threads = 0;      // CPU worker threads; 0: all cores
  int cuda_device = 0;  // CUDA device ordinal
  // Sample indices [first_sample, end_sample) of every pixel; no end_sample:
  // the scene's spp. The sampler is always built for the scene's spp, so a
  // sub-range takes the very samples a whole render would.
  uint32_t first_sample = 0;
  std::optional<uint32_t> end_sample;
  // The film to continue: it holds samples [0, first_sample) (a checkpoint,
  // or an earlier request's result); null: an empty film.
  const Film* start = nullptr;
  // Samples per pixel of every pass; 0: next_pass_spp's (the image is the
  // same either way: this only moves where a render can stop).
  uint32_t pass_spp = 0;
  // Seconds; 0: none. Passes are sized to end within it (from the rate of the
  // passes so far); a pass still running at the limit is abandoned.
  double time_limit = 0;
  // Polled between work items (at most tens of milliseconds apart on the
  // CPU, a pass apart on CUDA); when set, the render stops and returns its
  // whole passes. A signal handler may set it.
  const std::atomic<bool>* cancel = nullptr;
  // Called after each piece of work (a work item on the CPU, a pass on CUDA)
  // and after each pass, from whichever thread did it, never two calls at
  // once. Keep it short: the workers wait for it.
  std::function<void(const RenderProgress&)> progress;
  // Called after each whole pass on the thread that runs the render (the
  // workers wait): the film so far, samples [0, first_sample + stats.spp),
  // and this request's stats so far (rays and seconds excluded on CUDA).
  // Where checkpoints are written.
  std::function<void(const Film&, const RenderStats&)> pass_done;
};

struct RenderResult {
  Film film;  // samples [0, first_sample + stats.spp) of every pixel (with `start`'s), at least: Film::next
  RenderStats stats;
  bool complete = false;  // false: stopped by the time limit or cancellation
};

// Pixel-samples of a CPU pass, per thread, where passes stop doubling (and
// where they start, on a small image): about a quarter of a second of a
// core's work on the bundled box.
inline constexpr uint64_t kPassSamplesPerThread = uint64_t(1) << 18;
inline constexpr uint32_t kMaxDoublingSpp = 64;

// Samples per pixel of the CPU's next pass, after one of `previous` spp (0:
// the first), with `left` to go: doubling from the spp that fills
// kPassSamplesPerThread × threads (at least 1) up to the larger of that and
// kMaxDoublingSpp. Passes are long enough for their end not to idle the
// cores, short enough that a stop loses little, and no shorter than they must
// be: a pixel's seed cache (device/cpu) pays back over the samples of a pass.
// A pass that would leave less than itself takes the rest too.
uint32_t next_pass_spp(uint64_t pixels, int threads, uint32_t previous, uint32_t left);

// Throws std::invalid_argument for a request that contradicts the scene (a
// start film of another size, a reversed sample range), and
// CudaError from the CUDA device. A start film with per-pixel progress
// (Film::next: a checkpoint of an MPI render) continues by work units
// (render/units.h) on the CPU.
RenderResult render(const Scene& scene, const RenderRequest& request);

// The std::invalid_argument render() throws for a request, if any.
void check_request(const Scene& scene, const RenderRequest& request);

// When the request's time limit, counted from `start`, runs out (max: no limit).
std::chrono::steady_clock::time_point deadline_of(const RenderRequest& request,
                                                  std::chrono::steady_clock::time_point start);

// Pixels on a side of a work unit's block (render/units.h), where the image has enough of them.
inline constexpr int kUnitBlock = 16;

}  // namespace luz
