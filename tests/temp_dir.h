// A test fixture with a fresh temporary directory per test (removed after it)
// and a helper that writes a file there.
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>

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
