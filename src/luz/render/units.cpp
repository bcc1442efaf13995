#include "luz/render/units.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>

#include "luz/device/cpu/render.h"

namespace luz {

UnitScheduler::UnitScheduler(int width, int height, int size, uint32_t first, const std::vector<uint32_t>& next,
                             uint32_t end)
    : width_(width), height_(height), size_(std::max(size, 1)), end_(end) {
  if (!next.empty() && next.size() != size_t(width) * size_t(height))
    throw std::invalid_argument("render: the start film's per-pixel progress has the wrong size");
  auto uniform = [&](const PixelRect& r) {
    for (int y = r.y0; y < r.y1; ++y)
      for (int x = r.x0; x < r.x1; ++x)
        if (next[size_t(y) * width + x] != next[size_t(r.y0) * width + r.x0]) return false;
    return true;
  };
  for (;;) {
    bx_ = (width_ + size_ - 1) / size_;
    const uint32_t by = uint32_t((height_ + size_ - 1) / size_);
    next_.assign(size_t(bx_) * by, first);
    bool ok = true;
    for (uint32_t b = 0; b < next_.size() && ok && !next.empty(); ++b) {
      const PixelRect r = rect(b);
      ok = size_ == 1 || uniform(r);
      next_[b] = next[size_t(r.y0) * width + r.x0];
    }
    if (ok) break;
    size_ /= 2;
  }
  for (uint32_t b = 0; b < next_.size(); ++b) {
    if (next_[b] < first || next_[b] > end)
      throw std::invalid_argument("render: a start film pixel holds samples outside the render's range");
    if (next_[b] < end) idle_.emplace(next_[b], b);
    ++at_[next_[b]];
  }
}

PixelRect UnitScheduler::rect(uint32_t block) const {
  const int x0 = int(block % uint32_t(bx_)) * size_, y0 = int(block / uint32_t(bx_)) * size_;
  return {x0, y0, std::min(x0 + size_, width_), std::min(y0 + size_, height_)};
}

bool UnitScheduler::take(uint64_t samples, WorkUnit& u) {
  if (idle_.empty()) return false;
  const auto [next, block] = *idle_.begin();
  idle_.erase(idle_.begin());
  u.block = block;
  u.rect = rect(block);
  u.first = next;
  const uint64_t spp = std::max<uint64_t>(samples / std::max<uint64_t>(u.rect.pixels(), 1), 1);
  u.end = uint32_t(std::min<uint64_t>(uint64_t(next) + spp, end_));
  ++out_;
  return true;
}

void UnitScheduler::done(const WorkUnit& u) {
  --out_;
  if (--at_[u.first] == 0) at_.erase(u.first);
  ++at_[u.end];
  next_[u.block] = u.end;
  if (u.end < end_) idle_.emplace(u.end, u.block);
}

void UnitScheduler::undo(const WorkUnit& u) {
  --out_;
  idle_.emplace(u.first, u.block);
}

uint32_t UnitScheduler::frontier() const {
  return at_.empty() ? end_ : at_.begin()->first;
}

std::vector<uint32_t> UnitScheduler::pixel_next() const {
  if (at_.size() <= 1) return {};
  std::vector<uint32_t> px(size_t(width_) * size_t(height_));
  for (uint32_t b = 0; b < next_.size(); ++b) {
    const PixelRect r = rect(b);
    for (int y = r.y0; y < r.y1; ++y) std::fill_n(px.begin() + ptrdiff_t(size_t(y) * width_ + r.x0), r.width(), next_[b]);
  }
  return px;
}

int unit_block_start(const RenderSettings& s) { return splats(s.reconstruction, s.filter) ? 2 * kUnitBlock : kUnitBlock; }

int block_size_for(int width, int height, int workers, uint32_t spp, uint64_t unit_samples, int start) {
  // Blocks per worker below which the last units leave workers idle, and
  // below which blocks do not grow (the frame's end waits up to a unit).
  constexpr uint64_t kBlocksPerWorker = 4, kGrowBlocksPerWorker = 16;
  constexpr int kMaxBlock = 64;
  const uint64_t enough = kBlocksPerWorker * uint64_t(std::max(workers, 1));
  const uint64_t plenty = kGrowBlocksPerWorker * uint64_t(std::max(workers, 1));
  auto blocks = [&](int size) { return uint64_t((width + size - 1) / size) * uint64_t((height + size - 1) / size); };
  int size = start;
  // Larger while a whole block's samples are short of a unit and the blocks
  // stay many: each unit's fixed cost to rank 0 then buys more samples.
  while (size < kMaxBlock && uint64_t(size) * uint64_t(size) * spp < unit_samples && blocks(2 * size) >= plenty)
    size *= 2;
  while (size > 1 && blocks(size) < enough) size /= 2;
  return size;
}

namespace {

using Clock = std::chrono::steady_clock;

// Blocks per worker below which units take at most an eighth of the samples.
constexpr uint64_t kFewBlocksPerWorker = 8;

// This process's CPU device on a thread of its own, one unit at a time.
class LocalWorker {
 public:
  LocalWorker(const Scene& scene, int threads, std::function<bool()> stop, std::function<void()> wake)
      : device_(scene, threads), stop_(std::move(stop)), wake_(std::move(wake)), thread_([this] { run(); }) {}
  ~LocalWorker() {
    {
      std::lock_guard<std::mutex> lock(m_);
      quit_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  int threads() const { return device_.threads(); }
  void send(const WorkUnit& u, Film in) {
    {
      std::lock_guard<std::mutex> lock(m_);
      unit_ = u;
      in_ = std::move(in);
      has_unit_ = true;
    }
    cv_.notify_all();
  }
  // The finished unit, if there is one; rethrows the device's failure.
  bool poll(UnitResult& r) {
    std::lock_guard<std::mutex> lock(m_);
    if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
    if (!has_result_) return false;
    r = std::move(result_);
    has_result_ = false;
    return true;
  }

 private:
  void run() {
    for (;;) {
      WorkUnit u;
      Film in;
      {
        std::unique_lock<std::mutex> lock(m_);
        cv_.wait(lock, [&] { return quit_ || has_unit_; });
        if (quit_) return;
        u = unit_;
        in = std::move(in_);
        has_unit_ = false;
      }
      UnitResult r;
      r.unit = u;
      r.film = Film(u.rect.width(), u.rect.height());
      try {
        const PassResult p = device_.render_pass(in, r.film, u.rect, u.first, u.end, PassHooks{stop_, nullptr});
        r.complete = p.complete;
        r.rays = p.rays;
        r.discarded = p.discarded;
        std::lock_guard<std::mutex> lock(m_);
        result_ = std::move(r);
        has_result_ = true;
      } catch (...) {
        std::lock_guard<std::mutex> lock(m_);
        error_ = std::current_exception();
      }
      wake_();
    }
  }

  CpuDevice device_;
  std::function<bool()> stop_;
  std::function<void()> wake_;
  std::mutex m_;
  std::condition_variable cv_;
  bool quit_ = false, has_unit_ = false, has_result_ = false;
  WorkUnit unit_;
  Film in_;
  UnitResult result_;
  std::exception_ptr error_;
  std::thread thread_;  // last: started once the rest is built
};

}  // namespace

RenderResult render_units(const Scene& scene, const RenderRequest& req, RemoteWorkers* remote, int block_size,
                          bool local) {
  check_request(scene, req);
  if (req.device != RenderDevice::Cpu) throw std::invalid_argument("render: work units render on the CPU only");
  const Camera& cam = scene.camera;
  const uint32_t first = req.first_sample, end = req.end_sample.value_or(scene.settings.spp);
  RenderResult res;
  res.film = req.start ? *req.start : Film(cam.width, cam.height);
  UnitScheduler sched(cam.width, cam.height, block_size, first, res.film.next, end);
  uint64_t total = 0;
  if (res.film.next.empty())
    total = uint64_t(cam.width) * cam.height * (end - first);
  else
    for (uint32_t n : res.film.next) total += end - n;
  res.film.next.clear();

  std::mutex wake_m;
  std::condition_variable wake_cv;
  bool woken = false;
  auto wake = [&] {
    {
      std::lock_guard<std::mutex> lock(wake_m);
      woken = true;
    }
    wake_cv.notify_all();
  };
  // Built before the clock starts (Embree's BVH), as render()'s device is.
  Clock::time_point start = Clock::time_point::max(), deadline = Clock::time_point::max();
  auto cancelled = [&] { return req.cancel && req.cancel->load(std::memory_order_relaxed); };
  auto stop = [&] { return cancelled() || Clock::now() >= deadline; };
  std::optional<LocalWorker> me;
  if (local) me.emplace(scene, req.threads, stop, wake);
  start = Clock::now();
  deadline = deadline_of(req, start);

  const int nremote = remote ? remote->count() : 0;
  if (!local && nremote == 0) throw std::invalid_argument("render: work units need a worker");
  // Worker 0 is this process's device, 1.. the remote ones.
  std::vector<bool> busy(size_t(nremote) + 1, false);
  auto threads_of = [&](int w) { return w == 0 ? me->threads() : remote->threads(w - 1); };

  RenderStats& st = res.stats;
  RenderProgress progress;
  progress.samples_total = total;
  Clock::time_point last_pass_done = start;
  uint32_t last_frontier = first;
  auto handle = [&](UnitResult& r) {
    busy[size_t(r.worker)] = false;
    st.rays += r.rays;
    if (!r.complete) {
      sched.undo(r.unit);
      return;
    }
    res.film.paste(r.unit.rect, r.film);
    sched.done(r.unit);
    const uint64_t samples = r.unit.rect.pixels() * (r.unit.end - r.unit.first);
    st.samples += samples;
    st.discarded += r.discarded;
    ++st.passes;
    const uint32_t frontier = sched.frontier();
    st.spp = frontier - first;
    st.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    if (req.progress) {
      progress.samples_done += samples;
      progress.spp_done = st.spp;
      progress.passes_done = st.passes;
      progress.seconds = st.seconds;
      req.progress(progress);
    }
    // The film with its progress, when the frontier moves or a second has passed.
    const Clock::time_point now = Clock::now();
    if (req.pass_done && (frontier != last_frontier || now - last_pass_done >= std::chrono::seconds(1))) {
      res.film.next = sched.pixel_next();
      req.pass_done(res.film, st);
      res.film.next.clear();
      last_pass_done = now;
    }
    last_frontier = frontier;
  };

  for (;;) {
    const bool stopping = stop();
    for (int w = local ? 0 : 1; !stopping && w <= nremote; ++w) {
      if (busy[size_t(w)] || (w > 0 && !remote->available(w - 1))) continue;
      WorkUnit u;
      // A quarter of a second of the worker's threads: long beside what a
      // unit costs to send, receive and place. Where blocks are few beside
      // the workers, no more than an eighth of the samples, so that the last
      // units are short and every block advances in steps.
      const uint64_t block_px = uint64_t(sched.block_size()) * uint64_t(sched.block_size());
      uint64_t samples = kPassSamplesPerThread * uint64_t(std::max(threads_of(w), 1));
      if (sched.blocks() < kFewBlocksPerWorker * uint64_t(nremote + 1))
        samples = std::min(samples, block_px * std::max<uint64_t>((end - first + 7) / 8, 1));
      if (!sched.take(samples, u)) break;
      busy[size_t(w)] = true;
      Film in = res.film.crop(u.rect);
      if (w == 0)
        me->send(u, std::move(in));
      else
        remote->send(w - 1, u, in);
    }
    if (sched.out() == 0) break;
    // A signal does not wait for the units out; a time limit does (they end
    // within a unit, this process's at once).
    if (cancelled()) break;
    UnitResult r;
    if (local && me->poll(r)) {
      r.worker = 0;
      handle(r);
      continue;
    }
    if (remote && remote->poll(r)) {
      ++r.worker;
      handle(r);
      continue;
    }
    std::unique_lock<std::mutex> lock(wake_m);
    wake_cv.wait_for(lock, std::chrono::milliseconds(1), [&] { return woken; });
    woken = false;
  }
  st.spp = sched.frontier() - first;
  st.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  res.film.next = sched.pixel_next();
  res.complete = sched.finished();
  return res;
}

}  // namespace luz
