// A test fixture with a fresh temporary directory per test (removed after it)
// and a helper that writes a file there.
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/resource.h>

#include <csignal>

#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

class TempDirTest : public ::testing::Test {
 protected:
  std::filesystem::path dir;

  void SetUp() override {
    std::string tmpl = (std::filesystem::temp_directory_path() / "luz_test_XXXXXX").string();
    ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
    dir = tmpl;
  }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
  // Writes `text` to dir/name; returns its path.
  std::string write(const std::string& name, const std::string& text) {
    std::filesystem::path p = dir / name;
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
  }
};

// Runs f with the file-size limit at `bytes` (a write past it fails with
// EFBIG, as on a full disk, instead of raising SIGXFSZ), then restores it.
template <class F>
void with_file_size_limit(rlim_t bytes, F&& f) {
  struct rlimit old;
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  struct rlimit small = old;
  small.rlim_cur = bytes;
  void (*prev)(int) = std::signal(SIGXFSZ, SIG_IGN);
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  f();
  ::setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, prev);
}
