// Progress on stderr, shared by the CLI and the renderers: a bar redrawn in
// place every 200 ms on a terminal (fitted to its width), or a line every few
// seconds when stderr is a file or a pipe. Each shows the percentage, spp
// done, elapsed time and ETA as h:mm:ss, and samples/s. A thread of its own
// draws, so a long pass never freezes it. Host only.
#pragma once

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <thread>

namespace luz {

// "1:02:03" (hours unbounded), "--:--:--" for an unknown or absurd time.
inline std::string hms(double seconds) {
  if (!(seconds >= 0) || seconds > 3.6e8) return "--:--:--";
  const long long s = (long long)(seconds + 0.5);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%lld:%02lld:%02lld", s / 3600, s / 60 % 60, s % 60);
  return buf;
}

// One progress report at most `width` columns wide (a bar fills what the
// text leaves; fields go, least useful first, when even they do not fit).
// spp_total 0: no spp field.
inline std::string progress_text(uint64_t done, uint64_t total, uint32_t spp_done, uint32_t spp_total, double seconds,
                                 int width, bool bar) {
  const double frac = total ? std::min(1.0, double(done) / double(total)) : 1.0;
  const double rate = seconds > 0 ? double(done) / seconds : 0;
  const double eta = rate > 0 ? double(total - std::min(done, total)) / rate : -1;
  char pct[16], spp[48], speed[32];
  std::snprintf(pct, sizeof pct, "%5.1f%%", 100.0 * frac);
  std::snprintf(spp, sizeof spp, "%u/%u spp", spp_done, spp_total);
  std::snprintf(speed, sizeof speed, "%.2f Msamples/s", rate * 1e-6);
  const std::string fields[] = {pct, hms(seconds) + " elapsed", "ETA " + hms(eta), spp_total ? spp : "", speed};
  // Dropped in this order when the width is short: speed, elapsed, spp, ETA.
  bool keep[5] = {true, true, true, spp_total > 0, true};
  const int drop_order[] = {4, 1, 3, 2};
  auto text = [&] {
    std::string t;
    for (int k = 0; k < 5; ++k)
      if (keep[k]) t += (t.empty() ? "" : "  ") + fields[k];
    return t;
  };
  std::string t = text();
  constexpr int kMinBar = 10;
  const int need_bar = bar ? kMinBar + 3 : 0;  // "[...] "
  for (int d = 0; d < 4 && int(t.size()) + need_bar > width; ++d) {
    keep[drop_order[d]] = false;
    t = text();
  }
  if (!bar || int(t.size()) + need_bar > width) return t.substr(0, size_t(std::max(width, 0)));
  const int n = width - int(t.size()) - 3;
  std::string b = "[";
  const int filled = int(frac * n);
  b.append(size_t(filled), '#');
  b.append(size_t(n - filled), '.');
  return b + "] " + t;
}

class ProgressBar {
 public:
  enum class Mode { Off, Bar, Lines };
  static constexpr double kLineSeconds = 5;

  // Bar on a terminal, else Off (the renderers' own option).
  ProgressBar(bool enabled, uint64_t total) : ProgressBar(enabled ? Mode::Bar : Mode::Off, total, 0) {}
  // total: samples; spp_total: samples per pixel to report beside them (0: none).
  ProgressBar(Mode mode, uint64_t total, uint32_t spp_total) : mode_(mode), total_(total), spp_total_(spp_total) {
    if (mode_ != Mode::Off) thread_ = std::thread([this] { loop(); });
  }
  ~ProgressBar() {
    if (mode_ == Mode::Off) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_flag_ = true;
    }
    cv_.notify_all();
    thread_.join();
    if (mode_ == Mode::Bar) {
      draw();
      std::fputc('\n', stderr);
    }
  }
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  // Thread-safe: `samples` more are done.
  void advance(uint64_t samples) { done_.fetch_add(samples, std::memory_order_relaxed); }
  // Thread-safe: `samples` are done in all (and the film holds spp of every pixel).
  void set(uint64_t samples, uint32_t spp = 0) {
    done_.store(samples, std::memory_order_relaxed);
    if (spp) spp_.store(spp, std::memory_order_relaxed);
  }
  void set_spp_done(uint32_t spp) { spp_.store(spp, std::memory_order_relaxed); }

 private:
  void loop() {
    const auto period = mode_ == Mode::Bar ? std::chrono::milliseconds(200)
                                           : std::chrono::milliseconds(int(kLineSeconds * 1000));
    std::unique_lock<std::mutex> lock(mutex_);
    while (!cv_.wait_for(lock, period, [this] { return done_flag_; })) draw();
  }
  static int terminal_width() {
    struct winsize ws;
    if (::ioctl(2, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0) return ws.ws_col;
    const char* c = std::getenv("COLUMNS");
    const int n = c ? std::atoi(c) : 0;
    return n > 0 ? n : 80;
  }
  void draw() {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const uint64_t done = done_.load(std::memory_order_relaxed);
    const uint32_t spp = spp_.load(std::memory_order_relaxed);
    if (mode_ == Mode::Bar) {
      // One column short of the width: a full line would wrap on some terminals.
      const std::string s = progress_text(done, total_, spp, spp_total_, t, terminal_width() - 1, true);
      std::fprintf(stderr, "\r%s\033[K", s.c_str());
    } else {
      const std::string s = progress_text(done, total_, spp, spp_total_, t, 1 << 20, false);
      std::fprintf(stderr, "luz: %s\n", s.c_str());
    }
    std::fflush(stderr);
  }

  Mode mode_;
  uint64_t total_;
  uint32_t spp_total_;
  std::atomic<uint64_t> done_{0};
  std::atomic<uint32_t> spp_{0};
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::mutex mutex_;
  std::condition_variable cv_;
  bool done_flag_ = false;
  std::thread thread_;
};

}  // namespace luz
