// The CPU device: passes of the shared integrator on all cores (TBB), Embree
// for ray queries. render() (render/render.h) schedules the passes.
//
// A pass's work items are (tile of 16×16 pixels; splatting: 128 down to 16,
// film/splat.h) × (range of sample indices). On an image of many tiles an item takes all the pass's samples
// of its tile and adds them to each pixel's sums as it goes. On an image of
// few tiles a tile's samples are split into several items, so that every
// core is busy and the progress moves even on a 16×16 image: each item
// stores its samples' radiance in a buffer, and the last item of the tile to
// finish adds them to the sums in sample-index order. Either way every
// pixel's sums are built by adding its samples one by one in index order
// onto the film's previous sums, which is what makes the film independent of
// the thread count and of the pass schedule; partial sums added together
// would round differently for different splits. A splatting tile also
// computes the squares of a border around it, which its pixels' filters
// reach, so that no pixel's samples depend on another item.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>

#include "luz/film/film.h"
#include "luz/render/render.h"
#include "luz/scene/scene.h"

namespace luz {

struct PassHooks {
  std::function<bool()> stop;            // polled before each work item: true abandons the pass
  std::function<void(uint64_t)> done;    // after each work item, with its pixel-samples
};

struct PassResult {
  bool complete = false;
  uint64_t rays = 0;       // traced, complete or not
  uint64_t discarded = 0;  // non-finite samples left out (complete passes only)
};

class CpuDevice {
 public:
  // Builds the Embree scene. threads 0: all cores.
  CpuDevice(const Scene& scene, int threads);
  ~CpuDevice();
  CpuDevice(const CpuDevice&) = delete;
  CpuDevice& operator=(const CpuDevice&) = delete;

  int threads() const;

  // out = in + samples [first, end) of every pixel. `out` is overwritten
  // pixel by pixel (in and out are distinct films of the camera's size), so
  // an abandoned pass leaves `in` whole. stop() is polled before each work
  // item: when it answers true the remaining items are skipped and the
  // result is incomplete (out then holds some pixels' new sums, the rest stale).
  PassResult render_pass(const Film& in, Film& out, uint32_t first, uint32_t end, const PassHooks& hooks);
  // The same over the pixels of `rect` only: in and out are films of the
  // rect's size, image pixel (x, y) at (x - rect.x0, y - rect.y0). Its
  // pixels' sums are those render_pass gives them, bit for bit.
  PassResult render_pass(const Film& in, Film& out, const PixelRect& rect, uint32_t first, uint32_t end,
                         const PassHooks& hooks);

 private:
  struct Impl;
  std::unique_ptr<Impl> m_;
};

// The tests' and benchmarks' shorthand: the scene's whole range on the CPU
// (render() with a default request but for the threads).
struct CpuRenderOptions {
  int threads = 0;        // 0: all cores
  bool progress = false;  // progress bar on stderr
};

Film render_cpu(const Scene& scene, const CpuRenderOptions& options, RenderStats& stats);

}  // namespace luz
