#include "luz/device/cpu/render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <vector>

#include "luz/device/cpu/env_guide.h"
#include "luz/device/cpu/path_li.h"
#include "luz/device/progress.h"
#include "luz/film/splat.h"

namespace luz {

namespace {

constexpr int kTile = 16;
// Splatting's tiles: each computes the squares of a border `reach` wide
// around it too (those its pixels' filters reach), again for every tile
// that borders them: for the tent 3% more samples than the image's at 128,
// 6% at 64, 27% at 16. So the largest size, 128, where its tiles keep the
// threads busy or where splitting them by samples costs little memory (a
// small image, an MPI unit: the buffer holds every pixel's samples of the
// pass); otherwise halved (down to kTile) until the tiles are enough.
constexpr int kSplatTile = 128;
constexpr uint64_t kSplitBufferBytes = uint64_t(16) << 20;
// Splatting computes a tile's samples in chunks of at most this many per
// square (the squares' samples are kept until their pixels have them).
constexpr uint32_t kSplatChunk = 32;
// A pass has at least this many work items per thread when the samples
// allow: enough that the last items finishing leave little idle time.
constexpr int kItemsPerThread = 8;
// A split tile's items take at most this many pixel-samples: cancellation is
// polled between items.
constexpr uint64_t kMaxItemSamples = uint64_t(1) << 14;
// The Sobol seeds of a pixel's first dimensions (at most the camera's and 8
// vertices') are computed once per pixel and work item: two hashes per
// dimension (~60 instructions), against ~25 saved per draw. An item of n
// samples per pixel caches n/2 dimensions, so that even a dimension only
// some paths reach pays back.
constexpr uint32_t kSeedCacheDims = kCameraDims + 8 * kDimsPerVertex;

}  // namespace

struct CpuDevice::Impl {
  SceneView view;
  EmbreeScene embree;
  EmbreeTracer tracer;
  const RenderSettings& rs;
  SamplerDesc desc;
  tbb::task_arena arena;
  std::vector<Color> samples;  // split tiles' radiance, tile² × n per tile
  std::unique_ptr<std::atomic<uint32_t>[]> unfinished;  // split tiles' items still running

  bool splat;
  int reach;
  EnvGuideData guide;

  Impl(const Scene& scene, int threads)
      : view(scene.view()),
        embree(scene),
        tracer(embree.tracer()),
        rs(scene.settings),
        desc(make_sampler_desc(rs.sampler, rs.spp, rs.seed)),
        arena(threads > 0 ? threads : tbb::task_arena::automatic),
        splat(splats(rs.reconstruction, rs.filter)),
        reach(splat ? filter_reach(rs.filter) : 0) {
    // The environment's guide: its pilot traced here, once per device.
    if (wants_env_guide(view, rs.env_guide)) {
      const EnvGuideOptions o = env_guide_options(uint64_t(view.camera.width) * uint64_t(view.camera.height) * rs.spp);
      arena.execute([&] { guide = build_env_guide_embree(view, tracer, o); });
      if (guide.view.regions) view.lights.data.guide = &guide.view;
    }
  }

  // One path's radiance, by the path loop without the map code where the
  // scene has no normal or bump map.
  Color li(const Ray& ray, Sampler& sampler, uint64_t& rays) const {
    if (view.materials.mapped) return path_li_cpu(view, tracer, ray, sampler, rs.integrator, rays);
    return path_li_cpu_unmapped(view, tracer, ray, sampler, rs.integrator, rays);
  }

  // The tile size for a pass of n samples over `rect`, for `want` work items.
  int tile(const PixelRect& rect, uint64_t want, uint32_t n) const {
    if (!splat) return kTile;
    auto tiles = [&](int t) { return uint64_t((rect.width() + t - 1) / t) * uint64_t((rect.height() + t - 1) / t); };
    int t = kSplatTile;
    while (t > kTile && t / 2 >= std::max(rect.width(), rect.height())) t /= 2;  // no larger than the rect
    if (tiles(t) * uint64_t(t) * uint64_t(t) * n * sizeof(Color) <= kSplitBufferBytes) return t;
    while (t > kTile && tiles(t) < want) t /= 2;
    return t;
  }

  // Splatting: samples [a, b) of every pixel of [x0, x1) × [y0, y1)
  // (film/splat.h), chunk by chunk; each chunk hands sink(x, y, S, n, c0)
  // the samples [c0, c0 + n) of a pixel in index order, the pixels in rows.
  template <class Sink>
  void take_splat(int x0, int y0, int x1, int y1, uint32_t a, uint32_t b, DimSeeds* seeds, uint64_t& rays,
                  Sink&& sink) const {
    const int r = reach, cw = x1 - x0 + 2 * r, ch = y1 - y0 + 2 * r;
    // The item's own (a few megabytes, against seconds of paths): nothing
    // stays allocated once the render is done.
    std::vector<Color> squares;  // [square][k]
    std::vector<Color> S;
    SplatWeights weights[kSplatChunk];
    for (uint32_t c0 = a; c0 < b; c0 += kSplatChunk) {
      const uint32_t n = std::min(kSplatChunk, b - c0);
      squares.resize(size_t(cw) * ch * n);
      S.resize(n);
      Vec2 offset[kSplatChunk];
      for (uint32_t k = 0; k < n; ++k) {
        offset[k] = splat_offset(desc, c0 + k);
        weights[k] = splat_weights(rs.filter, r, offset[k]);
      }
      for (int sy = 0; sy < ch; ++sy)
        for (int sx = 0; sx < cw; ++sx) {
          const int x = x0 - r + sx, y = y0 - r + sy;
          Color* out = &squares[(size_t(sy) * cw + sx) * n];
          Sampler sampler;
          sampler.start(desc, uint32_t(x), uint32_t(y), c0);  // squares outside the image: wrapped, distinct
          sampler.cache_seeds(seeds, std::min(kSeedCacheDims, n / 2));
          for (uint32_t k = 0; k < n; ++k) {
            sampler.set_sample(c0 + k);
            const Ray ray = camera_sample_at(view.camera, x, y, sampler, offset[k]);
            out[k] = li(ray, sampler, rays);
          }
        }
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          const size_t base = (size_t(y - y0 + r) * cw + (x - x0 + r)) * n;
          for (uint32_t k = 0; k < n; ++k)
            S[k] = splat_gather(r, weights[k], [&](int ox, int oy) -> const Color& {
              return squares[base + (ptrdiff_t(oy) * cw + ox) * ptrdiff_t(n) + k];
            });
          sink(x, y, S.data(), n, c0);
        }
    }
  }

  // Samples [a, b) of pixel (x, y) in index order, each radiance handed to sink.
  template <class Sink>
  void take(uint32_t x, uint32_t y, uint32_t a, uint32_t b, DimSeeds* seeds, uint64_t& rays, Sink&& sink) const {
    Sampler sampler;
    sampler.start(desc, x, y, a);
    sampler.cache_seeds(seeds, std::min(kSeedCacheDims, (b - a) / 2));
    for (uint32_t s = a; s < b; ++s) {
      sampler.set_sample(s);
      const Ray ray = camera_sample(view.camera, x, y, sampler, rs.filter);
      sink(li(ray, sampler, rays));
    }
  }
};

CpuDevice::CpuDevice(const Scene& scene, int threads) : m_(std::make_unique<Impl>(scene, threads)) {}
CpuDevice::~CpuDevice() = default;

int CpuDevice::threads() const { return m_->arena.max_concurrency(); }

PassResult CpuDevice::render_pass(const Film& in, Film& out, uint32_t first, uint32_t end, const PassHooks& hooks) {
  const Camera& cam = m_->view.camera;
  return render_pass(in, out, PixelRect{0, 0, cam.width, cam.height}, first, end, hooks);
}

PassResult CpuDevice::render_pass(const Film& in, Film& out, const PixelRect& rect, uint32_t first, uint32_t end,
                                  const PassHooks& hooks) {
  Impl& m = *m_;
  // Items per tile: 1 when the tiles alone keep the cores busy (then the
  // buffer, tile_size² × n radiances per tile, would be the largest).
  // Splatting asks half as many: each tile more means more border squares.
  const uint64_t want = uint64_t(m.splat ? kItemsPerThread / 2 : kItemsPerThread) * uint64_t(threads());
  const uint32_t n = end - first;
  const int tile_size = m.tile(rect, want, n);
  const int tiles_x = (rect.width() + tile_size - 1) / tile_size, tiles_y = (rect.height() + tile_size - 1) / tile_size;
  const int tiles = tiles_x * tiles_y;
  // Samples an item takes per sample index: a whole tile's, or for
  // splatting the squares of a tile and its border.
  const uint64_t tile_px =
      m.splat ? uint64_t(std::min(tile_size, rect.width()) + 2 * m.reach) * uint64_t(std::min(tile_size, rect.height()) + 2 * m.reach)
              : uint64_t(tile_size) * uint64_t(tile_size);
  uint32_t split = 1;
  if (uint64_t(tiles) < want)
    split = uint32_t(std::clamp<uint64_t>(std::max((want + tiles - 1) / tiles,
                                                   (tile_px * n + kMaxItemSamples - 1) / kMaxItemSamples),
                                          1, std::max(n, 1u)));
  if (split > 1) {
    m.samples.resize(size_t(tiles) * tile_size * tile_size * n);
    m.unfinished = std::make_unique<std::atomic<uint32_t>[]>(size_t(tiles));
    for (int t = 0; t < tiles; ++t) m.unfinished[t].store(split, std::memory_order_relaxed);
  }

  std::atomic<uint64_t> rays{0}, discarded{0};
  std::atomic<bool> abandoned{false};
  auto item = [&](int it) {
    if (abandoned.load(std::memory_order_relaxed) || (hooks.stop && hooks.stop())) {
      abandoned.store(true, std::memory_order_relaxed);
      return;
    }
    const int tile = it / int(split), part = it % int(split);
    const int x0 = rect.x0 + (tile % tiles_x) * tile_size, y0 = rect.y0 + (tile / tiles_x) * tile_size;
    const int x1 = std::min(x0 + tile_size, rect.x1), y1 = std::min(y0 + tile_size, rect.y1);
    const uint32_t k0 = uint32_t(uint64_t(n) * part / split), k1 = uint32_t(uint64_t(n) * (part + 1) / split);
    uint64_t item_rays = 0, bad = 0;
    DimSeeds seeds[kSeedCacheDims];
    // Adds samples to pixel (x, y)'s sums from `in`, in index order.
    auto add_all = [&](int x, int y, auto&& samples_of) {
      const size_t i = size_t(y - rect.y0) * rect.width() + (x - rect.x0);
      PixelSums px = in.pixel(i);
      samples_of([&](const Color& L) {
        if (is_finite(L))
          px.add(L);
        else
          ++bad;
      });
      out.set(i, px);
    };
    if (m.splat && split == 1) {
      // Chunk by chunk: the first adds onto `in`'s sums, the next onto its own.
      m.take_splat(x0, y0, x1, y1, first, end, seeds, item_rays,
                   [&](int x, int y, const Color* S, uint32_t count, uint32_t c0) {
                     const size_t i = size_t(y - rect.y0) * rect.width() + (x - rect.x0);
                     PixelSums px = (c0 == first ? in : out).pixel(i);
                     for (uint32_t k = 0; k < count; ++k) {
                       if (is_finite(S[k]))
                         px.add(S[k]);
                       else
                         ++bad;
                     }
                     out.set(i, px);
                   });
    } else if (split == 1) {
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x)
          add_all(x, y, [&](auto&& sink) { m.take(uint32_t(x), uint32_t(y), first, end, seeds, item_rays, sink); });
    } else {
      Color* buf = m.samples.data() + size_t(tile) * tile_size * tile_size * n;
      if (m.splat) {
        m.take_splat(x0, y0, x1, y1, first + k0, first + k1, seeds, item_rays,
                     [&](int x, int y, const Color* S, uint32_t count, uint32_t c0) {
                       std::copy(S, S + count, buf + (size_t(y - y0) * tile_size + (x - x0)) * n + (c0 - first));
                     });
      } else {
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x) {
            Color* dst = buf + (size_t(y - y0) * tile_size + (x - x0)) * n + k0;
            m.take(uint32_t(x), uint32_t(y), first + k0, first + k1, seeds, item_rays, [&](const Color& L) { *dst++ = L; });
          }
      }
      // The tile's last item adds all its samples, in order.
      if (m.unfinished[tile].fetch_sub(1, std::memory_order_acq_rel) == 1)
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x) {
            const Color* src = buf + (size_t(y - y0) * tile_size + (x - x0)) * n;
            add_all(x, y, [&](auto&& sink) {
              for (uint32_t k = 0; k < n; ++k) sink(src[k]);
            });
          }
    }
    rays.fetch_add(item_rays, std::memory_order_relaxed);
    discarded.fetch_add(bad, std::memory_order_relaxed);
    if (hooks.done) hooks.done(uint64_t(x1 - x0) * uint64_t(y1 - y0) * (k1 - k0));
  };
  m.arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, tiles * int(split), 1), [&](const tbb::blocked_range<int>& r) {
      for (int it = r.begin(); it != r.end(); ++it) item(it);
    });
  });
  PassResult res;
  res.complete = !abandoned.load();
  res.rays = rays.load();
  res.discarded = res.complete ? discarded.load() : 0;
  return res;
}

Film render_cpu(const Scene& scene, const CpuRenderOptions& options, RenderStats& stats) {
  RenderRequest req;
  req.threads = options.threads;
  const Camera& cam = scene.camera;
  ProgressBar bar(options.progress, uint64_t(cam.width) * cam.height * scene.settings.spp);
  if (options.progress) req.progress = [&](const RenderProgress& p) { bar.set(p.samples_done); };
  RenderResult r = render(scene, req);
  stats = r.stats;
  return std::move(r.film);
}

}  // namespace luz
