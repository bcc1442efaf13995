#include "luz/device/cpu/render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <thread>

#include "luz/accel/embree_tracer.h"
#include "luz/integrator/path.h"

namespace luz {

namespace {

constexpr int kTile = 16;

// Progress bar on stderr: percent, ETA and samples/s, redrawn in place.
class ProgressBar {
 public:
  ProgressBar(bool enabled, uint64_t total) : enabled_(enabled), total_(total) {
    if (enabled_) thread_ = std::thread([this] { loop(); });
  }
  ~ProgressBar() {
    if (!enabled_) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_flag_ = true;
    }
    cv_.notify_all();
    thread_.join();
    draw();
    std::fputc('\n', stderr);
  }
  void advance(uint64_t samples) { done_.fetch_add(samples, std::memory_order_relaxed); }

 private:
  void loop() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!cv_.wait_for(lock, std::chrono::milliseconds(200), [this] { return done_flag_; })) draw();
  }
  void draw() {
    double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    uint64_t done = done_.load(std::memory_order_relaxed);
    double frac = total_ ? double(done) / double(total_) : 1.0;
    double rate = t > 0 ? done / t : 0;
    double eta = rate > 0 ? (total_ - done) / rate : 0;
    constexpr int kWidth = 30;
    char bar[kWidth + 1];
    int filled = int(frac * kWidth);
    for (int i = 0; i < kWidth; ++i) bar[i] = i < filled ? '#' : '.';
    bar[kWidth] = 0;
    std::fprintf(stderr, "\r[%s] %5.1f%%  ETA %6.1fs  %7.2f Msamples/s ", bar, 100.0 * frac, eta, rate * 1e-6);
    std::fflush(stderr);
  }

  bool enabled_;
  uint64_t total_;
  std::atomic<uint64_t> done_{0};
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::mutex mutex_;
  std::condition_variable cv_;
  bool done_flag_ = false;
  std::thread thread_;
};

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
          for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x) {
              PixelSums px;
              Sampler sampler;
              sampler.start(desc, uint32_t(x), uint32_t(y), 0);
              for (uint32_t s = 0; s < desc.spp; ++s) {
                sampler.set_sample(s);
                Vec2 off = sample_filter(rs.filter, sampler.next_2d());
                Ray ray = cam.generate_ray(float(x) + 0.5f + off.x, float(y) + 0.5f + off.y);
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
