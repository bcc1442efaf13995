// Rendering by work units (render/units.h):
//  * The scheduler hands each block's sample ranges out in order, one unit
//    of a block at a time, covering [first, end) exactly, the block
//    furthest behind first; an undone unit is handed out again.
//  * A start with per-pixel progress halves the block size until it is
//    uniform within every block.
//  * The film is bitwise render()'s for this process alone, for simulated
//    remote workers finishing units in a shuffled order (some units lost
//    and handed out again), with and without this process working too.
//  * A render stopped midway leaves per-pixel progress (Film::next); render()
//    continues it to the very film of an uninterrupted render. A time limit
//    keeps the whole units done.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <atomic>
#include <chrono>
#include <deque>
#include <map>
#include <random>

#include "luz/device/cpu/render.h"
#include "film_helpers.h"
#include "luz/io/load.h"
#include "luz/render/units.h"

namespace {

using namespace luz;

const tbb::global_control kParallelism(tbb::global_control::max_allowed_parallelism, 3);

Scene box(int res, uint32_t spp) {
  return load_scene(LUZ_SOURCE_DIR "/scenes/cornell-box.xml", {{"res", std::to_string(res)}, {"spp", std::to_string(spp)}});
}


TEST(UnitScheduler, EachBlocksRangesInOrderOneAtATime) {
  UnitScheduler s(37, 20, 8, 3, {}, 50);
  EXPECT_EQ(s.block_size(), 8);
  ASSERT_EQ(s.blocks(), 5u * 3u);
  std::vector<uint32_t> next(s.blocks(), 3);
  std::vector<bool> out(s.blocks(), false);
  std::deque<WorkUnit> running;
  std::mt19937 rng(7);
  int undone = 0;
  while (!s.finished()) {
    WorkUnit u;
    while (running.size() < 4 && s.take(64 * 7, u)) {
      ASSERT_FALSE(out[u.block]) << "block " << u.block << " out twice";
      out[u.block] = true;
      EXPECT_EQ(u.first, next[u.block]);
      EXPECT_GT(u.end, u.first);
      EXPECT_LE(u.end, 50u);
      // Samples per pixel from the budget, at least one.
      EXPECT_EQ(u.end - u.first, std::min<uint32_t>(std::max<uint64_t>(64 * 7 / u.rect.pixels(), 1), 50 - u.first));
      const PixelRect r = s.rect(u.block);
      EXPECT_TRUE(r.x0 == u.rect.x0 && r.y1 == u.rect.y1);
      EXPECT_LE(u.rect.x1, 37);
      EXPECT_LE(u.rect.y1, 20);
      running.push_back(u);
    }
    ASSERT_FALSE(running.empty());
    const size_t k = rng() % running.size();
    u = running[k];
    running.erase(running.begin() + ptrdiff_t(k));
    out[u.block] = false;
    if (rng() % 5 == 0) {
      s.undo(u);
      ++undone;
    } else {
      s.done(u);
      next[u.block] = u.end;
    }
  }
  for (uint32_t n : next) EXPECT_EQ(n, 50u);
  EXPECT_GT(undone, 0);
  EXPECT_EQ(s.frontier(), 50u);
  EXPECT_TRUE(s.pixel_next().empty());
}

TEST(UnitScheduler, FurthestBehindFirstAndPerPixelProgress) {
  UnitScheduler s(32, 16, 16, 0, {}, 10);
  WorkUnit a, b;
  ASSERT_TRUE(s.take(256 * 4, a));
  ASSERT_TRUE(s.take(256 * 4, b));
  EXPECT_EQ(a.end, 4u);
  s.done(a);
  WorkUnit c;
  ASSERT_TRUE(s.take(256, c));
  EXPECT_EQ(c.block, a.block);  // the only idle block
  EXPECT_EQ(c.first, 4u);
  WorkUnit none;
  EXPECT_FALSE(s.take(256, none));  // both blocks out
  s.done(b);
  s.done(c);  // c's block at 5, b's at 4
  EXPECT_EQ(s.frontier(), 4u);
  const std::vector<uint32_t> px = s.pixel_next();
  ASSERT_EQ(px.size(), 32u * 16u);
  EXPECT_EQ(px[0], c.block == 0 ? 5u : 4u);
  EXPECT_EQ(px[31], c.block == 1 ? 5u : 4u);
  WorkUnit d;
  ASSERT_TRUE(s.take(256, d));
  EXPECT_EQ(d.block, b.block);  // the block behind

  // Progress of 16² blocks resumed with 16² blocks keeps them; progress that
  // differs within a 4² square forces blocks of 2², within a 2² one of 1.
  UnitScheduler same(32, 16, 16, 4, px, 10);
  EXPECT_EQ(same.block_size(), 16);
  std::vector<uint32_t> finer(32 * 16, 4);
  for (int k : {2, 3, 32 + 2, 32 + 3}) finer[size_t(k)] = 6;
  UnitScheduler halved(32, 16, 16, 4, finer, 10);
  EXPECT_EQ(halved.block_size(), 2);
  EXPECT_EQ(halved.frontier(), 4u);
  finer[3] = 5;
  EXPECT_EQ(UnitScheduler(32, 16, 16, 4, finer, 10).block_size(), 1);
  EXPECT_THROW(UnitScheduler(32, 16, 16, 5, finer, 10), std::invalid_argument);  // a pixel behind `first`
}

TEST(UnitScheduler, BlockSizeGivesEveryWorkerBlocksAndUnitsTheirSamples) {
  EXPECT_EQ(block_size_for(256, 256, 4), 16);
  EXPECT_EQ(block_size_for(16, 16, 4), 4);
  EXPECT_EQ(block_size_for(16, 16, 1000), 1);
  EXPECT_EQ(block_size_for(3, 1, 2), 1);
  // Few samples on many-thread ranks: larger blocks, while enough remain.
  EXPECT_EQ(block_size_for(3840, 2160, 64, 4096, (uint64_t(1) << 18) * 16), 32);
  EXPECT_EQ(block_size_for(256, 256, 4, 0, 0, 32), 32);  // splatting's start
  EXPECT_EQ(block_size_for(64, 64, 4, 0, 0, 32), 16);     // halved for the workers' 4 blocks each
  EXPECT_EQ(block_size_for(3840, 2160, 64, 64, (uint64_t(1) << 18) * 16), 64);
  EXPECT_EQ(block_size_for(3840, 2160, 1000, 64, (uint64_t(1) << 18) * 16), 16);  // 32² would leave 8 blocks a rank
  EXPECT_EQ(block_size_for(256, 256, 2, 64, (uint64_t(1) << 18) * 2), 32);
}

// Remote workers simulated in this process: units queue up and finish in a
// shuffled order; every seventh is lost (returned incomplete).
class ShuffledWorkers : public RemoteWorkers {
 public:
  ShuffledWorkers(const Scene& scene, int n) : device_(scene, 1), n_(n) {}
  int count() const override { return n_; }
  int threads(int) const override { return 1; }
  void send(int worker, const WorkUnit& u, const Film& in) override {
    EXPECT_EQ(in.width, u.rect.width());
    queue_.push_back({worker, u, in});
  }
  bool poll(UnitResult& r) override {
    if (queue_.empty()) return false;
    const size_t k = rng_() % queue_.size();
    Sent s = std::move(queue_[k]);
    queue_.erase(queue_.begin() + ptrdiff_t(k));
    r.worker = s.worker;
    r.unit = s.unit;
    r.film = Film(s.unit.rect.width(), s.unit.rect.height());
    if (++polls_ % 7 == 0) return true;  // lost: incomplete
    const PassResult p = device_.render_pass(s.in, r.film, s.unit.rect, s.unit.first, s.unit.end, {});
    r.complete = p.complete;
    r.rays = p.rays;
    return true;
  }
  int polls() const { return polls_; }

 private:
  struct Sent {
    int worker;
    WorkUnit unit;
    Film in;
  };
  CpuDevice device_;
  int n_, polls_ = 0;
  std::deque<Sent> queue_;
  std::mt19937 rng_{11};
};

TEST(RenderUnits, BitwiseRenderForAnyWorkersAndOrder) {
  const Scene s = box(40, 9);
  RenderRequest req;
  req.threads = 2;
  const RenderResult whole = render(s, req);

  const RenderResult alone = render_units(s, req, nullptr, 16);
  EXPECT_TRUE(alone.complete);
  EXPECT_TRUE(alone.film.next.empty());
  expect_same_film(alone.film, whole.film, "this process alone");
  EXPECT_EQ(alone.stats.spp, 9u);
  EXPECT_EQ(alone.stats.samples, 40u * 40u * 9u);

  ShuffledWorkers three(s, 3);
  const RenderResult remote = render_units(s, req, &three, 8, /*local=*/false);
  EXPECT_TRUE(remote.complete);
  expect_same_film(remote.film, whole.film, "three shuffled remote workers, some units lost");
  EXPECT_GT(three.polls(), 7);

  ShuffledWorkers two(s, 2);
  req.first_sample = 2;
  req.end_sample = 7;
  RenderRequest head = req;
  head.first_sample = 0;
  head.end_sample = 2;
  const RenderResult first = render(s, head);
  req.start = &first.film;
  const RenderResult both = render_units(s, req, &two, 4);
  RenderRequest ref = head;
  ref.end_sample = 7;
  expect_same_film(both.film, render(s, ref).film, "samples [2, 7) by this process and two workers, onto [0, 2)");
}

TEST(RenderUnits, StoppedMidwayContinuesToTheSameFilm) {
  const Scene s = box(48, 12);
  RenderRequest req;
  req.threads = 2;
  const RenderResult whole = render(s, req);

  std::atomic<bool> cancel{false};
  RenderRequest part = req;
  part.cancel = &cancel;
  uint64_t seen = 0;
  part.progress = [&](const RenderProgress& p) {
    seen = p.samples_done;
    if (p.passes_done >= 5) cancel = true;
  };
  const RenderResult stopped = render_units(s, part, nullptr, 16);
  ASSERT_FALSE(stopped.complete);
  ASSERT_EQ(stopped.film.next.size(), 48u * 48u);
  uint64_t held = 0;
  for (size_t i = 0; i < stopped.film.next.size(); ++i) {
    held += stopped.film.next[i];
    EXPECT_LE(stopped.film.count[i], stopped.film.next[i]);
  }
  EXPECT_EQ(held, seen);
  EXPECT_EQ(stopped.stats.spp, *std::min_element(stopped.film.next.begin(), stopped.film.next.end()));

  RenderRequest more = req;
  more.start = &stopped.film;
  more.first_sample = stopped.stats.spp;
  const RenderResult resumed = render(s, more);
  EXPECT_TRUE(resumed.complete);
  EXPECT_TRUE(resumed.film.next.empty());
  expect_same_film(resumed.film, whole.film, "stopped after 5 units, continued by render()");
}

}  // namespace

namespace {

// A time limit stops handing out units; the units out are waited for and
// kept (this process's is abandoned at once): the film holds exactly the
// samples its per-pixel progress says.
TEST(RenderUnits, TimeLimitKeepsWholeUnits) {
  const Scene s = box(32, 20000);
  RenderRequest req;
  req.threads = 1;
  req.time_limit = 0.3;
  ShuffledWorkers two(s, 2);
  const auto start = std::chrono::steady_clock::now();
  const RenderResult r = render_units(s, req, &two, 8);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_FALSE(r.complete);
  EXPECT_LT(seconds, 5.0);
  ASSERT_EQ(r.film.next.size(), 32u * 32u);
  uint64_t held = 0;
  for (size_t i = 0; i < r.film.next.size(); ++i) {
    held += r.film.next[i];
    EXPECT_LE(r.film.count[i], r.film.next[i]);
  }
  EXPECT_EQ(held, r.stats.samples);
  EXPECT_GT(held, 0u);
}

}  // namespace
