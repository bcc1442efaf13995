// The constant environment's guide (light/env_guide.h, env_guide_build.h):
//  * built the same, bit for bit, on 1 and 3 threads, and a render with it
//    the same on 1 and 3 threads and split in two requests (a resume);
//  * in a room lit through a skylight, the floor's light samples go through
//    the opening many times more often than by the cosine alone, which a
//    closed-form cosine fraction checks the test's own geometry against;
//  * outdoors (a plane under the sky, most of the pilot's rays escaping) no
//    guide is built, and only the first eighth of the pilot is traced.
// Its sampling density (χ² against pdf_li, integrating to one):
// test_emitter_sampling. Renders with it converge to the unguided image:
// test_integrator's EfficiencyVariantsConvergeToTheSameImage.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "luz/accel/embree_tracer.h"
#include "luz/device/cpu/render.h"
#include "luz/io/load.h"
#include "luz/light/env_guide_build.h"
#include "luz/light/light.h"
#include "luz/render/render.h"
#include "temp_dir.h"

using namespace luz;

namespace {

const std::string kSponzaInside = LUZ_SOURCE_DIR "/bench/scenes/sponza-inside.xml";

EnvGuideData build(const Scene& s, int threads, const EnvGuideOptions& o) {
  const SceneView view = s.view();
  EmbreeScene embree(s);
  const EmbreeTracer tracer = embree.tracer();
  tbb::task_arena arena(threads);
  EnvGuideData g;
  arena.execute([&] { g = build_env_guide(view, tracer, o); });
  return g;
}

// A 4 × 3 × 4 room (y up, floor at y = 0) whose ceiling has a 1 × 1
// opening above the floor's centre, lit by a constant sky; the camera inside.
std::string room() {
  auto rect = [](const std::string& transform) {
    return "<shape type=\"rectangle\"><transform name=\"to_world\">" + transform +
           "</transform><bsdf type=\"diffuse\"/></shape>\n";
  };
  std::string shapes;
  shapes += rect("<scale x=\"2\" y=\"2\"/><rotate x=\"1\" angle=\"-90\"/>");                                      // floor
  shapes += rect("<scale x=\"2\" y=\"1.5\"/><translate x=\"0\" y=\"1.5\" z=\"-2\"/>");                             // walls
  shapes += rect("<scale x=\"2\" y=\"1.5\"/><rotate y=\"1\" angle=\"180\"/><translate x=\"0\" y=\"1.5\" z=\"2\"/>");
  shapes += rect("<scale x=\"2\" y=\"1.5\"/><rotate y=\"1\" angle=\"90\"/><translate x=\"-2\" y=\"1.5\" z=\"0\"/>");
  shapes += rect("<scale x=\"2\" y=\"1.5\"/><rotate y=\"1\" angle=\"-90\"/><translate x=\"2\" y=\"1.5\" z=\"0\"/>");
  // The ceiling at y = 3 around the opening |x|, |z| < 0.5: four strips.
  shapes += rect("<scale x=\"2\" y=\"0.75\"/><rotate x=\"1\" angle=\"90\"/><translate x=\"0\" y=\"3\" z=\"-1.25\"/>");
  shapes += rect("<scale x=\"2\" y=\"0.75\"/><rotate x=\"1\" angle=\"90\"/><translate x=\"0\" y=\"3\" z=\"1.25\"/>");
  shapes += rect("<scale x=\"0.75\" y=\"0.5\"/><rotate x=\"1\" angle=\"90\"/><translate x=\"-1.25\" y=\"3\" z=\"0\"/>");
  shapes += rect("<scale x=\"0.75\" y=\"0.5\"/><rotate x=\"1\" angle=\"90\"/><translate x=\"1.25\" y=\"3\" z=\"0\"/>");
  return R"(<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="80"/>
    <transform name="to_world"><lookat origin="0, 1.5, 1.9" target="0, 0, -1" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="64"/></sampler>
    <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="64"/></film>
  </sensor>
)" + shapes + R"(  <emitter type="constant"/>
</scene>)";
}

class EnvGuideTest : public TempDirTest {};

}  // namespace

TEST(EnvGuide, BuiltTheSameOnAnyThreadCount) {
  const Scene s = load_scene(kSponzaInside, {{"res", "64"}, {"max_depth", "10"}});
  EnvGuideOptions o = env_guide_options(64 * 64 * 16);
  const EnvGuideData one = build(s, 1, o), three = build(s, 3, o);
  std::printf("Sponza inside: %u distributions, escaped fraction %.3f, %llu rays\n", one.distributions(),
              one.escaped_fraction, (unsigned long long)one.rays);
  ASSERT_GT(one.distributions(), 10u);
  EXPECT_LT(one.escaped_fraction, 0.1);
  EXPECT_EQ(one.regions, three.regions);
  EXPECT_EQ(one.cdf, three.cdf);
  EXPECT_EQ(one.rays, three.rays);
  // Each distribution a cdf ending at exactly 1, never falling.
  for (uint32_t d = 0; d < one.distributions(); ++d) {
    const float* c = &one.cdf[size_t(d) * EnvGuide::kBins];
    EXPECT_EQ(c[EnvGuide::kBins - 1], 1.f);
    for (int b = 1; b < EnvGuide::kBins; ++b) ASSERT_LE(c[b - 1], c[b]) << "distribution " << d;
  }
}

TEST(EnvGuide, RenderTheSameOnAnyThreadCount) {
  Scene s = load_scene(kSponzaInside, {{"res", "32"}, {"max_depth", "10"}});
  s.settings.spp = 16;
  CpuRenderOptions opt;
  RenderStats st;
  opt.threads = 1;
  const Film one = render_cpu(s, opt, st);
  opt.threads = 3;
  const Film three = render_cpu(s, opt, st);
  EXPECT_TRUE(one.sum == three.sum);
  EXPECT_TRUE(one.sum_sq == three.sum_sq);
  // Split in two requests, as a resume from a checkpoint: the second
  // builds its own guide, the same.
  RenderRequest first;
  first.threads = 2;
  first.end_sample = 5;
  const RenderResult a = render(s, first);
  RenderRequest rest;
  rest.threads = 2;
  rest.first_sample = 5;
  rest.start = &a.film;
  const RenderResult b = render(s, rest);
  EXPECT_TRUE(one.sum == b.film.sum);
  EXPECT_TRUE(one.sum_sq == b.film.sum_sq);
  // And the guide took part: without it the image differs.
  s.settings.env_guide = false;
  const Film off = render_cpu(s, opt, st);
  EXPECT_FALSE(one.sum == off.sum);
}

TEST_F(EnvGuideTest, AimsAtTheSkylight) {
  const Scene s = load_scene(write("room.xml", room()));
  const EnvGuideData g = build(s, 2, env_guide_options(64 * 64 * 64));
  std::printf("room: %u distributions, escaped fraction %.4f\n", g.distributions(), g.escaped_fraction);
  ASSERT_GT(g.distributions(), 0u);
  // Light samples from the floor's centre, with the guide and without.
  SceneView view = s.view();
  ASSERT_GE(view.lights.environment, 0);
  const Light& sky = view.lights[uint32_t(view.lights.environment)];
  const LightSampleContext ctx{{0.f, 0.f, 0.f}, {0.f, 1.f, 0.f}, {0.f, 1.f, 0.f}, {0.f, 1.f, 0.f}};
  ASSERT_GE(g.view.find(ctx.p, ctx.hemisphere), 0);
  auto through_opening = [&](const LightData& data) {
    const int n = 1 << 16;
    int hits = 0;
    for (int i = 0; i < n; ++i) {
      const Vec2 u{(float(i) + 0.5f) / float(n), float((uint32_t(i) * 2654435769u) >> 8) * 0x1p-24f};
      const LightSample ls = sample_li(sky, ctx, u, data);
      if (!(ls.wi.y > 0.f)) continue;
      const float t = 3.f / ls.wi.y;
      hits += std::fabs(ls.wi.x * t) < 0.5f && std::fabs(ls.wi.z * t) < 0.5f;
    }
    return double(hits) / n;
  };
  LightData plain = view.lights.data, guided = plain;
  guided.guide = &g.view;
  const double cosine = through_opening(plain), aimed = through_opening(guided);
  // The cosine's share by quadrature of cos θ / π over the opening (a
  // check of the sampling loop itself): ∫∫ h² / (π (x² + z² + h²)²) dx dz.
  double closed = 0;
  const int q = 400;
  for (int i = 0; i < q; ++i)
    for (int j = 0; j < q; ++j) {
      const double x = -0.5 + (i + 0.5) / q, z = -0.5 + (j + 0.5) / q, r2 = x * x + z * z + 9.0;
      closed += 9.0 / (M_PI * r2 * r2) / (double(q) * q);
    }
  std::printf("floor centre: through the opening %.4f by the cosine (quadrature %.4f), %.4f guided\n", cosine, closed,
              aimed);
  // 2^16 samples of a fraction p ≈ 0.034: σ = sqrt(p (1 - p) / n) ≈ 7e-4
  // (less: x is stratified), so 0.004 is over 5σ.
  EXPECT_NEAR(cosine, closed, 0.004);
  EXPECT_GT(aimed, 5 * cosine);
}

TEST_F(EnvGuideTest, NoneOutdoors) {
  const std::string plane = R"(<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="60"/>
    <transform name="to_world"><lookat origin="0, 2, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
  </sensor>
  <shape type="rectangle"><transform name="to_world"><scale value="10"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"/></shape>
  <shape type="sphere"><float name="radius" value="0.5"/><bsdf type="diffuse"/></shape>
  <emitter type="constant"/>
</scene>)";
  const Scene s = load_scene(write("plane.xml", plane));
  const EnvGuideOptions o = env_guide_options(1 << 20);
  const EnvGuideData g = build(s, 2, o);
  std::printf("outdoors: escaped fraction %.3f, %llu rays\n", g.escaped_fraction, (unsigned long long)g.rays);
  EXPECT_GE(g.escaped_fraction, double(o.scene_escaped));
  EXPECT_EQ(g.distributions(), 0u);
  EXPECT_EQ(g.view.regions, nullptr);
  // Only the first eighth traced: at most depth × (1 + 16) rays a path.
  EXPECT_LE(g.rays, uint64_t(o.pilot_paths / 8) * uint64_t(o.depth) * 17u);
}
