// Scenes in library tests: rendering one on the CPU with no sample lost, a
// loader's warnings, and bad ones, whose loading must throw one InputError
// naming the file and the problem.
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "luz/device/cpu/render.h"
#include "luz/io/error.h"
#include "luz/io/load.h"

namespace luz_test {

inline luz::Film render_finite(const luz::Scene& s, int threads = 2) {
  luz::CpuRenderOptions opt;
  opt.threads = threads;
  luz::RenderStats stats;
  luz::Film f = luz::render_cpu(s, opt, stats);
  EXPECT_EQ(stats.discarded, 0u) << "non-finite samples";
  return f;
}

// Whether a warning of the loader contains `text`.
inline bool has_warning(const luz::Scene& s, const std::string& text) {
  for (const std::string& w : s.warnings)
    if (w.find(text) != std::string::npos) return true;
  return false;
}

inline void expect_load_refused(const std::string& path, const std::string& file, const std::string& problem) {
  try {
    luz::load_scene(path);
    ADD_FAILURE() << "accepted: " << path << " (wanted: " << problem << ")";
  } catch (const luz::InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file + ":"), std::string::npos) << what;
    EXPECT_NE(what.find(problem), std::string::npos) << what << " (wanted: " << problem << ")";
  }
}

}  // namespace luz_test
