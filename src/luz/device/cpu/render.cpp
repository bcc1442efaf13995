#include "luz/device/cpu/render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>

#include "luz/accel/embree_tracer.h"
#include "luz/device/progress.h"
#include "luz/integrator/path.h"

namespace luz {

namespace {

constexpr int kTile = 16;
// The Sobol seeds of a pixel's first dimensions (at most the camera's and 8
// vertices') are computed once per pixel: two hashes per dimension (~60
// instructions), against ~25 saved per draw. A pixel of n samples caches n/2
// dimensions, so that even a dimension only some paths reach pays back.
constexpr uint32_t kSeedCacheDims = kCameraDims + 8 * kDimsPerVertex;

}  // namespace

Film render_cpu(const Scene& scene, const CpuRenderOptions& options, RenderStats& stats) {
  const SceneView view = scene.view();
  const Camera& cam = view.camera;
  Film film(cam.width, cam.height);
  EmbreeScene embree(scene);
  const EmbreeTracer tracer = embree.tracer();
  const RenderSettings& rs = scene.settings;
  const SamplerDesc desc = make_sampler_desc(rs.sampler, rs.spp, rs.seed);

  const int tiles_x = (cam.width + kTile - 1) / kTile, tiles_y = (cam.height + kTile - 1) / kTile;
  std::atomic<uint64_t> rays{0}, discarded{0};
  auto start = std::chrono::steady_clock::now();
  {
    ProgressBar progress(options.progress, uint64_t(cam.width) * cam.height * desc.spp);
    tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<int>(0, tiles_x * tiles_y, 1), [&](const tbb::blocked_range<int>& r) {
        for (int tile = r.begin(); tile != r.end(); ++tile) {
          int x0 = (tile % tiles_x) * kTile, y0 = (tile / tiles_x) * kTile;
          int x1 = std::min(x0 + kTile, cam.width), y1 = std::min(y0 + kTile, cam.height);
          uint64_t tile_rays = 0, tile_bad = 0;
          DimSeeds seeds[kSeedCacheDims];
          for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x) {
              PixelSums px;
              Sampler sampler;
              sampler.start(desc, uint32_t(x), uint32_t(y), 0);
              sampler.cache_seeds(seeds, std::min(kSeedCacheDims, desc.spp / 2));
              for (uint32_t s = 0; s < desc.spp; ++s) {
                sampler.set_sample(s);
                const Ray ray = camera_sample(cam, uint32_t(x), uint32_t(y), sampler, rs.filter);
                Color L = path_li(view, tracer, ray, sampler, rs.integrator, tile_rays);
                if (is_finite(L))
                  px.add(L);
                else
                  ++tile_bad;
              }
              film.add(x, y, px);
            }
          rays.fetch_add(tile_rays, std::memory_order_relaxed);
          discarded.fetch_add(tile_bad, std::memory_order_relaxed);
          progress.advance(uint64_t(x1 - x0) * (y1 - y0) * desc.spp);
        }
      });
    });
  }
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  stats.samples = uint64_t(cam.width) * cam.height * desc.spp;
  stats.rays = rays.load();
  stats.discarded = discarded.load();
  return film;
}

}  // namespace luz
