// The render API (render/render.h):
//  * Definition: a film's sums are each pixel's finite samples added one by
//    one in sample-index order, checked against a plain loop over the
//    sampler, camera and integrator.
//  * Bitwise the same film for 1, 2 and 3 threads (which switch the CPU
//    device between whole-tile work items and tiles split by samples), for
//    passes of 1, 2, 4, ..., of 5 spp and of all spp, and for a range split
//    into two requests, the second continuing the first's film.
//  * A tiny image with many samples: the progress moves many times and more
//    than one thread does the work.
//  * A time limit and a cancellation return whole passes: a film equal to a
//    complete render of the samples per pixel they report.
//  * Requests that contradict the scene are refused.
//  * luz render --time-limit: a valid image and exit 0; bad values refused.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include "cli_helpers.h"
#include "luz/accel/embree_tracer.h"
#include "luz/device/cuda/render_cuda.h"
#include "luz/film/splat.h"
#include "luz/integrator/path.h"
#include "film_helpers.h"
#include "luz/io/load.h"
#include "luz/render/render.h"

namespace {

using namespace luz;

// Three threads even on a machine of two cores, for the whole program (a
// scoped change leaves TBB's market short of workers afterwards).
const tbb::global_control kParallelism(tbb::global_control::max_allowed_parallelism, 3);

const char* kCornell = LUZ_SOURCE_DIR "/scenes/cornell-box.xml";

Scene box(int res, uint32_t spp, const char* sampler = "sobol") {
  Scene s = load_scene(kCornell, {{"res", std::to_string(res)}, {"spp", std::to_string(spp)}});
  if (std::string(sampler) == "independent") s.settings.sampler = SamplerType::Independent;
  if (std::string(sampler) == "stratified") s.settings.sampler = SamplerType::Stratified;
  return s;
}

RenderResult run(const Scene& s, int threads, uint32_t pass_spp = 0, uint32_t first = 0,
                 std::optional<uint32_t> end = std::nullopt,
                 const Film* start = nullptr) {
  RenderRequest req;
  req.threads = threads;
  req.pass_spp = pass_spp;
  req.first_sample = first;
  req.end_sample = end;
  req.start = start;
  return render(s, req);
}

uint64_t film_count(const Film& f) {
  uint64_t n = 0;
  for (uint32_t c : f.count) n += c;
  return n;
}

TEST(Render, FilmIsTheSamplesAddedInIndexOrder) {
  Scene s = box(8, 6);
  s.settings.reconstruction = Reconstruction::FilterSampling;
  const RenderResult r = run(s, 2);
  EXPECT_TRUE(r.complete);
  EXPECT_EQ(r.stats.spp, 6u);
  EXPECT_EQ(r.stats.samples, 8u * 8u * 6u);
  EXPECT_EQ(r.stats.discarded, 0u);
  // The definition, as plainly as it can be written.
  const SceneView view = s.view();
  EmbreeScene embree(s);
  const EmbreeTracer tracer = embree.tracer();
  const SamplerDesc desc = make_sampler_desc(s.settings.sampler, s.settings.spp, s.settings.seed);
  Film want(8, 8);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x)
      for (uint32_t k = 0; k < 6; ++k) {
        Sampler sampler;
        sampler.start(desc, uint32_t(x), uint32_t(y), k);
        uint64_t rays = 0;
        const Color L = path_li(view, tracer, camera_sample(view.camera, uint32_t(x), uint32_t(y), sampler, s.settings.filter),
                                sampler, s.settings.integrator, rays);
        ASSERT_TRUE(is_finite(L));
        want.add(x, y, L);
      }
  expect_same_film(r.film, want, "render() against a plain loop");
}

// Splatting (film/splat.h), as plainly as it can be written: every square
// of the image and a border of one (the tent's reach) takes samples at the
// shared offsets; pixel p's k-th sample weighs the k-th samples of the nine
// squares around it. 34 samples (two chunks of a tile's samples). 264 × 136
// on 1, 2 and 3 threads: whole tiles of 128 and 64 (3 × 2 and 5 × 3, the
// last column and row cut short), each with its border; in passes of 5 spp
// and at 40 × 24, tiles split by samples.
TEST(Render, SplattedFilmIsItsDefinition) {
  for (const auto& [W, H] : {std::pair{264, 136}, std::pair{40, 24}}) {
    Scene s = box(8, 34);
    s.set_resolution(W, H);
    s.settings.integrator.max_depth = 3;
    ASSERT_EQ(s.settings.filter, FilterKind::Tent);
    ASSERT_EQ(s.settings.reconstruction, Reconstruction::Splat);
    const int r = 1;
    const uint32_t spp = 34;
    const SceneView view = s.view();
    EmbreeScene embree(s);
    const EmbreeTracer tracer = embree.tracer();
    const SamplerDesc desc = make_sampler_desc(s.settings.sampler, spp, s.settings.seed);
    const int SW = W + 2 * r, SH = H + 2 * r;
    std::vector<Color> L(size_t(SW) * SH * spp);
    std::vector<Vec2> u(spp);
    for (uint32_t k = 0; k < spp; ++k) u[k] = splat_offset(desc, k);
    for (int y = -r; y < H + r; ++y)
      for (int x = -r; x < W + r; ++x)
        for (uint32_t k = 0; k < spp; ++k) {
          Sampler sampler;
          sampler.start(desc, uint32_t(x), uint32_t(y), k);
          uint64_t rays = 0;
          L[(size_t(y + r) * SW + (x + r)) * spp + k] = path_li(
              view, tracer, camera_sample_at(view.camera, x, y, sampler, u[k]), sampler, s.settings.integrator, rays);
        }
    Film want(W, H);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        for (uint32_t k = 0; k < spp; ++k) {
          Color S{};
          for (int oy = -r; oy <= r; ++oy)
            for (int ox = -r; ox <= r; ++ox) {
              const float w = filter_weight_1d(FilterKind::Tent, float(ox) + u[k].x - 0.5f) *
                              filter_weight_1d(FilterKind::Tent, float(oy) + u[k].y - 0.5f);
              if (w != 0.f) S += L[(size_t(y + oy + r) * SW + (x + ox + r)) * spp + k] * w;
            }
          ASSERT_TRUE(is_finite(S));
          want.add(x, y, S);
        }
    const std::string size = std::to_string(W) + "x" + std::to_string(H);
    for (int threads : {1, 2, 3})
      expect_same_film(run(s, threads).film, want, size + " splatted on " + std::to_string(threads) + " threads");
    expect_same_film(run(s, 2, 5).film, want, size + " splatted in passes of 5");
  }
}

TEST(Render, SameFilmForAnyThreadCount) {
  for (const char* sampler : {"sobol", "independent", "stratified"}) {
    const Scene s = box(40, 24, sampler);  // 3×3 tiles, the last row and column 8 wide
    const RenderResult one = run(s, 1);
    EXPECT_TRUE(one.complete);
    EXPECT_EQ(film_count(one.film) + one.stats.discarded, 40u * 40u * 24u);
    for (int threads : {2, 3}) expect_same_film(one.film, run(s, threads).film, std::string(sampler) + ", threads " + std::to_string(threads));
  }
}

TEST(Render, SameFilmForAnyPassSchedule) {
  const Scene s = box(24, 40);
  const RenderResult whole = run(s, 2);
  EXPECT_EQ(whole.stats.passes, 1u);  // a small image: next_pass_spp's first pass holds it all
  const RenderResult ones = run(s, 2, 1);
  EXPECT_EQ(ones.stats.passes, 40u);
  const RenderResult fives = run(s, 3, 5);
  EXPECT_EQ(fives.stats.passes, 8u);
  expect_same_film(whole.film, ones.film, "passes of 1 spp against one pass");
  expect_same_film(whole.film, fives.film, "passes of 5 spp against one pass");
  // [0, 13) then [13, 40) onto its film: the resume of a checkpoint.
  const RenderResult head = run(s, 1, 0, 0, 13);
  EXPECT_EQ(head.stats.spp, 13u);
  EXPECT_TRUE(head.complete);
  const RenderResult tail = run(s, 2, 3, 13, 40, &head.film);
  EXPECT_EQ(tail.stats.spp, 27u);
  expect_same_film(whole.film, tail.film, "[0, 13) + [13, 40) against [0, 40)");
  // The tail alone is a different film: the test can tell.
  const RenderResult alone = run(s, 2, 0, 13, 40);
  EXPECT_NE(alone.film.sum, tail.film.sum);
  EXPECT_EQ(film_count(alone.film) + alone.stats.discarded, 24u * 24u * 27u);
}

TEST(Render, TinyImageWithManySamplesKeepsTheCoresBusy) {
  const Scene s = box(8, 8192);  // one tile, one pass
  struct Run {
    std::set<std::thread::id> ids;
    std::vector<uint64_t> done;
    bool overlapped = false;
  };
  auto run = [&] {
    Run out;
    std::mutex mutex;
    std::atomic<int> in_callback{0};
    RenderRequest req;
    req.threads = 2;
    req.progress = [&](const RenderProgress& p) {
      if (in_callback.fetch_add(1) != 0) out.overlapped = true;
      {
        std::lock_guard<std::mutex> lock(mutex);
        out.ids.insert(std::this_thread::get_id());
        out.done.push_back(p.samples_done);
        EXPECT_EQ(p.samples_total, 8u * 8u * 8192u);
      }
      in_callback.fetch_sub(1);
    };
    EXPECT_TRUE(render(s, req).complete);
    return out;
  };
  const Run r = run();
  EXPECT_FALSE(r.overlapped) << "the progress callback ran twice at once";
  EXPECT_GE(r.done.size(), 50u);
  for (size_t i = 1; i < r.done.size(); ++i) ASSERT_GE(r.done[i], r.done[i - 1]);
  EXPECT_EQ(r.done.back(), 8u * 8u * 8192u);
  size_t distinct = std::set<uint64_t>(r.done.begin(), r.done.end()).size();
  EXPECT_GE(distinct, 40u) << "the progress hardly moved";
  // Both threads take work items. Which thread runs an item is the
  // scheduler's choice: on a machine busy with other tests one worker can
  // take them all within a second, so up to five renders are given the
  // chance; work in one item would never show two.
  size_t threads = r.ids.size();
  for (int attempt = 1; attempt < 5 && threads < 2; ++attempt) threads = run().ids.size();
  EXPECT_EQ(threads, 2u) << "the work items ran on one thread in five renders";
}

// Passes double from about kPassSamplesPerThread pixel-samples per thread to
// 64 spp (or that first size, when larger), and never leave a short one.
TEST(Render, PassSchedule) {
  auto schedule = [](uint64_t pixels, int threads, uint32_t spp) {
    std::vector<uint32_t> out;
    for (uint32_t s = 0, n = 0; s < spp; s += n) out.push_back(n = next_pass_spp(pixels, threads, n, spp - s));
    return out;
  };
  using V = std::vector<uint32_t>;
  EXPECT_EQ(schedule(1920 * 1080, 2, 300), (V{1, 2, 4, 8, 16, 32, 64, 64, 109}));
  EXPECT_EQ(schedule(1920 * 1080, 2, 3), (V{1, 2}));
  EXPECT_EQ(schedule(256 * 256, 2, 64), (V{8, 16, 40}));
  EXPECT_EQ(schedule(256 * 256, 16, 64), (V{64}));
  EXPECT_EQ(schedule(16 * 16, 2, 10000), (V{2048, 2048, 2048, 3856}));
  EXPECT_EQ(schedule(1, 1, 1u << 24).size(), 64u);
}

TEST(Render, TimeLimitReturnsWholePasses) {
  const Scene s = box(32, 1 << 20);  // hours of work
  RenderRequest req;
  req.threads = 2;
  req.time_limit = 0.5;
  const RenderResult r = render(s, req);
  EXPECT_FALSE(r.complete);
  EXPECT_GT(r.stats.spp, 0u);
  EXPECT_LT(r.stats.spp, 1u << 20);
  EXPECT_LT(r.stats.seconds, 10.0);  // generous: a loaded machine
  EXPECT_EQ(r.stats.samples, 32u * 32u * r.stats.spp);
  EXPECT_EQ(film_count(r.film) + r.stats.discarded, r.stats.samples);
  for (uint32_t c : r.film.count) ASSERT_LE(c, r.stats.spp);
  // The same film as a complete render of that many samples.
  expect_same_film(r.film, run(s, 2, 0, 0, r.stats.spp).film, "time-limited against complete");
}

TEST(Render, CancellationFromTheProgressCallbackStopsEarly) {
  Scene s = box(16, 1 << 20);
  s.settings.reconstruction = Reconstruction::FilterSampling;  // the work items counted below
  std::atomic<bool> cancel{false};
  int calls = 0;
  RenderRequest req;
  req.threads = 2;
  req.cancel = &cancel;
  req.pass_spp = 256;  // 16 work items and a pass end: 17 calls a pass
  req.progress = [&](const RenderProgress& p) {
    if (++calls == 40 || p.seconds > 30) cancel = true;  // in the third pass
  };
  const RenderResult r = render(s, req);
  EXPECT_FALSE(r.complete);
  EXPECT_GE(calls, 40);
  EXPECT_EQ(r.stats.spp, 512u);
  EXPECT_LT(r.stats.spp, 1u << 20);
  EXPECT_EQ(film_count(r.film) + r.stats.discarded, 16u * 16u * r.stats.spp);
  expect_same_film(r.film, run(s, 1, 0, 0, r.stats.spp).film, "cancelled against complete");
  // Cancelled before it starts: an empty film.
  const RenderResult none = render(s, req);
  EXPECT_FALSE(none.complete);
  EXPECT_EQ(none.stats.spp, 0u);
  EXPECT_EQ(film_count(none.film), 0u);
}

TEST(Render, RequestsThatContradictTheSceneAreRefused) {
  const Scene s = box(8, 4);
  EXPECT_THROW(run(s, 1, 0, 3, 2), std::invalid_argument);
  const Film other(9, 8);
  EXPECT_THROW(run(s, 1, 0, 0, 4, &other), std::invalid_argument);
  // An empty range returns the start film as it was.
  const RenderResult head = run(s, 1, 0, 0, 2);
  const RenderResult same = run(s, 1, 0, 2, 2, &head.film);
  EXPECT_TRUE(same.complete);
  expect_same_film(same.film, head.film, "an empty range");
  RenderRequest req;
  req.device = RenderDevice::Cuda;
  std::string why;
  if (!cuda_available(&why)) EXPECT_THROW(render(s, req), CudaError);
}

using RenderCli = luz_test::LuzCliTest;

TEST_F(RenderCli, TimeLimit) {
  const auto t0 = std::chrono::steady_clock::now();
  luz_test::CliResult r =
      run({"render", kCornell, "-D", "res=16", "--spp", "16777216", "--time-limit", "0.5", "-o", "out.pfm"});
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_TRUE(r.exited);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("the time limit of 0.5 s ended the render at "), std::string::npos) << r.err;
  EXPECT_LT(wall, 30.0);  // generous: a loaded machine; without the limit it takes hours
  EXPECT_GT(luz_test::fs::file_size(dir / "out.pfm"), 16u * 16u * 12u);
  for (const char* bad : {"0", "-1", "nan", "inf", "0x10", "1e400", "2s"}) {
    r = run({"render", kCornell, "--time-limit", bad, "-o", "bad.pfm"});
    EXPECT_EQ(r.status, 2) << bad;
    EXPECT_NE(r.err.find(std::string("--time-limit: '") + bad + "' is not a number of seconds"), std::string::npos)
        << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  EXPECT_EQ(listing(), std::set<std::string>{"out.pfm"});
}

}  // namespace
