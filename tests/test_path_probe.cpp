// path.h's probe hooks (bench/efficiency's profile): a probed path_li returns
// the same radiance and ray count as the renderers' unprobed one, and its
// counts add up: one camera ray per sample, every shadow ray occluded or
// contributing, one end per path, roulette only from rr_depth on, and the
// radiance by path length summing to the sample's.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <string>

#include "luz/accel/embree_tracer.h"
#include "luz/camera/camera.h"
#include "luz/integrator/path.h"
#include "luz/io/load.h"

using namespace luz;

namespace {

constexpr int kMaxLength = 80;

struct Counts {
  uint64_t rays[3] = {}, nee[5] = {}, ends[5] = {}, roulette_before_rr = 0;
  std::array<Color, kMaxLength + 1> by_length{};
};

struct TestProbe {
  static constexpr bool kEnabled = true;
  static inline Counts* c = nullptr;
  static inline int rr_depth = 0;
  static void ray(RayKind k) { ++c->rays[uint32_t(k)]; }
  static void nee(NeeOutcome o) { ++c->nee[uint32_t(o)]; }
  static void roulette(int depth, bool) { c->roulette_before_rr += depth < rr_depth; }
  static void end(int, PathEnd e) { ++c->ends[uint32_t(e)]; }
  static void radiance(int length, const Color& v) { c->by_length[std::min(length, kMaxLength)] += v; }
};

void check_scene(const std::string& path, const Defines& defines) {
  Scene s = load_scene(path, defines);
  EmbreeScene embree(s);
  const EmbreeTracer tracer = embree.tracer();
  const SceneView view = s.view();
  const SamplerDesc desc = make_sampler_desc(s.settings.sampler, 4, 1);
  Counts total;
  uint64_t samples = 0, rays_plain = 0;
  TestProbe::rr_depth = s.settings.integrator.rr_depth;
  for (int y = 0; y < s.camera.height; ++y)
    for (int x = 0; x < s.camera.width; ++x)
      for (uint32_t i = 0; i < desc.spp; ++i) {
        Sampler a, b;
        a.start(desc, uint32_t(x), uint32_t(y), i);
        b.start(desc, uint32_t(x), uint32_t(y), i);
        const Ray ra = camera_sample(s.camera, uint32_t(x), uint32_t(y), a, s.settings.filter);
        const Ray rb = camera_sample(s.camera, uint32_t(x), uint32_t(y), b, s.settings.filter);
        uint64_t na = 0, nb = 0;
        const Color plain = path_li(view, tracer, ra, a, s.settings.integrator, na);
        Counts one;
        TestProbe::c = &one;
        const Color probed = path_li<EmbreeTracer, TestProbe>(view, tracer, rb, b, s.settings.integrator, nb);
        ASSERT_EQ(plain.x, probed.x);
        ASSERT_EQ(plain.y, probed.y);
        ASSERT_EQ(plain.z, probed.z);
        ASSERT_EQ(na, nb);
        ASSERT_EQ(one.rays[0] + one.rays[1] + one.rays[2], nb);
        Color sum{};
        for (const Color& v : one.by_length) sum += v;
        for (int k = 0; k < 3; ++k) ASSERT_NEAR(sum[k], probed[k], 1e-4f * (1.f + std::fabs(probed[k])));
        ++samples;
        rays_plain += na;
        for (int k = 0; k < 3; ++k) total.rays[k] += one.rays[k];
        for (int k = 0; k < 5; ++k) total.nee[k] += one.nee[k], total.ends[k] += one.ends[k];
        total.roulette_before_rr += one.roulette_before_rr;
      }
  EXPECT_EQ(total.rays[uint32_t(RayKind::Camera)], samples);
  EXPECT_EQ(total.rays[uint32_t(RayKind::Shadow)],
            total.nee[uint32_t(NeeOutcome::Occluded)] + total.nee[uint32_t(NeeOutcome::Contributed)]);
  EXPECT_EQ(total.ends[0] + total.ends[1] + total.ends[2] + total.ends[3] + total.ends[4], samples);
  EXPECT_EQ(total.roulette_before_rr, 0u);
  EXPECT_GT(total.nee[uint32_t(NeeOutcome::Contributed)], 0u);
  EXPECT_GT(rays_plain, samples);
}

}  // namespace

TEST(PathProbe, CornellBoxCountsAddUpAndRadianceIsUnchanged) {
  check_scene(LUZ_SOURCE_DIR "/scenes/cornell-box.xml", {{"res", "16"}, {"max_depth", "65"}});
}

TEST(PathProbe, EnvironmentLitSceneCountsAddUp) {
  const std::string envmap = LUZ_SHARED_DIR "/scenes/material-testball/pbrt-v4/textures/envmap.hdr";
  if (!std::filesystem::exists(envmap)) GTEST_SKIP() << envmap << " is missing";
  check_scene(LUZ_SOURCE_DIR "/bench/scenes/envmap-spheres.xml", {{"res", "16"}, {"envmap", envmap}});
}
