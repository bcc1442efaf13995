#include "luz/render/render.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>

#include "luz/device/cpu/render.h"
#include "luz/device/cuda/render_cuda.h"
#include "luz/render/units.h"

namespace luz {

namespace {

using Clock = std::chrono::steady_clock;

// Of the time left, the share a time-limited pass is sized to fill: the rate
// measured so far varies between passes.
constexpr double kTimeMargin = 0.9;

// Serialises the progress callback and keeps its running totals.
class ProgressReport {
 public:
  ProgressReport(const RenderRequest& req, uint64_t total, Clock::time_point start)
      : req_(req), start_(start) {
    p_.samples_total = total;
  }
  void work(uint64_t samples) {
    if (!req_.progress) return;
    std::lock_guard<std::mutex> lock(mutex_);
    p_.samples_done += samples;
    call();
  }
  void pass(uint32_t spp_done, uint32_t passes_done) {
    if (!req_.progress) return;
    std::lock_guard<std::mutex> lock(mutex_);
    p_.spp_done = spp_done;
    p_.passes_done = passes_done;
    call();
  }

 private:
  void call() {
    p_.seconds = std::chrono::duration<double>(Clock::now() - start_).count();
    req_.progress(p_);
  }
  const RenderRequest& req_;
  Clock::time_point start_;
  std::mutex mutex_;
  RenderProgress p_;
};

RenderResult render_on_cuda(const Scene& scene, const RenderRequest& req, uint32_t first, uint32_t end,
                            const std::function<bool()>& stop, ProgressReport& report) {
  CudaRenderOptions opt;
  opt.device = req.cuda_device;
  opt.first_sample = first;
  opt.end_sample = end;
  opt.start = req.start;
  opt.stop = stop;
  uint64_t reported = 0;
  opt.pass_done = [&](const Film& film, const RenderStats& so_far) {
    report.work(so_far.samples - reported);
    reported = so_far.samples;
    report.pass(so_far.spp, so_far.passes);
    if (req.pass_done) req.pass_done(film, so_far);
  };
  RenderResult r;
  r.film = render_cuda(scene, opt, r.stats);
  r.complete = r.stats.spp == end - first;
  return r;
}

}  // namespace

uint32_t next_pass_spp(uint64_t pixels, int threads, uint32_t previous, uint32_t left) {
  const uint64_t per_pass = kPassSamplesPerThread * uint64_t(std::max(threads, 1));
  const uint64_t first = std::max<uint64_t>((per_pass + pixels - 1) / std::max<uint64_t>(pixels, 1), 1);
  const uint64_t cap = std::max<uint64_t>(kMaxDoublingSpp, first);
  uint64_t n = std::min<uint64_t>(previous ? std::min<uint64_t>(2 * uint64_t(previous), cap) : std::min(first, cap), left);
  if (left - n < n) n = left;  // no short pass at the end
  return uint32_t(n);
}

Clock::time_point deadline_of(const RenderRequest& req, Clock::time_point start) {
  if (!(req.time_limit > 0)) return Clock::time_point::max();
  return start + std::chrono::duration_cast<Clock::duration>(
                     std::chrono::duration<double>(std::min(req.time_limit, 1e9)));  // no overflow
}

void check_request(const Scene& scene, const RenderRequest& req) {
  const Camera& cam = scene.camera;
  const uint32_t first = req.first_sample, end = req.end_sample.value_or(scene.settings.spp);
  if (first > end)
    throw std::invalid_argument("render: sample range [" + std::to_string(first) + ", " + std::to_string(end) +
                                ") is reversed");
  if (req.start && (req.start->width != cam.width || req.start->height != cam.height))
    throw std::invalid_argument("render: the start film is " + std::to_string(req.start->width) + "x" +
                                std::to_string(req.start->height) + ", the camera " + std::to_string(cam.width) +
                                "x" + std::to_string(cam.height));
}

RenderResult render(const Scene& scene, const RenderRequest& req) {
  check_request(scene, req);
  // A film stopped with blocks at different samples goes on by blocks.
  if (req.start && !req.start->next.empty()) {
    if (req.device != RenderDevice::Cpu)
      throw std::invalid_argument("render: a film rendered by blocks (an MPI render's checkpoint) continues on the CPU");
    return render_units(scene, req, nullptr, unit_block_start(scene.settings));
  }
  const Camera& cam = scene.camera;
  const uint32_t first = req.first_sample, end = req.end_sample.value_or(scene.settings.spp);
  const uint64_t pixels = uint64_t(cam.width) * uint64_t(cam.height);
  if (first == end) {  // nothing to render: the start film as it is
    RenderResult r;
    r.film = req.start ? *req.start : Film(cam.width, cam.height);
    r.complete = true;
    return r;
  }

  Clock::time_point start = Clock::now(), deadline = Clock::time_point::max();
  auto stop = [&] {
    return (req.cancel && req.cancel->load(std::memory_order_relaxed)) || Clock::now() >= deadline;
  };
  auto set_deadline = [&] {
    start = Clock::now();
    deadline = deadline_of(req, start);
  };

  if (req.device == RenderDevice::Cuda) {
    set_deadline();  // the upload counts against the limit: the CUDA device times its passes alone
    ProgressReport report(req, pixels * (end - first), start);
    return render_on_cuda(scene, req, first, end, stop, report);
  }

  CpuDevice device(scene, req.threads);
  RenderResult res;
  Film film = req.start ? *req.start : Film(cam.width, cam.height), next(cam.width, cam.height);
  set_deadline();
  ProgressReport report(req, pixels * (end - first), start);
  PassHooks hooks{stop, [&](uint64_t samples) { report.work(samples); }};
  RenderStats& st = res.stats;
  uint32_t s = first, last = 0;
  while (s < end && !stop()) {
    uint32_t n = req.pass_spp ? std::min(end - s, req.pass_spp) : next_pass_spp(pixels, device.threads(), last, end - s);
    if (req.time_limit > 0 && st.passes == 0 && !req.pass_spp) {
      n = 1;  // the rate is not known yet
    } else if (req.time_limit > 0 && st.passes > 0) {
      // Only as many samples as the rate so far fits in the time left.
      const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
      const double fit = kTimeMargin * (req.time_limit - elapsed) * (double(st.samples) / elapsed) / double(pixels);
      n = uint32_t(std::clamp(std::floor(fit), 0.0, double(n)));
      if (n == 0) break;
    }
    const PassResult p = device.render_pass(film, next, s, s + n, hooks);
    st.rays += p.rays;
    if (!p.complete) break;
    std::swap(film, next);
    s += n;
    last = n;
    ++st.passes;
    st.spp = s - first;
    st.samples = pixels * st.spp;
    st.discarded += p.discarded;
    report.pass(st.spp, st.passes);
    if (req.pass_done) {
      st.seconds = std::chrono::duration<double>(Clock::now() - start).count();
      req.pass_done(film, st);
    }
  }
  st.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  res.film = std::move(film);
  res.complete = s == end;
  return res;
}

}  // namespace luz
