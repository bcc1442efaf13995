// Checkpoints (render/checkpoint.h):
//  * A checkpoint written and read back holds the same film (bitwise), fields,
//    arguments, next sample and stats; a render continued from it equals the
//    uninterrupted render bit for bit.
//  * Every truncation and every corrupted byte is refused with one line
//    naming the file; so are a foreign file, a directory and a missing file.
//  * render_fields: the same scene loaded twice gives the same fields (no
//    stray bytes hashed); one changed vertex, material, light, camera, spp or
//    seed changes exactly the field that names it, and fields_mismatch names it.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <atomic>
#include <fstream>
#include <sstream>

#include "luz/io/error.h"
#include "film_helpers.h"
#include "luz/io/load.h"
#include "luz/render/checkpoint.h"
#include "luz/render/units.h"
#include "temp_dir.h"

namespace {

using namespace luz;

const char* kCornell = LUZ_SOURCE_DIR "/scenes/cornell-box.xml";

Scene box(int res, uint32_t spp) {
  return load_scene(kCornell, {{"res", std::to_string(res)}, {"spp", std::to_string(spp)}});
}

std::string slurp(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void spit(const std::string& p, const std::string& bytes) { std::ofstream(p, std::ios::binary) << bytes; }


// The problem of reading `path` as a checkpoint, checked to be one line
// naming the file; "" when it reads.
std::string read_problem(const std::string& path) {
  try {
    read_checkpoint(path);
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
    return e.problem();
  }
  return "";
}

// Continuing from `c` gives the film of the render never stopped.
void expect_exact_resume(const Scene& s, const Checkpoint& c, const std::string& what) {
  RenderRequest tail;
  tail.threads = 1;
  tail.first_sample = c.next_sample;
  tail.start = &c.film;
  RenderRequest whole;
  whole.threads = 2;
  expect_same_film(render(s, tail).film, render(s, whole).film, what);
}

class CheckpointTest : public TempDirTest {};

TEST_F(CheckpointTest, RoundTripAndExactResume) {
  const Scene s = box(24, 40);
  RenderRequest head;
  head.threads = 2;
  head.end_sample = 13;
  const RenderResult a = render(s, head);
  ASSERT_TRUE(a.complete);
  Checkpoint c;
  c.fields = render_fields(s, RenderDevice::Cpu);
  c.args = {"scene", "/x/y.xml", "output", "", "with\nline break", "\xff\x01"};
  c.next_sample = 13;
  c.stats = a.stats;
  c.film = a.film;
  const std::string path = (dir / "c.ckpt").string();
  write_checkpoint(path, c);
  const Checkpoint r = read_checkpoint(path);
  EXPECT_EQ(r.fields, c.fields);
  EXPECT_EQ(r.args, c.args);
  EXPECT_EQ(r.next_sample, 13u);
  EXPECT_EQ(r.stats.samples, a.stats.samples);
  EXPECT_EQ(r.stats.rays, a.stats.rays);
  EXPECT_EQ(r.stats.seconds, a.stats.seconds);
  EXPECT_EQ(r.stats.spp, 13u);
  expect_same_film(r.film, a.film, "read back");

  expect_exact_resume(s, r, "[0, 13) through a checkpoint, then [13, 40)");
  // Only the checkpoint is in the directory: nothing temporary stays.
  size_t files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1u);
}

// A film stopped with its blocks at different samples (an MPI render's):
// the per-pixel progress goes through the file, and the resume is exact.
TEST_F(CheckpointTest, PerPixelProgressRoundTrip) {
  const Scene s = box(40, 10);
  std::atomic<bool> cancel{false};
  RenderRequest part;
  part.threads = 2;
  part.cancel = &cancel;
  part.progress = [&](const RenderProgress& p) { cancel = p.passes_done >= 3; };
  const RenderResult a = render_units(s, part, nullptr, 16);
  ASSERT_FALSE(a.film.next.empty());
  Checkpoint c;
  c.fields = render_fields(s, RenderDevice::Cpu);
  c.next_sample = a.stats.spp;
  c.film = a.film;
  const std::string path = (dir / "c.ckpt").string();
  write_checkpoint(path, c);
  const Checkpoint r = read_checkpoint(path);
  EXPECT_EQ(r.film.next, a.film.next);
  expect_same_film(r.film, a.film, "read back");
  // A pixel ahead of its count is refused; so is one behind next_sample.
  c.next_sample = a.stats.spp + 1;
  write_checkpoint(path, c);
  EXPECT_NE(read_problem(path).find("behind"), std::string::npos);

  expect_exact_resume(s, r, "3 units through a checkpoint, then the rest");
}

TEST_F(CheckpointTest, TruncatedCorruptedAndForeignFilesAreRefused) {
  const Scene s = box(4, 2);
  RenderRequest req;
  req.threads = 1;
  Checkpoint c;
  c.fields = render_fields(s, RenderDevice::Cpu);
  c.args = {"scene", "/a.xml"};
  c.next_sample = 2;
  c.film = render(s, req).film;
  const std::string good = (dir / "good.ckpt").string(), bad = (dir / "bad.ckpt").string();
  write_checkpoint(good, c);
  const std::string bytes = slurp(good);
  ASSERT_EQ(read_problem(good), "");
  // Every prefix and every byte changed, up to the film; then every 16th (the
  // film's arrays are read alike whatever their size).
  const size_t film = bytes.size() - 16 * (6 * 8 + 4) - 4 - 4;
  auto next = [&](size_t i) { return i < film ? i + 1 : i + 16; };
  for (size_t n = 0; n < bytes.size(); n = next(n)) {
    spit(bad, bytes.substr(0, n));
    const std::string p = read_problem(bad);
    ASSERT_NE(p, "") << "a prefix of " << n << " of " << bytes.size() << " bytes was accepted";
  }
  for (size_t i = 0; i < bytes.size(); i = next(i)) {
    const unsigned char x = i % 2 ? 0x80 : 0x01;
    std::string b = bytes;
    b[i] = char(b[i] ^ x);
    spit(bad, b);
    ASSERT_NE(read_problem(bad), "") << "byte " << i << " ^ " << int(x) << " was accepted";
  }
  // A byte appended.
  spit(bad, bytes + "x");
  EXPECT_NE(read_problem(bad).find("bytes past its end"), std::string::npos);
  spit(bad, bytes.substr(0, bytes.size() / 2));
  EXPECT_NE(read_problem(bad).find("truncated"), std::string::npos);
  std::string flipped = bytes;
  flipped[bytes.size() - 40] ^= 1;  // inside the film's counts: only the checksum can tell
  spit(bad, flipped);
  EXPECT_NE(read_problem(bad).find("checksum"), std::string::npos);
  spit(bad, "<scene version=\"3.0.0\"/>");
  EXPECT_EQ(read_problem(bad), "not a Luz checkpoint");
  EXPECT_NE(read_problem(dir.string()).find("not a regular file"), std::string::npos);
  EXPECT_NE(read_problem((dir / "none.ckpt").string()).find("cannot open"), std::string::npos);
}

TEST(CheckpointFields, SameSceneSameFieldsAndEachChangeNamed) {
  const Scene a = box(16, 8), b = box(16, 8);
  const RenderFields fa = render_fields(a, RenderDevice::Cpu);
  EXPECT_EQ(fa, render_fields(b, RenderDevice::Cpu));
  EXPECT_EQ(fields_mismatch(fa, fa), "");

  auto changed = [&](auto edit) {
    Scene s = box(16, 8);
    edit(s);
    return fields_mismatch(fa, render_fields(s, RenderDevice::Cpu));
  };
  EXPECT_EQ(changed([](Scene& s) { s.positions[0].x += 1e-3f; }), "the geometry differs from the checkpoint's");
  EXPECT_EQ(changed([](Scene& s) { s.colors.assign(s.positions.size(), Color{0.5f, 0.5f, 0.5f}); }),
            "the geometry differs from the checkpoint's");
  EXPECT_EQ(changed([](Scene& s) { s.materials[0].bsdf.diffuse.reflectance.x += 1e-3f; }),
            "the materials and textures differ from the checkpoint's");
  EXPECT_EQ(changed([](Scene& s) { s.lights[0].parallelogram.radiance.x += 1.f; }),
            "the lights differ from the checkpoint's");
  EXPECT_EQ(changed([](Scene& s) { s.camera.origin.y += 1e-3f; }), "the camera differs from the checkpoint's");
  EXPECT_EQ(changed([](Scene& s) { s.settings.spp = 9; }), "spp: the checkpoint has 8, this render 9");
  EXPECT_EQ(changed([](Scene& s) { s.settings.seed = 7; }), "seed: the checkpoint has 0, this render 7");
  EXPECT_EQ(changed([](Scene& s) { s.set_resolution(17, 16); }).rfind("image size: the checkpoint has 16x16, this render 17x16", 0), 0u);
  EXPECT_EQ(fields_mismatch(fa, render_fields(a, RenderDevice::Cuda)), "device: the checkpoint has cpu, this render cuda");
  RenderFields fewer(fa.begin(), fa.end() - 1);
  EXPECT_NE(fields_mismatch(fa, fewer).find("this render none"), std::string::npos);
  EXPECT_NE(fields_mismatch(fewer, fa).find("the checkpoint has none"), std::string::npos);
}

}  // namespace
