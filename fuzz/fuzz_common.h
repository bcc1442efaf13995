// What the fuzz targets share. The readers take paths, as the command line
// calls them: the input is written to a file in a folder of its own, so a
// scene's relative references find nothing but the files a target puts
// there. Bad input must end in luz::InputError, the one error the command
// line reports as "file:line: problem"; anything else escapes to libFuzzer
// as a finding (as do crashes, sanitizer reports, timeouts and memory).
// The folder also holds small files scenes may name (fuzz/assets: mesh.obj,
// mesh.ply, colors.ply, mesh.serialized, texture.png, env.exr, env.pfm), so that a scene
// reads on past its meshes and textures. LUZ_FUZZ_VERBOSE=1 prints each
// input's InputError (to see how far a seed reads).
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "luz/io/error.h"

namespace luz::fuzz {

// A folder for this process (fuzzing jobs run side by side), removed at
// exit; in memory (/dev/shm) where there is one: writing the input to a
// disk's file system makes a run several times slower.
inline const std::string& folder() {
  struct Folder {
    std::string path;
    Folder() {
      const char* tmp = std::getenv("TMPDIR");
      const std::string base = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : tmp && *tmp ? tmp : "/tmp";
      path = base + "/luz-fuzz-" + std::to_string(getpid());
      std::filesystem::create_directories(path);
      namespace fs = std::filesystem;
      fs::copy(LUZ_FUZZ_ASSETS, path, fs::copy_options::overwrite_existing | fs::copy_options::recursive);
    }
    ~Folder() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
  };
  static const Folder f;
  return f.path;
}

// Writes the bytes to folder()/name and returns its path.
inline std::string write_file(const std::string& name, const uint8_t* data, size_t size) {
  const std::string path = folder() + "/" + name;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f || std::fwrite(data, 1, size, f) != size || std::fclose(f) != 0) std::abort();
  return path;
}

template <class F>
void expect_input_error(F&& read) {
  try {
    read();
  } catch (const InputError& e) {
    static const bool verbose = std::getenv("LUZ_FUZZ_VERBOSE") != nullptr;
    if (verbose) std::fprintf(stderr, "%s\n", e.what());
  }
}

// The input as file `name` (its extension chooses the format), read by read(path).
template <class F>
int read_file(const uint8_t* data, size_t size, const std::string& name, F&& read) {
  const std::string path = write_file(name, data, size);
  expect_input_error([&] { read(path); });
  return 0;
}

}  // namespace luz::fuzz
