// Files read ahead in parallel, for readers whose scene names many (meshes,
// images): the reader lists the files first, reads them all at once with
// TBB, then translates its scene in file order as before, taking each file's
// result from here. A read that failed keeps its exception, thrown where the
// translation takes that file: the first error in file order is the one
// reported, with the message a sequential read gives. Each read depends on
// its file alone, so results do not depend on the thread count.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <exception>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace luz {

template <class T>
class ReadAhead {
 public:
  // Reads each key not read yet with read(key), in parallel, the keys listed
  // first started first (list the larger files first). A key listed n times
  // may be taken n times.
  void run(const std::vector<std::string>& keys, const std::function<T(const std::string&)>& read) {
    std::vector<std::pair<const std::string*, Slot*>> jobs;
    for (const std::string& k : keys) {
      auto [it, added] = slots_.try_emplace(k);
      ++it->second.uses;
      if (added) jobs.push_back({&it->first, &it->second});
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, jobs.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t j = r.begin(); j < r.end(); ++j) try {
          jobs[j].second->value.emplace(read(*jobs[j].first));
        } catch (...) {
          jobs[j].second->error = std::current_exception();
        }
    });
  }

  // The result for key (nullopt when it was not read ahead or was taken as
  // often as listed; the last take moves it out); rethrows the exception its
  // read threw.
  std::optional<T> take(const std::string& key) {
    auto it = slots_.find(key);
    if (it == slots_.end()) return std::nullopt;
    if (--it->second.uses > 0) {
      if (it->second.error) std::rethrow_exception(it->second.error);
      return it->second.value;
    }
    Slot s = std::move(it->second);
    slots_.erase(it);
    if (s.error) std::rethrow_exception(s.error);
    return std::move(s.value);
  }

  // Frees what nobody took.
  void clear() { slots_.clear(); }

 private:
  struct Slot {
    std::optional<T> value;
    std::exception_ptr error;
    int uses = 0;
  };
  std::map<std::string, Slot> slots_;
};

// Files in the order to read them in: larger first, so that the last to
// finish are small.
inline std::vector<std::string> largest_first(const std::vector<std::string>& paths) {
  std::vector<std::pair<uintmax_t, std::string>> by_size;
  for (const std::string& p : paths) {
    std::error_code ec;
    const uintmax_t size = std::filesystem::file_size(p, ec);
    by_size.push_back({ec ? 0 : size, p});
  }
  std::stable_sort(by_size.begin(), by_size.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::string> out;
  for (auto& [size, p] : by_size) out.push_back(std::move(p));
  return out;
}

}  // namespace luz
