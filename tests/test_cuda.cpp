// The CUDA backend (DESIGN.md, validation layer 3: "CPU and GPU agree within
// noise"), in three layers, so that most of it is tested without a GPU:
//
//  * CudaPassOnHost (always runs): the GPU's pass logic, render_pixel_pass
//    and accumulate_pass (device/cuda/pass.h), run on the host over Luz's BVH
//    exactly as render_cuda drives them (passes of K samples, float sums per
//    pass, double film). Checked against render_cpu: same random numbers, so
//    the one-sample images match pixel for pixel but for the rare ray the two
//    tracers round differently; independent seeds agree within noise; K does
//    not change the image beyond float rounding.
//  * CudaDevice (needs a GPU; otherwise SKIPPED with the reason): the same
//    checks on render_cuda's films, plus ray and sample counts.
//  * CudaNoDevice / CliDevice: without a GPU render_cuda throws a one-line
//    "Unavailable" CudaError, `luz render --device cuda` exits 2 with one line
//    and writes nothing, `--device auto` warns once and renders on the CPU,
//    `--device bogus` is refused.
//
// Tolerances.
//  * Agreement within noise: 8×8-pixel block means per channel, z-test with
//    var(A − B) = var(A) + var(B) from the films' own sums (independent
//    seeds), Šidák-corrected over all blocks and channels, family level 1e-3
//    (as test_integrator.cpp).
//  * First sample, same seed: a sample whose path takes the same branches on
//    both sides differs only by float rounding. One path is at most a few
//    hundred float operations (each ≤ ε/2 = 6e-8 relative; the GPU also fuses
//    multiply-adds and its sqrt/pow/exp differ from glibc's by an ulp or two),
//    so such samples agree to ~1e-5 relative: we allow 1e-3 (absolute below
//    1). A sample whose branch flips (a grazing hit, a Russian-roulette
//    decision within an ulp of its threshold) differs arbitrarily: at most 1%
//    of pixels may (on the host, where only the tracer differs, 0.2%).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli_helpers.h"
#include "luz/accel/bvh_build.h"
#include "luz/device/cpu/render.h"
#include "luz/device/cuda/pass.h"
#include "luz/device/cuda/render_cuda.h"
#include "luz/io/image.h"
#include "luz/io/scene_loader.h"
#include "stat_helpers.h"

using namespace luz;
namespace fs = std::filesystem;

namespace {

constexpr double kFamilyAlpha = 1e-3;
constexpr int kBlock = 8;
const std::string kCornell = LUZ_SOURCE_DIR "/scenes/cornell-box.xml";

Scene cornell(int res, uint32_t spp, uint64_t seed) {
  Scene s = load_scene(kCornell, {{"res", std::to_string(res)}});
  // Independent samples: the per-pixel sample variance is then an unbiased
  // estimate of the variance of the mean (test_integrator.cpp).
  s.settings.sampler = SamplerType::Independent;
  s.settings.spp = spp;
  s.settings.seed = seed;
  return s;
}

// The box with an analytic diffuse sphere in the middle and no vertex
// normals: every kind of uploaded array, the null ones included.
Scene cornell_with_sphere(int res, uint32_t spp, uint64_t seed) {
  Scene s = cornell(res, spp, seed);
  Vec3 c = (s.bounds_min + s.bounds_max) * 0.5f;
  uint32_t m = s.add_material(s.materials[0]);
  s.add_sphere(c, 0.15f * (s.bounds_max.x - s.bounds_min.x), m, nullptr, false);
  s.normals.clear();
  s.compile();
  EXPECT_EQ(s.spheres.size(), 1u);
  return s;
}

Film cpu(const Scene& s, RenderStats* stats_out = nullptr) {
  CpuRenderOptions opt;
  RenderStats stats;
  Film f = render_cpu(s, opt, stats);
  if (stats_out) *stats_out = stats;
  return f;
}

// render_cuda's pass loop, on the host: the same PassParams over host
// pointers, render_pixel_pass for every pixel, accumulate_pass per pass.
Film passes_on_host(const Scene& scene, uint32_t per_pass, RenderStats* stats_out = nullptr) {
  const SceneView view = scene.view();
  const Bvh bvh = build_bvh(view);
  const Camera& cam = view.camera;
  const size_t pixels = size_t(cam.width) * cam.height;
  const RenderSettings& rs = scene.settings;
  PassParams p;
  p.scene = view;
  p.tracer = make_bvh_tracer(bvh, view);
  p.sampler = make_sampler_desc(rs.sampler, rs.spp, rs.seed);
  p.integrator = rs.integrator;
  p.filter = rs.filter;
  std::vector<float> sum(3 * pixels), sum_sq(3 * pixels);
  std::vector<uint32_t> count(pixels);
  p.out = {sum.data(), sum_sq.data(), count.data()};
  Film film(cam.width, cam.height);
  std::atomic<uint64_t> rays{0};
  uint64_t discarded = 0;
  for (uint32_t first = 0; first < p.sampler.spp; first += per_pass) {
    p.first_sample = first;
    p.num_samples = std::min(per_pass, p.sampler.spp - first);
    // Poison the outputs: the pass must overwrite every pixel.
    std::fill(sum.begin(), sum.end(), NAN);
    std::fill(count.begin(), count.end(), 0xdeadbeefu);
    tbb::parallel_for(tbb::blocked_range<int>(0, cam.height), [&](const tbb::blocked_range<int>& r) {
      uint64_t n = 0;
      for (int y = r.begin(); y != r.end(); ++y)
        for (int x = 0; x < cam.width; ++x) n += render_pixel_pass(p, uint32_t(x), uint32_t(y));
      rays += n;
    });
    discarded += accumulate_pass(film, sum.data(), sum_sq.data(), count.data(), p.num_samples, 0, pixels);
  }
  if (stats_out) {
    stats_out->samples = uint64_t(pixels) * p.sampler.spp;
    stats_out->rays = rays;
    stats_out->discarded = discarded;
  }
  return film;
}

// ---------------------------------------------------------------- checks

// Two independent images agree within their noise (block z-test, Šidák).
void expect_agree(const Film& a, const Film& b, const char* what) {
  luz_test::Blocks A = luz_test::make_blocks(a, kBlock), B = luz_test::make_blocks(b, kBlock);
  double worst = 0, rel_sum = 0;
  int worst_bx = 0, worst_by = 0, worst_c = 0, n = 0;
  for (int by = 0; by < A.bh; ++by)
    for (int bx = 0; bx < A.bw; ++bx)
      for (int c = 0; c < 3; ++c) {
        double m = 0.5 * (A.m(bx, by, c) + B.m(bx, by, c));
        double floor = luz_test::rounding_floor(m);
        double sigma = std::sqrt(A.v(bx, by, c) + B.v(bx, by, c) + 2 * floor * floor);
        double z = std::fabs(A.m(bx, by, c) - B.m(bx, by, c)) / sigma;
        if (m > 0) rel_sum += sigma / m, ++n;
        if (z > worst) worst = z, worst_bx = bx, worst_by = by, worst_c = c;
      }
  const double thr = luz_test::sidak_z(kFamilyAlpha, 3.0 * A.bw * A.bh);
  std::printf("[%s] worst block z %.2f at (%d,%d) ch %d, threshold %.2f, mean block sigma %.2f%%\n", what, worst,
              worst_bx, worst_by, worst_c, thr, n ? 100 * rel_sum / n : 0.0);
  EXPECT_LE(worst, thr) << what;
}

// Same seed, one sample: pixel for pixel equal to float rounding, but for a
// fraction `max_diverged` of pixels whose path branched differently.
void expect_same_samples(const Film& a, const Film& b, double max_diverged, const char* what) {
  ASSERT_EQ(a.sum.size(), b.sum.size());
  size_t diverged = 0, pixels = a.count.size();
  double worst_rel = 0;
  for (size_t i = 0; i < pixels; ++i) {
    bool differ = a.count[i] != b.count[i];
    for (int k = 0; k < 3; ++k) {
      double x = a.sum[3 * i + k], y = b.sum[3 * i + k];
      double d = std::fabs(x - y) / std::max(1.0, std::fabs(x));
      if (d > 1e-3)
        differ = true;
      else
        worst_rel = std::max(worst_rel, d);
    }
    diverged += differ;
  }
  std::printf("[%s] %zu of %zu one-sample pixels differ (paths that branched apart); the rest within %.2g\n", what,
              diverged, pixels, worst_rel);
  EXPECT_LE(double(diverged), max_diverged * double(pixels)) << what;
}

// ---------------------------------------------------------------- on the host

TEST(CudaPassOnHost, SamplesPerPassDefault) {
  EXPECT_EQ(default_samples_per_pass(512 * 512, 1024), 8u);
  EXPECT_EQ(default_samples_per_pass(64 * 64, 1024), kMaxSamplesPerPass);
  EXPECT_EQ(default_samples_per_pass(64 * 64, 5), 5u);
  EXPECT_EQ(default_samples_per_pass(3840 * 2160, 1024), 1u);
  EXPECT_EQ(default_samples_per_pass(0, 16), 1u);
}

TEST(CudaPassOnHost, FirstSampleMatchesCpu) {
  Scene s = cornell(64, 1, 11);
  RenderStats hs, cs;
  Film h = passes_on_host(s, 1, &hs), c = cpu(s, &cs);
  expect_same_samples(h, c, 2e-3, "host passes vs CPU, 1 spp, same seed");
  EXPECT_EQ(h.count, c.count);
  EXPECT_EQ(hs.discarded, 0u);
  EXPECT_NEAR(double(hs.rays), double(cs.rays), 2e-3 * double(cs.rays)) << "same paths, same rays";
}

TEST(CudaPassOnHost, AgreesWithCpuWithinNoise) {
  Scene a = cornell(64, 128, 21), b = cornell(64, 128, 22);
  expect_agree(passes_on_host(a, 16), cpu(b), "host passes vs CPU, 128 spp, independent seeds");
}

TEST(CudaPassOnHost, SamplesPerPassChangesOnlyRounding) {
  Scene s = cornell(32, 24, 3);
  Film one = passes_on_host(s, 1), five = passes_on_host(s, 5), all = passes_on_host(s, 24);
  for (const Film* f : {&five, &all}) {
    EXPECT_EQ(f->count, one.count);
    for (size_t i = 0; i < one.sum.size(); ++i) {
      // Float sums of ≤ 24 samples: relative error ≤ 24 ε of the sum of magnitudes.
      ASSERT_NEAR(f->sum[i], one.sum[i], 24 * 6e-8 * std::max(1.0, one.sum[i])) << i;
      ASSERT_NEAR(f->sum_sq[i], one.sum_sq[i], 48 * 6e-8 * std::max(1.0, one.sum_sq[i])) << i;
    }
  }
  // One sample per pass: the sums are the CPU's own accumulation of the same floats.
  Film again = passes_on_host(s, 1);
  EXPECT_TRUE(again.sum == one.sum) << "deterministic";
}

TEST(CudaPassOnHost, SpheresAndFlatShadingMatchCpu) {
  Scene s = cornell_with_sphere(64, 1, 12);
  expect_same_samples(passes_on_host(s, 1), cpu(s), 2e-3, "host passes vs CPU, sphere + flat shading, 1 spp");
}

// ---------------------------------------------------------------- on a GPU

#define REQUIRE_GPU()                                                          \
  do {                                                                         \
    std::string why_;                                                          \
    if (!cuda_available(&why_)) GTEST_SKIP() << "no usable CUDA GPU: " << why_; \
  } while (0)

Film gpu(const Scene& s, uint32_t per_pass = 0, RenderStats* stats_out = nullptr) {
  CudaRenderOptions opt;
  opt.samples_per_pass = per_pass;
  RenderStats stats;
  Film f = render_cuda(s, opt, stats);
  if (stats_out) *stats_out = stats;
  return f;
}

TEST(CudaDevice, FirstSampleMatchesCpu) {
  REQUIRE_GPU();
  std::printf("[gpu] %s\n", cuda_device_name().c_str());
  Scene s = cornell(128, 1, 11);
  RenderStats gs, cs;
  Film g = gpu(s, 0, &gs), c = cpu(s, &cs);
  expect_same_samples(g, c, 1e-2, "GPU vs CPU, 1 spp, same seed");
  EXPECT_EQ(gs.samples, cs.samples);
  EXPECT_EQ(gs.discarded, 0u);
  EXPECT_NEAR(double(gs.rays), double(cs.rays), 1e-2 * double(cs.rays)) << "same paths, same rays";
}

TEST(CudaDevice, AgreesWithCpuWithinNoise) {
  REQUIRE_GPU();
  Scene a = cornell(64, 256, 31), b = cornell(64, 256, 32);
  RenderStats gs;
  Film g = gpu(a, 0, &gs);
  EXPECT_EQ(gs.discarded, 0u);
  EXPECT_EQ(gs.samples, 64u * 64u * 256u);
  for (uint32_t n : g.count) ASSERT_EQ(n, 256u);
  expect_agree(g, cpu(b), "GPU vs CPU, 256 spp, independent seeds");
  // And against the pass logic on the host with the GPU's own seed: the same
  // samples, so the whole images match to rounding but for diverged paths.
  Film h = passes_on_host(a, 16);
  double sg = 0, sh = 0;
  for (size_t i = 0; i < g.sum.size(); ++i) sg += g.sum[i], sh += h.sum[i];
  EXPECT_NEAR(sg, sh, 1e-2 * sh) << "GPU vs host passes, same seed: image totals";
}

TEST(CudaDevice, SamplesPerPassChangesOnlyRounding) {
  REQUIRE_GPU();
  Scene s = cornell(48, 20, 4);
  Film one = gpu(s, 1), many = gpu(s, 7), again = gpu(s, 1);
  EXPECT_TRUE(again.sum == one.sum && again.sum_sq == one.sum_sq) << "the same passes give the same film";
  EXPECT_EQ(many.count, one.count);
  for (size_t i = 0; i < one.sum.size(); ++i)
    ASSERT_NEAR(many.sum[i], one.sum[i], 7 * 6e-8 * std::max(1.0, one.sum[i])) << i;
}

TEST(CudaDevice, SpheresAndFlatShadingMatchCpu) {
  REQUIRE_GPU();
  Scene s = cornell_with_sphere(64, 1, 12);
  RenderStats gs;
  Film g = gpu(s, 0, &gs), c = cpu(s);
  EXPECT_EQ(gs.discarded, 0u);
  expect_same_samples(g, c, 1e-2, "GPU vs CPU, sphere + flat shading, 1 spp, same seed");
}

// ---------------------------------------------------------------- without a GPU

TEST(CudaNoDevice, RenderThrowsOneLineUnavailable) {
  std::string why;
  if (cuda_available(&why)) GTEST_SKIP() << "a GPU is present: " << cuda_device_name();
  EXPECT_FALSE(why.empty());
  EXPECT_EQ(why.find('\n'), std::string::npos);
  EXPECT_EQ(cuda_device_name(), "");
  std::printf("[no gpu] cuda_available: %s\n", why.c_str());
  Scene s = cornell(8, 1, 0);
  RenderStats stats;
  try {
    render_cuda(s, CudaRenderOptions{}, stats);
    FAIL() << "render_cuda succeeded without a GPU";
  } catch (const CudaError& e) {
    EXPECT_EQ(e.kind(), CudaError::Kind::Unavailable);
    EXPECT_EQ(std::string(e.what()), why);
  }
}

// ---------------------------------------------------------------- the CLI

class CliDevice : public luz_test::LuzCliTest {
 protected:
  static size_t lines(const std::string& s) { return size_t(std::count(s.begin(), s.end(), '\n')); }
  // A tiny render of the Cornell box.
  std::vector<std::string> tiny(const std::string& device) {
    return {"render", kCornell, "-o", "out.pfm", "-D", "res=16", "--spp", "2", "--device", device};
  }
};

TEST_F(CliDevice, CudaWithoutGpuIsOneLineExit2) {
  std::string why;
  if (cuda_available(&why)) GTEST_SKIP() << "a GPU is present: " << cuda_device_name();
  auto before = listing();
  luz_test::CliResult r = run(tiny("cuda"));
  ASSERT_TRUE(r.exited);
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_EQ(r.err.rfind("luz: error: --device cuda: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(why), std::string::npos) << "the reason: " << why << "\nstderr: " << r.err;
  EXPECT_EQ(listing(), before) << "no output file";
  std::printf("[cli] %s", r.err.c_str());
}

TEST_F(CliDevice, CudaRendersOnAGpu) {
  REQUIRE_GPU();
  luz_test::CliResult r = run(tiny("cuda"));
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find(cuda_device_name()), std::string::npos) << r.err;
  EXPECT_EQ(r.out.rfind("luz: ", 0), 0u) << "the stats line";
  EXPECT_NE(r.out.find("Mrays/s"), std::string::npos) << r.out;
  luz::Image img = luz::read_pfm((dir / "out.pfm").string());
  EXPECT_EQ(img.width, 16);
  EXPECT_EQ(img.height, 16);
}

TEST_F(CliDevice, AutoFallsBackToCpuWithOneWarning) {
  std::string why;
  bool gpu = cuda_available(&why);
  luz_test::CliResult r = run(tiny("auto"));
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "out.pfm"));
  EXPECT_NE(r.out.find("Mrays/s"), std::string::npos) << r.out;
  size_t warnings = 0;
  for (size_t at = r.err.find("luz: warning:"); at != std::string::npos; at = r.err.find("luz: warning:", at + 1))
    ++warnings;
  if (gpu) {
    EXPECT_EQ(warnings, 0u) << r.err;
    EXPECT_NE(r.err.find(cuda_device_name()), std::string::npos) << r.err;
  } else {
    EXPECT_EQ(warnings, 1u) << r.err;
    EXPECT_NE(r.err.find("luz: warning: --device auto: no usable GPU (" + why + "); rendering on the CPU\n"),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("on the CPU\n"), std::string::npos) << r.err;
  }
}

TEST_F(CliDevice, AutoOnBadInputIsStillOneLine) {
  auto before = listing();
  luz_test::CliResult r = run({"render", "missing.xml", "-o", "out.pfm", "--device", "auto"});
  ASSERT_TRUE(r.exited);
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_EQ(r.err.rfind("missing.xml: error: ", 0), 0u) << r.err;
  EXPECT_EQ(listing(), before);
}

TEST_F(CliDevice, BogusDeviceIsRefused) {
  auto before = listing();
  luz_test::CliResult r = run(tiny("bogus"));
  ASSERT_TRUE(r.exited);
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("--device"), std::string::npos) << r.err;
  EXPECT_EQ(listing(), before);
}

TEST_F(CliDevice, CpuIsTheDefaultAndNeverWarns) {
  luz_test::CliResult r = run({"render", kCornell, "-o", "out.pfm", "-D", "res=16", "--spp", "2"});
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("on the CPU\n"), std::string::npos) << r.err;
  luz_test::CliResult c = run({"render", kCornell, "-o", "cpu.pfm", "-D", "res=16", "--spp", "2", "--device", "cpu"});
  ASSERT_EQ(c.status, 0) << c.err;
  EXPECT_EQ(luz::read_pfm((dir / "out.pfm").string()).rgb, luz::read_pfm((dir / "cpu.pfm").string()).rgb);
}

}  // namespace
