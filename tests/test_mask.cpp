// Mitsuba's `mask` (material/opacity.h): alpha-tested geometry.
//
// The scene: a diffuse plane (albedo ρ) at z = 0 seen straight down by an
// orthographic camera over [-2, 2]², lit by a directional light at 45° in x
// (direction (1, 0, -1)), direct light only (max_depth 2): an unshadowed
// pixel is ρ/π · E cos 45° in every sample. A masked quad at z = 2 over
// x ∈ [-4, -2] lies outside the view but shadows x ∈ [-2, 0], the image's
// left half, exactly.
//  * opacity 0 (on a quad in view and in the light): the image is the image
//    without the quad, bit for bit (no random number depends on it);
//  * a 0/1 checkerboard opacity whose cells' shadows tile the left half in
//    whole periods across x: each row of the shadow is half open, so the
//    shadow's mean is half the lit mean;
//  * a constant opacity 0.3: the stochastic test keeps 30% of the shadow
//    rays' hits, so the shadow's mean is 0.7 of the lit mean.
// The ratios are z-tested against the shadow's pixel variance (the lit
// pixels have none beyond rounding), from the film's own sums.
//  * Embree's filter function and Luz's BVH any-hit make the same decisions:
//    random rays through masked quads (textured and constant) and a masked
//    sphere, both queries.
//  * Bad input: one file:line error each.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "luz/accel/bvh_build.h"
#include "luz/accel/embree_tracer.h"
#include "luz/io/load.h"
#include "luz/math/hash.h"
#include "scene_helpers.h"
#include "stat_helpers.h"
#include "temp_dir.h"

using namespace luz;

namespace {

constexpr int kRes = 32;
constexpr double kAlbedo = 0.5;

std::string scene_xml(const std::string& extra, int spp = 64) {
  return R"(<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="2"/></integrator>
  <sensor type="orthographic">
    <transform name="to_world"><scale x="2" y="2"/><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value=")" + std::to_string(spp) + R"("/></sampler>
    <film type="hdrfilm"><integer name="width" value=")" + std::to_string(kRes) + R"("/><integer name="height" value=")" +
         std::to_string(kRes) + R"("/><rfilter type="box"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><scale value="10"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value=")" + std::to_string(kAlbedo) + R"("/></bsdf>
  </shape>
  <emitter type="directional"><vector name="direction" x="1" y="0" z="-1"/><rgb name="irradiance" value="1"/></emitter>
)" + extra + "\n</scene>\n";
}

// A quad over x ∈ [-4, -2], y ∈ [-3, 3] at z = 2 whose bsdf is `bsdf`.
std::string side_quad(const std::string& bsdf) {
  return R"(<shape type="rectangle">
    <transform name="to_world"><scale x="1" y="3"/><translate x="-3" y="0" z="2"/></transform>)" +
         bsdf + "</shape>";
}

std::string mask(const std::string& opacity) {
  return R"(<bsdf type="mask">)" + opacity + R"(<bsdf type="diffuse"/></bsdf>)";
}

// Mean radiance of the shadowed (left) and lit (right) halves, and the
// variance of the shadowed mean (pixels independent: variances add).
struct Halves {
  double shadow = 0, lit = 0, shadow_var = 0;
};

class Mask : public TempDirTest {
 protected:
  Scene load(const std::string& extra, int spp = 64) { return load_scene(write("scene.xml", scene_xml(extra, spp))); }

  // Pixel columns 1..14 and 17..30 (one column off the shadow's edge at
  // x = 0 and off the view's); the shadowed half is the darker one.
  static Halves halves(const Film& f) {
    double sum[2] = {0, 0}, var[2] = {0, 0};
    int n[2] = {0, 0};
    const std::vector<double> v = f.variance_of_mean();
    for (int y = 0; y < kRes; ++y)
      for (int x = 0; x < kRes; ++x) {
        if (x == 0 || x == kRes / 2 - 1 || x == kRes / 2 || x == kRes - 1) continue;
        const size_t i = size_t(y) * kRes + x;
        const int h = x < kRes / 2 ? 0 : 1;
        sum[h] += f.sum[3 * i] / f.count[i];
        var[h] += v[3 * i];
        ++n[h];
      }
    const int s = sum[0] < sum[1] ? 0 : 1;
    return {sum[s] / n[s], sum[1 - s] / n[1 - s], var[s] / (double(n[s]) * n[s])};
  }

  // The shadow's mean is `fraction` of the lit mean, by a z-test.
  void expect_shadow_fraction(const std::string& extra, double fraction) {
    const Halves h = halves(luz_test::render_finite(load(extra, 256)));
    const double lit_want = kAlbedo / M_PI * std::sqrt(0.5);
    EXPECT_NEAR(h.lit, lit_want, 1e-5) << "the lit half is not lit as the closed form says";
    const double want = fraction * h.lit;
    const double sd = std::sqrt(h.shadow_var + std::pow(luz_test::rounding_floor(want), 2));
    const double z = luz_test::sidak_z(1e-3, 1);
    std::printf("shadow/lit %.5f (want %.3f), |z| %.2f (threshold %.2f)\n", h.shadow / h.lit, fraction,
                std::fabs(h.shadow - want) / sd, z);
    EXPECT_LE(std::fabs(h.shadow - want), z * sd) << "shadow " << h.shadow << " vs " << want;
    EXPECT_GT(h.shadow_var, 0.0) << "test bug: a fractional shadow has variance";
  }
};

// Opacity 0 cuts the whole quad away for every ray: a quad across the view
// and the light (camera rays, shadow rays) changes no pixel.
TEST_F(Mask, FullyMaskedQuadIsInvisibleAndCastsNoShadow) {
  const std::string over = R"(<shape type="rectangle">
    <transform name="to_world"><scale x="1.5" y="1"/><translate x="-0.5" y="0.3" z="1"/></transform>)";
  Film base = luz_test::render_finite(load(""));
  Film cut = luz_test::render_finite(load(over + mask(R"(<float name="opacity" value="0"/>)") + "</shape>"));
  EXPECT_EQ(base.sum, cut.sum);
  // The same quad opaque is seen and casts its shadow (the test can fail).
  Film opaque = luz_test::render_finite(load(over + R"(<bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf></shape>)"));
  EXPECT_NE(base.sum, opaque.sum);
}

// A checkerboard opacity of 0 and 1 (4 periods across the quad's width):
// half of the shadow's area is open.
TEST_F(Mask, CheckerboardOpacityHalvesTheIrradiance) {
  expect_shadow_fraction(side_quad(mask(R"(<texture type="checkerboard" name="opacity">
      <rgb name="color0" value="0"/><rgb name="color1" value="1"/>
      <transform name="to_uv"><scale x="4" y="4"/></transform></texture>)")),
                         0.5);
}

// A fractional opacity, tested stochastically per ray, is unbiased.
TEST_F(Mask, FractionalOpacityTransmitsOneMinusOpacity) {
  expect_shadow_fraction(side_quad(mask(R"(<float name="opacity" value="0.3"/>)")), 0.7);
  // An opaque quad shadows the half entirely.
  const Halves h = halves(luz_test::render_finite(load(side_quad(R"(<bsdf type="diffuse"/>)"))));
  EXPECT_EQ(h.shadow, 0.0);
}

// Embree's filter function and the BVH's any-hit decide alike, hit for hit.
TEST_F(Mask, EmbreeFilterAgreesWithBvhAnyHit) {
  const std::string quads =
      side_quad(mask(R"(<texture type="checkerboard" name="opacity"><rgb name="color0" value="0.2"/><rgb name="color1" value="1"/>
        <transform name="to_uv"><scale x="5" y="3"/></transform></texture>)")) +
      R"(<shape type="rectangle"><transform name="to_world"><translate x="0.5" y="0" z="1"/></transform>)" +
      mask(R"(<float name="opacity" value="0.5"/>)") + "</shape>" +
      R"(<shape type="sphere"><point name="center" x="0" y="1" z="0.6"/><float name="radius" value="0.5"/>)" +
      mask(R"(<float name="opacity" value="0.4"/>)") + "</shape>";
  Scene s = load(quads);
  s.compile();
  const SceneView view = s.view();
  ASSERT_TRUE(view.materials.masked);
  EmbreeScene embree(s);
  const EmbreeTracer et = embree.tracer();
  const Bvh bvh = build_bvh(view);
  const BvhTracer bt = make_bvh_tracer(bvh, view);
  BvhTracer plain = bt;  // the same geometry opaque
  plain.geometry.opacity = {};
  constexpr int kRays = 200000;
  int hits = 0, cut = 0, differ = 0, occl_differ = 0;
  for (int k = 0; k < kRays; ++k) {
    auto u = [&](int d) { return to_unit_float(hash4(uint64_t(k), uint64_t(d), 7, 11)); };
    const Vec3 o{-5.f + 10.f * u(0), -4.f + 8.f * u(1), 3.f + 2.f * u(2)};
    const Vec3 target{-4.f + 6.f * u(3), -3.f + 6.f * u(4), 0.f};
    Ray r;
    r.o = o;
    r.d = normalize(target - o);
    r.tmax = u(5) < 0.5f ? kInfinity : 0.5f + 5.f * u(6);
    Hit he, hb;
    const bool ie = et.intersect(r, he), ib = bt.intersect(r, hb);
    if (ie != ib || (ie && (he.kind != hb.kind || he.prim != hb.prim || std::fabs(he.t - hb.t) > 1e-4f * he.t))) ++differ;
    occl_differ += et.occluded(r) != bt.occluded(r);
    hits += ie;
    // A ray whose opaque closest hit the masks cut away.
    Hit hp;
    cut += plain.intersect(r, hp) && (!ib || hb.kind != hp.kind || hb.prim != hp.prim);
  }
  std::printf("%d rays: %d hits (%d cut away), closest differ %d, occluded differ %d\n", kRays, hits, cut, differ,
              occl_differ);
  // Barycentrics from the two triangle tests differ by rounding: a hit within
  // an ulp of a checker edge may fall either way.
  EXPECT_LE(differ, kRays / 20000);
  EXPECT_LE(occl_differ, kRays / 20000);
  EXPECT_GT(cut, kRays / 20) << "test bug: rays must pass the masks";
}

TEST_F(Mask, BadMasksAreRefused) {
  auto expect_refused = [&](const std::string& extra, const std::string& problem) {
    luz_test::expect_load_refused(write("bad.xml", scene_xml(extra)), "bad.xml", problem);
  };
  expect_refused(side_quad(mask(R"(<float name="opacity" value="1.5"/>)")), "mask 'opacity' must lie in [0, 1]");
  expect_refused(side_quad(mask(R"(<float name="opacity" value="-0.1"/>)")), "mask 'opacity' must lie in [0, 1]");
  expect_refused(side_quad(mask(R"(<texture type="checkerboard" name="opacity"><rgb name="color1" value="2"/></texture>)")),
                 "mask 'opacity' texture has texels above 1");
  expect_refused(R"(<shape type="sphere"><float name="radius" value="0.5"/>)" +
                     mask(R"(<texture type="checkerboard" name="opacity"/>)") + R"(<emitter type="area"/></shape>)",
                 "a masked material on an emitting shape is not supported");
  expect_refused(side_quad(R"(<bsdf type="mask"><float name="opacity" value="0.5"/></bsdf>)"),
                 "mask needs exactly one nested bsdf");
  expect_refused(side_quad(R"(<bsdf type="mask"><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>)"),
                 "mask needs exactly one nested bsdf");
  expect_refused(side_quad(R"(<bsdf type="blendbsdf">)" + mask("") + R"(<bsdf type="diffuse"/></bsdf>)"),
                 "a mask inside a blendbsdf is not supported");
  expect_refused(side_quad(R"(<bsdf type="mask">)" + mask("") + "</bsdf>"), "a mask inside a mask is not supported");
  expect_refused(R"(<shape type="rectangle">)" + mask("") + R"(<emitter type="area"/></shape>)",
                 "a masked material on an emitting shape is not supported");
}

// Wrapping a twosided (one or two sides) or a blend is accepted; a
// one-sided mask inside a twosided too (one opacity for the surface).
TEST_F(Mask, MaskComposesWithTwosidedAndBlend) {
  const std::string half = R"(<float name="opacity" value="0.25"/>)";
  for (const std::string& bsdf :
       {R"(<bsdf type="mask">)" + half + R"(<bsdf type="twosided"><bsdf type="diffuse"/><bsdf type="conductor"/></bsdf></bsdf>)",
        R"(<bsdf type="mask">)" + half + R"(<bsdf type="blendbsdf"><bsdf type="diffuse"/><bsdf type="conductor"/></bsdf></bsdf>)",
        R"(<bsdf type="twosided">)" + mask(half) + "</bsdf>"}) {
    Scene s = load(side_quad(bsdf));
    ASSERT_EQ(s.materials.size(), 2u) << bsdf;
    EXPECT_EQ(s.materials[1].opacity, 0.25f) << bsdf;
    EXPECT_TRUE(s.materials[1].masked());
  }
}

}  // namespace
