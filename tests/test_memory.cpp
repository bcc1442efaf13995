// The memory check (core/memory.h) and what it refuses:
//  * available_memory() is positive and never above the kernel's MemAvailable;
//    under an address-space limit (ulimit -v) it is that limit's headroom.
//  * require_memory() passes a request that fits and refuses one that does
//    not, naming the file, what needs how much and what is available.
//  * luz under `ulimit -v`: a glTF file of 40 KB whose 20,000 mirrored
//    nodes each copy a 3,000-vertex mesh (2.6 GB in all) is refused while it
//    loads with one line naming the file and what needs how much, exit 2, not an
//    out-of-memory failure; a film too large for the limit likewise, before
//    any rendering.
#include "luz/core/memory.h"

#include <sys/resource.h>

#include <fstream>

#include "cli_helpers.h"
#include "luz/io/error.h"
#include "sanitizer.h"

namespace {

using namespace luz_test;

// A "Key: value kB" line of a /proc file, in bytes (0 when absent).
uint64_t proc_bytes(const char* path, const std::string& key) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(key, 0) == 0) return std::stoull(line.substr(key.size())) * 1024;
  return 0;
}

TEST(Memory, AvailableIsAtMostTheKernels) {
  const uint64_t a = luz::available_memory(), kernel = proc_bytes("/proc/meminfo", "MemAvailable:");
  ASSERT_GT(kernel, 0u);
  EXPECT_GT(a, 0u);
  // The kernel's figure moves between the two readings: 64 MiB of slack.
  EXPECT_LE(a, kernel + (64u << 20));
}

// In a child process (the limit is for good): the headroom under RLIMIT_AS,
// a request that fits, one that does not and its message.
TEST(Memory, AddressSpaceLimitIsHonoured) {
  if (kAsan) GTEST_SKIP() << "under AddressSanitizer (its shadow memory exceeds any address-space limit)";
  const pid_t pid = ::fork();
  if (pid == 0) {
    const uint64_t size = proc_bytes("/proc/self/status", "VmSize:"), room = uint64_t(512) << 20;
    rlimit r{rlim_t(size + room), rlim_t(size + room)};
    if (::setrlimit(RLIMIT_AS, &r) != 0) ::_exit(10);
    const uint64_t a = luz::available_memory();
    if (a > room || a < room - (uint64_t(64) << 20)) ::_exit(11);
    try {
      luz::require_memory(uint64_t(256) << 20, "fits.ply", "its vertices");
    } catch (...) {
      ::_exit(12);
    }
    try {
      luz::require_memory(uint64_t(3) << 30, "big.ply", "its vertices");
      ::_exit(13);
    } catch (const luz::InputError& e) {
      const std::string want = "big.ply: its vertices need 3.0 GiB of memory; ";
      if (std::string(e.what()).rfind(want, 0) != 0 || std::string(e.what()).find(" MiB are available") == std::string::npos)
        ::_exit(14);
    }
    // Within 128 MiB of the limit: refused (the render needs some to spare).
    try {
      luz::require_memory(a - (uint64_t(64) << 20), "edge.ply", "its vertices");
      ::_exit(15);
    } catch (const luz::InputError&) {
    }
    ::_exit(0);
  }
  int st = 0;
  ASSERT_EQ(::waitpid(pid, &st, 0), pid);
  ASSERT_TRUE(WIFEXITED(st));
  EXPECT_EQ(WEXITSTATUS(st), 0) << "10: setrlimit failed, 11: headroom not seen, 12: a fitting request refused, "
                                   "13: a 3 GiB request passed, 14: the message, 15: the reserve";
}

TEST(Memory, Text) {
  EXPECT_EQ(luz::memory_text(uint64_t(3) << 30), "3.0 GiB");
  EXPECT_EQ(luz::memory_text(uint64_t(1536) << 20), "1.5 GiB");
  EXPECT_EQ(luz::memory_text(uint64_t(512) << 20), "512 MiB");
  EXPECT_EQ(luz::memory_text(1), "1 MiB");
}

class MemoryCli : public LuzCliTest {
 protected:
  // luz with `args` under `ulimit -v` of `mib` MiB.
  void SetUp() override {
    if (kAsan) GTEST_SKIP() << "under AddressSanitizer (its shadow memory exceeds any address-space limit)";
    LuzCliTest::SetUp();
  }

  CliResult limited(int mib, const std::vector<std::string>& args) {
    std::string command = "ulimit -v " + std::to_string(mib * 1024) + " && exec '" + std::string(LUZ_BINARY) + "'";
    for (const std::string& a : args) command += " '" + a + "'";
    return run_program("/bin/sh", {"-c", command});
  }
};

TEST_F(MemoryCli, ManyCopiesOfAMeshAreRefusedWhileLoading) {
  // One mesh: a 30×100 grid of vertices (5,742 triangles), in grid.bin.
  const int nx = 30, ny = 100, n = nx * ny;
  std::vector<float> pos;
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x) pos.insert(pos.end(), {float(x), float(y), 0.f});
  std::vector<uint32_t> idx;
  for (int y = 0; y + 1 < ny; ++y)
    for (int x = 0; x + 1 < nx; ++x) {
      const uint32_t a = uint32_t(y * nx + x);
      idx.insert(idx.end(), {a, a + 1, a + nx + 1, a, a + nx + 1, a + nx});
    }
  {
    std::ofstream bin(dir / "grid.bin", std::ios::binary);
    bin.write(reinterpret_cast<const char*>(pos.data()), std::streamsize(pos.size() * 4));
    bin.write(reinterpret_cast<const char*>(idx.data()), std::streamsize(idx.size() * 4));
  }
  // 20,000 nodes place it mirrored (scale -1 in x): a mirrored placement is
  // copied, not instanced, 3,000 vertices each time.
  const int nodes = 20000;
  std::string json = R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[)";
  for (int k = 0; k < nodes; ++k) json += (k ? "," : "") + std::to_string(k);
  json += "]}],\"nodes\":[";
  for (int k = 0; k < nodes; ++k)
    json += std::string(k ? "," : "") + R"({"mesh":0,"scale":[-1,1,1],"translation":[0,0,)" + std::to_string(k) + "]}";
  const size_t pos_bytes = pos.size() * 4, idx_bytes = idx.size() * 4;
  json += R"(],"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],)";
  json += R"("buffers":[{"uri":"grid.bin","byteLength":)" + std::to_string(pos_bytes + idx_bytes) + "}],";
  json += R"("bufferViews":[{"buffer":0,"byteLength":)" + std::to_string(pos_bytes) + R"(},{"buffer":0,"byteOffset":)" +
          std::to_string(pos_bytes) + R"(,"byteLength":)" + std::to_string(idx_bytes) + "}],";
  json += R"("accessors":[{"bufferView":0,"componentType":5126,"count":)" + std::to_string(n) +
          R"(,"type":"VEC3","min":[0,0,0],"max":[29,99,0]},{"bufferView":1,"componentType":5125,"count":)" +
          std::to_string(idx.size()) + R"(,"type":"SCALAR"}]})";
  std::ofstream(dir / "copies.gltf") << json;

  const CliResult r = limited(1536, {"render", "copies.gltf", "--res", "8x8", "--spp", "1", "-o", "x.pfm"});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  // Refused by the reader's request for a copy or by the scene's arrays' growth, whichever comes first.
  EXPECT_EQ(r.err.rfind("copies.gltf: meshes[0].primitives[0]: error: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(" need "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(" of memory; "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(" are available"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "x.pfm"));
}

TEST_F(MemoryCli, AFilmBeyondTheLimitIsRefusedBeforeRendering) {
  const CliResult r = limited(1536, {"render", LUZ_SOURCE_DIR "/scenes/cornell-box.xml", "--res", "8000x8000", "-o",
                                     "x.pfm"});
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  // 64 million pixels, 168 bytes each (three films of 52, the image's 12).
  EXPECT_NE(r.err.find("luz: error: the render needs 10.0 GiB of memory (the films of the 8000×8000 image: 10.0 GiB, "
                       "the acceleration structure of 32 triangles: 1 MiB); "),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir / "x.pfm"));
}

}  // namespace
