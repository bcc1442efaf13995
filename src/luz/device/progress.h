// Progress bar on stderr, shared by the CPU and CUDA renderers: percent, ETA
// and samples/s, redrawn in place every 200 ms by a thread of its own (so a
// long pass or tile never freezes it), and once more, complete, at the end.
// Host only.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <thread>

namespace luz {

class ProgressBar {
 public:
  // enabled false: a no-op (no thread, nothing printed). total: samples.
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
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  // Thread-safe: `samples` more are done.
  void advance(uint64_t samples) { done_.fetch_add(samples, std::memory_order_relaxed); }
  // Thread-safe: `samples` are done in all.
  void set(uint64_t samples) { done_.store(samples, std::memory_order_relaxed); }

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

}  // namespace luz
