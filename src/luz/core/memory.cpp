#include "luz/core/memory.h"

#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <limits>

#include "luz/io/error.h"

namespace luz {

namespace {

constexpr uint64_t kUnknown = std::numeric_limits<uint64_t>::max();

// A "Key: value kB" line of a /proc file, in bytes; kUnknown when absent.
uint64_t proc_kib(const char* path, const std::string& key) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line))
    if (line.compare(0, key.size(), key) == 0) {
      unsigned long long kib = 0;
      if (std::sscanf(line.c_str() + key.size(), "%llu", &kib) == 1) return uint64_t(kib) * 1024;
    }
  return kUnknown;
}

// A file holding one number ("max" or a value past 2^60: no limit).
uint64_t file_number(const std::string& path) {
  std::ifstream in(path);
  unsigned long long v = 0;
  if (!(in >> v) || v >= (1ull << 60)) return kUnknown;
  return uint64_t(v);
}

uint64_t headroom(uint64_t limit, uint64_t used) {
  if (limit == kUnknown || used == kUnknown) return kUnknown;
  return limit > used ? limit - used : 0;
}

// The memory cgroup's limit less its usage, v2 ("0::/path") or v1 ("N:memory:/path").
uint64_t cgroup_headroom() {
  std::ifstream in("/proc/self/cgroup");
  std::string line;
  uint64_t best = kUnknown;
  while (std::getline(in, line)) {
    const size_t a = line.find(':'), b = line.find(':', a + 1);
    if (a == std::string::npos || b == std::string::npos) continue;
    const std::string controllers = line.substr(a + 1, b - a - 1), path = line.substr(b + 1);
    if (controllers.empty()) {
      // v2: the limits of this group and its ancestors (a container sees "/").
      for (std::string p = path;;) {
        const std::string dir = "/sys/fs/cgroup" + (p == "/" ? "" : p);
        best = std::min(best, headroom(file_number(dir + "/memory.max"), file_number(dir + "/memory.current")));
        const size_t slash = p.find_last_of('/');
        if (p == "/" || slash == std::string::npos) break;
        p.resize(slash == 0 ? 1 : slash);
      }
    } else if (("," + controllers + ",").find(",memory,") != std::string::npos) {
      for (const std::string& dir : {"/sys/fs/cgroup/memory" + path, std::string("/sys/fs/cgroup/memory")})
        best = std::min(best, headroom(file_number(dir + "/memory.limit_in_bytes"),
                                       file_number(dir + "/memory.usage_in_bytes")));
    }
  }
  return best;
}

uint64_t rlimit_headroom(int resource, const char* key) {
  rlimit r{};
  if (::getrlimit(resource, &r) != 0 || r.rlim_cur == RLIM_INFINITY) return kUnknown;
  return headroom(uint64_t(r.rlim_cur), proc_kib("/proc/self/status", key));
}

}  // namespace

uint64_t available_memory() {
  uint64_t a = proc_kib("/proc/meminfo", "MemAvailable:");
  a = std::min(a, cgroup_headroom());
  a = std::min(a, rlimit_headroom(RLIMIT_AS, "VmSize:"));
  a = std::min(a, rlimit_headroom(RLIMIT_DATA, "VmData:"));
  return a == kUnknown ? 0 : a;
}

std::string memory_text(uint64_t bytes) {
  char buf[32];
  if (bytes >= (1ull << 30)) std::snprintf(buf, sizeof buf, "%.1f GiB", double(bytes) / double(1ull << 30));
  else std::snprintf(buf, sizeof buf, "%llu MiB", (unsigned long long)((bytes + (1ull << 20) - 1) >> 20));
  return buf;
}

void require_memory(uint64_t bytes, const std::string& file, const std::string& what, int line) {
  static std::atomic<uint64_t> since_reading{0};
  constexpr uint64_t kStep = uint64_t(16) << 20;
  if (bytes < kStep && since_reading.fetch_add(bytes, std::memory_order_relaxed) + bytes < kStep) return;
  since_reading.store(0, std::memory_order_relaxed);
  // What must stay free beside the request (the render's own buffers): a
  // loader whose many small requests add up is refused as memory runs out.
  constexpr uint64_t kReserve = uint64_t(128) << 20;
  const uint64_t avail = available_memory();
  if (avail == 0 || bytes + kReserve <= avail) return;
  throw InputError(file, line, what + " need " + memory_text(bytes) + " of memory; " + memory_text(avail) +
                                " are available");
}

}  // namespace luz
