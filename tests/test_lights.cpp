// Delta lights (light/point.h, spot.h, directional.h) against closed forms.
//
// A diffuse plane (albedo ρ) seen from above by a pinhole camera, lit by one
// delta light, rendered with direct light only (max_depth 2): each pixel is
// ρ/π · E averaged over its footprint, E the irradiance of the closed form:
//   point:        E = I cos θ / d²
//   spot:         E = I falloff(angle from the axis) cos θ / d² (Mitsuba's
//                 linear-in-angle falloff: 1 within beam_width, 0 beyond
//                 cutoff_angle)
//   directional:  E = E₀ cos θ
// The reference is a midpoint quadrature of that over each pixel (box
// filter), computed here in double from the camera's geometry; its error is
// estimated by halving the grid and added to the tolerance. The render's only
// randomness is the position within the pixel, so each pixel mean is compared
// by a z-test whose variance is that of the reference over the pixel (the
// quadrature gives it), Šidák-corrected over all pixels and channels, with a
// float-rounding floor (stat_helpers.h).
//
// Estimators: a delta light is found by next-event estimation only, so the
// path estimator (its light samples weighted 1: no MIS density) gives the
// same image as the light estimator, bit for bit, and the bsdf estimator a
// black one.
//
// A scene without a light (or whose lights are all black) renders, with a
// one-line warning that the image will be black.
//
// A spot's projected texture (a checkerboard over the cone's tangent plane,
// Mitsuba's direction_to_uv) against the same closed form times the texture.
//
// Textured area lights: a textured rectangle seen directly shows its texels
// (radiance, not reflectance: values above 1 too); lighting a diffuse plane,
// the NEE-only (light) and BSDF-only (bsdf) estimators agree per pixel within
// their error bars, so light samples read the texture where rays find it.
//
// Bad input: a cutoff_angle outside (0, 90], a beam_width above it, negative
// intensities, a position and a to_world together, textured emitters with
// negative texels (a sphere's too): one file:line error.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>

#include "luz/device/cpu/render.h"
#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "cli_helpers.h"
#include "geometry_helpers.h"
#include "scene_helpers.h"
#include "sphere_helpers.h"
#include "stat_helpers.h"
#include "temp_dir.h"

using namespace luz;

namespace {

constexpr int kRes = 32;
constexpr int kSpp = 64;
constexpr double kHeight = 4.0, kFovDeg = 60.0, kAlbedo = 0.5;
constexpr double kFamilyAlpha = 1e-3;

struct D3 {
  double x, y, z;
};
D3 operator-(D3 a, D3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
double dot(D3 a, D3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
double norm(D3 a) { return std::sqrt(dot(a, a)); }
D3 unit(D3 a) {
  double l = norm(a);
  return {a.x / l, a.y / l, a.z / l};
}

std::string scene_xml(const std::string& light, const std::string& integrator = "path") {
  return R"(<scene version="3.0.0">
  <integrator type=")" + integrator + R"("><integer name="max_depth" value="2"/></integrator>
  <sensor type="perspective">
    <float name="fov" value=")" + std::to_string(kFovDeg) + R"("/>
    <transform name="to_world"><lookat origin="0, 0, )" + std::to_string(kHeight) + R"(" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value=")" + std::to_string(kSpp) + R"("/></sampler>
    <film type="hdrfilm"><integer name="width" value=")" + std::to_string(kRes) + R"("/><integer name="height" value=")" +
         std::to_string(kRes) + R"("/><rfilter type="box"/></film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world"><scale value="10"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value=")" + std::to_string(kAlbedo) + R"("/></bsdf>
  </shape>
)" + light + "\n</scene>\n";
}

// The plane point (z = 0) seen at film position (fx, fy): the camera at
// height h looks down -z with +y up, so the image's left is world -x, its top
// world +y; the film spans tan(fov/2) on both axes (square image).
D3 plane_point(double fx, double fy) {
  const double t = std::tan(kFovDeg * M_PI / 360.0);
  const double sx = (2.0 * fx / kRes - 1.0) * t, sy = (1.0 - 2.0 * fy / kRes) * t;
  return {kHeight * sx, kHeight * sy, 0.0};
}

// Per-pixel radiance reference: the mean of ρ/π · E(P) over a k×k midpoint
// grid of the pixel, and the variance of that value over the pixel (what
// one sample's variance is, since the render's only randomness is where in
// the pixel the sample falls).
struct PixelRef {
  double mean = 0, var = 0;
};
PixelRef pixel_reference(const std::function<double(D3)>& irradiance, int x, int y, int k) {
  double acc = 0, acc2 = 0;
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      const double L = kAlbedo / M_PI * irradiance(plane_point(x + (i + 0.5) / k, y + (j + 0.5) / k));
      acc += L;
      acc2 += L * L;
    }
  const double n = double(k) * k, mean = acc / n;
  return {mean, std::max(0.0, acc2 / n - mean * mean)};
}

class Lights : public TempDirTest {
 protected:
  Scene load(const std::string& light, const std::string& integrator = "path") {
    return load_scene(write("scene.xml", scene_xml(light, integrator)));
  }
  static Film render(const Scene& s) { return luz_test::render_finite(s); }
  // The means of 4×4-pixel blocks (8×8 of them, per channel) and their variances.
  static void block_means(const Film& f, std::vector<double>& mean, std::vector<double>& var) {
    const std::vector<double> m = luz_test::pixel_means(f), v = f.variance_of_mean();
    mean.assign(64 * 3, 0.0), var.assign(64 * 3, 0.0);
    for (int y = 0; y < kRes; ++y)
      for (int x = 0; x < kRes; ++x)
        for (int c = 0; c < 3; ++c) {
          const size_t k = 3 * (size_t(y) * kRes + x) + c, b = 3 * (size_t(y / 4) * 8 + x / 4) + c;
          mean[b] += m[k] / 16, var[b] += v[k] / 256;
        }
  }

  // `light` above the floor: light samples (NEE only) and BSDF samples
  // (emission found by rays only) agree per 4×4-pixel block at 256 spp
  // within their error bars (Šidák over the blocks), and more than
  // `min_lit` block channels are lit. hide_emitters: the camera sees the
  // floor lit, not the light itself.
  void expect_light_matches_bsdf(const std::string& light, bool hide_emitters, const char* what, int min_lit) {
    auto blocks = [&](const std::string& integrator, std::vector<double>& mean, std::vector<double>& var) {
      Scene s = load(light, integrator);
      s.settings.spp = 256;
      s.settings.integrator.hide_emitters = hide_emitters;
      const Film f = render(s);
      block_means(f, mean, var);
    };
    std::vector<double> m1, v1, m2, v2;
    blocks("light", m1, v1);
    blocks("bsdf", m2, v2);
    const double z = luz_test::sidak_z(kFamilyAlpha, double(m1.size()));
    double worst = 0;
    int lit = 0;
    for (size_t k = 0; k < m1.size(); ++k) {
      lit += m1[k] > 0.0;  // blocks of an emitter's black back are 0 in both
      const double sd = std::sqrt(v1[k] + v2[k]) + luz_test::rounding_floor(m1[k]);
      worst = std::max(worst, std::fabs(m1[k] - m2[k]) / sd);
    }
    std::printf("%s, light vs bsdf over 64 blocks: worst |z| %.2f (threshold %.2f), %d of 192 lit\n", what, worst, z, lit);
    EXPECT_LE(worst, z);
    EXPECT_GT(lit, min_lit);
  }

  // Every pixel and channel against the quadrature of E · rgb[c].
  void expect_closed_form(const std::string& light, const std::function<double(D3)>& irradiance, const double rgb[3]) {
    Scene s = load(light);
    ASSERT_EQ(s.camera.width, kRes);
    Film f = render(s);
    const double z = luz_test::sidak_z(kFamilyAlpha, 3.0 * kRes * kRes);
    double worst = 0;
    int lit = 0;
    for (int y = 0; y < kRes; ++y)
      for (int x = 0; x < kRes; ++x) {
        const PixelRef fine = pixel_reference(irradiance, x, y, 32), coarse = pixel_reference(irradiance, x, y, 16);
        const size_t i = size_t(y) * kRes + x;
        const double n = f.count[i];
        ASSERT_EQ(n, kSpp);
        lit += fine.mean > 0;
        for (int c = 0; c < 3; ++c) {
          const double want = fine.mean * rgb[c], quad_err = std::fabs(fine.mean - coarse.mean) * rgb[c];
          const double mean = f.sum[3 * i + c] / n;
          // The pixel mean's standard deviation, known from the reference
          // (a sample variance can be 0 where a sliver of the pixel is lit).
          const double var = std::max(fine.var, coarse.var) * rgb[c] * rgb[c];
          const double sd = std::sqrt(var / n + std::pow(luz_test::rounding_floor(want), 2));
          const double excess = std::fabs(mean - want) - quad_err;
          worst = std::max(worst, excess / sd);
          ASSERT_LE(excess, z * sd) << "pixel " << x << "," << y << " channel " << c << ": " << mean << " vs "
                                    << want << " (quadrature error " << quad_err << ")";
        }
      }
    std::printf("worst |z| %.2f (threshold %.2f), %d of %d pixels lit\n", worst, z, lit, kRes * kRes);
    EXPECT_GT(lit, kRes * kRes / 8) << "test bug: the light must reach a good part of the view";
  }
};

TEST_F(Lights, PointLightMatchesInverseSquareLaw) {
  const D3 pos{0.7, -0.4, 1.5};
  const double rgb[3] = {2, 3, 4};
  expect_closed_form(R"(<emitter type="point"><point name="position" x="0.7" y="-0.4" z="1.5"/>
    <rgb name="intensity" value="2, 3, 4"/></emitter>)",
                     [&](D3 p) {
                       const D3 d = pos - p;
                       const double r = norm(d);
                       return d.z / r / (r * r);  // cos θ / d², intensity per channel in rgb
                     },
                     rgb);
  // Placed by to_world instead of position: the same light.
  expect_closed_form(R"(<emitter type="point"><transform name="to_world"><translate x="0.7" y="-0.4" z="1.5"/></transform>
    <rgb name="intensity" value="2, 3, 4"/></emitter>)",
                     [&](D3 p) {
                       const D3 d = pos - p;
                       const double r = norm(d);
                       return d.z / r / (r * r);
                     },
                     rgb);
}

TEST_F(Lights, SpotLightMatchesItsFalloff) {
  const D3 pos{-0.5, 0.3, 2.0}, target{0.3, -0.2, 0.0};
  const D3 axis = unit(target - pos);
  const double cutoff = 25.0 * M_PI / 180.0, beam = 15.0 * M_PI / 180.0;
  const double rgb[3] = {5, 5, 2};
  expect_closed_form(R"(<emitter type="spot">
    <transform name="to_world"><lookat origin="-0.5, 0.3, 2" target="0.3, -0.2, 0" up="0, 1, 0"/></transform>
    <float name="cutoff_angle" value="25"/><float name="beam_width" value="15"/>
    <rgb name="intensity" value="5, 5, 2"/></emitter>)",
                     [&](D3 p) {
                       const D3 d = pos - p;
                       const double r = norm(d);
                       const D3 out = unit(p - pos);
                       const double theta = std::acos(std::min(1.0, dot(out, axis)));
                       const double fall = theta <= beam ? 1.0 : theta < cutoff ? (cutoff - theta) / (cutoff - beam) : 0.0;
                       return fall * d.z / r / (r * r);
                     },
                     rgb);
}

// The three falloffs between beam and cutoff, from the formats' own
// definitions in double: Mitsuba's linear in θ (rendered above), pbrt-v4's
// smoothstep in cos θ (SpotLight::I), glTF's squared linear ramp in cos θ
// (KHR_lights_punctual's sample code); full inside the beam, 0 beyond the
// cutoff. Rendering reads falloff() alike for all three.
TEST(SpotFalloff, EachFormatsCurve) {
  const double cutoff = 40 * M_PI / 180, beam = 15 * M_PI / 180;
  const double cc = std::cos(cutoff), cb = std::cos(beam);
  for (SpotFalloff kind : {SpotFalloff::LinearAngle, SpotFalloff::SmoothstepCos, SpotFalloff::SquaredRampCos}) {
    SpotLight l;
    l.set_cone(cutoff, beam, kind);
    double worst = 0, inside = 0;
    for (int i = 0; i <= 1000; ++i) {
      const double th = (cutoff + 0.1) * i / 1000;
      const double t = std::clamp((std::cos(th) - cc) / (cb - cc), 0.0, 1.0);
      double want = kind == SpotFalloff::LinearAngle   ? std::clamp((cutoff - th) / (cutoff - beam), 0.0, 1.0)
                    : kind == SpotFalloff::SmoothstepCos ? t * t * (3 - 2 * t)
                                                         : t * t;
      const float got = l.falloff({float(3 * std::sin(th)), 0.f, float(3 * std::cos(th))});
      // Within float rounding of θ away from the two edges.
      if (std::fabs(th - cutoff) > 1e-5 && std::fabs(th - beam) > 1e-5) worst = std::max(worst, std::fabs(got - want));
      if (th > beam && th < cutoff) inside += want;
    }
    EXPECT_LT(worst, 2e-5) << int(kind);
    EXPECT_GT(inside, 10.0) << "test bug: the ramp must be sampled";
  }
  // Different curves: at the middle of the angles, 0.5, 0.655 and 0.366.
  const double mid = 0.5 * (cutoff + beam);
  const Vec3 d{float(std::sin(mid)), 0.f, float(std::cos(mid))};
  SpotLight a, b, c;
  a.set_cone(cutoff, beam, SpotFalloff::LinearAngle);
  b.set_cone(cutoff, beam, SpotFalloff::SmoothstepCos);
  c.set_cone(cutoff, beam, SpotFalloff::SquaredRampCos);
  EXPECT_NEAR(a.falloff(d), 0.5f, 1e-5f);
  EXPECT_NEAR(b.falloff(d), 0.6555f, 1e-4f);
  EXPECT_NEAR(c.falloff(d), 0.3663f, 1e-4f);
}

TEST_F(Lights, DirectionalLightGivesCosineIrradiance) {
  const D3 dir = unit({0.3, -0.2, -1.0});
  const double rgb[3] = {1, 2, 0.5};
  expect_closed_form(R"(<emitter type="directional"><vector name="direction" x="0.3" y="-0.2" z="-1"/>
    <rgb name="irradiance" value="1, 2, 0.5"/></emitter>)",
                     [&](D3) { return -dir.z; }, rgb);
}

// NEE alone finds a delta light: path equals light bit for bit, bsdf is black.
TEST_F(Lights, OnlyNextEventEstimationSeesDeltaLights) {
  const std::string spot = R"(<emitter type="spot"><transform name="to_world"><lookat origin="0, 0, 2" target="0, 0, 0" up="0, 1, 0"/></transform>
    <rgb name="intensity" value="3"/></emitter>)";
  for (const std::string& light : {spot, std::string(R"(<emitter type="point"><point name="position" x="0" y="0" z="1"/></emitter>)")}) {
    Film path = render(load(light, "path")), nee = render(load(light, "light")), bsdf = render(load(light, "bsdf"));
    EXPECT_EQ(path.sum, nee.sum);
    double total = 0;
    for (double v : path.sum) total += v;
    EXPECT_GT(total, 0.0);
    for (double v : bsdf.sum) ASSERT_EQ(v, 0.0);
  }
}

TEST_F(Lights, BadDeltaLightsAreRefused) {
  auto expect_refused = [&](const std::string& light, const std::string& problem) {
    luz_test::expect_load_refused(write("bad.xml", scene_xml(light)), "bad.xml", problem);
  };
  expect_refused(R"(<emitter type="spot"><float name="cutoff_angle" value="0"/></emitter>)", "cutoff_angle must be in (0, 90]");
  expect_refused(R"(<emitter type="spot"><float name="cutoff_angle" value="95"/></emitter>)", "cutoff_angle must be in (0, 90]");
  expect_refused(R"(<emitter type="spot"><float name="cutoff_angle" value="20"/><float name="beam_width" value="30"/></emitter>)",
                 "beam_width must be in (0, cutoff_angle]");
  expect_refused(R"(<emitter type="spot"><rgb name="intensity" value="1, -1, 1"/></emitter>)", "intensity must be finite and not negative");
  expect_refused(R"(<emitter type="point"><float name="intensity" value="-2"/></emitter>)", "intensity must be finite and not negative");
  expect_refused(R"(<emitter type="directional"><rgb name="irradiance" value="-1"/></emitter>)", "irradiance must be finite and not negative");
  expect_refused(R"(<emitter type="point"><point name="position" x="0" y="0" z="1"/><transform name="to_world"><translate x="1"/></transform></emitter>)",
                 "either 'position' or 'to_world'");
  expect_refused(R"(<emitter type="directional"><vector name="direction" x="0" y="0" z="0"/></emitter>)", "direction is zero");
  expect_refused(R"(<emitter type="point"><point name="position" x="0" y="0" z="1e30"/></emitter>)", "beyond 1e18");
  expect_refused(R"(<emitter type="point"><float name="radius" value="1"/></emitter>)", "unknown parameter 'radius'");
  expect_refused(R"(<emitter type="sunsky"/>)", "unknown top-level emitter 'sunsky'");
  expect_refused(R"(<emitter type="spot"><rgb name="texture" value="0.5"/></emitter>)",
                 "parameter 'texture' has the wrong type <rgb>");
}

// The spot of SpotLightMatchesItsFalloff straight down with a projected
// checkerboard (values 0.9 and 0.2, three squares per unit of uv): Mitsuba's
// lookat frame has light-space x = up × axis = -x (world), y = +y, so the
// plane point p is at uv = 1/2 + (-p.x, p.y) / (2 h tan(cutoff)).
TEST_F(Lights, SpotLightProjectsItsTexture) {
  const double h = 2.0, cutoff = 35.0 * M_PI / 180.0;
  const double rgb[3] = {4, 4, 4};
  auto checker = [](double u, double v) {
    const bool a = 3 * u - std::floor(3 * u) > 0.5, b = 3 * v - std::floor(3 * v) > 0.5;
    return a != b ? 0.9 : 0.2;
  };
  expect_closed_form(R"(<emitter type="spot">
    <transform name="to_world"><lookat origin="0, 0, 2" target="0, 0, 0" up="0, 1, 0"/></transform>
    <float name="cutoff_angle" value="35"/><float name="beam_width" value="35"/>
    <texture type="checkerboard" name="texture"><float name="color0" value="0.9"/><float name="color1" value="0.2"/>
      <transform name="to_uv"><scale x="3" y="3"/></transform></texture>
    <rgb name="intensity" value="4"/></emitter>)",
                     [&](D3 p) {
                       const D3 d = D3{0, 0, h} - p;
                       const double r = norm(d);
                       if (d.z / r <= std::cos(cutoff)) return 0.0;
                       const double k = 0.5 / (h * std::tan(cutoff));
                       return checker(0.5 - p.x * k, 0.5 + p.y * k) * d.z / r / (r * r);
                     },
                     rgb);
}

// A 4×4 float texture as the radiance of a rectangle (x, y in [-1, 1]) that
// fills a 16×16 view square-on: every pixel lies within one texel and sees
// its value exactly (Mitsuba's rectangle uv = ((x + 1) / 2, (y + 1) / 2),
// texel row 0 at v = 0); the mirrored texture does not match.
TEST_F(Lights, TexturedAreaLightShowsItsTexels) {
  Image tex;
  tex.width = tex.height = 4;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i)
      for (float c : {0.5f + 0.75f * float(i), 0.2f + 1.5f * float(j), 3.f - 0.15f * float(4 * j + i)}) tex.rgb.push_back(c);
  write_image((dir / "glow.pfm").string(), tex);
  const double fov = 2.0 * std::atan(0.2) * 180.0 / M_PI;  // the camera at z = 5 sees x, y in [-1, 1]
  char fov_text[64];
  std::snprintf(fov_text, sizeof fov_text, "%.17g", fov);
  const Scene s = load_scene(write(
      "glow.xml", std::string(R"(<scene version="3.0.0"><integrator type="path"/><sensor type="perspective">)") +
                      "<float name=\"fov\" value=\"" + fov_text + "\"/>" +
                      R"(<transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
      <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
      <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film>
      </sensor><shape type="rectangle"><bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
      <emitter type="area"><texture type="bitmap" name="radiance"><string name="filename" value="glow.pfm"/>
      <string name="filter_type" value="nearest"/></texture></emitter></shape></scene>)"));
  ASSERT_EQ(s.lights.size(), 2u) << "a textured quad stays two triangle lights";
  Film f = render(s);
  int mismatched_mirror = 0;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      Ray r = s.camera.generate_ray(x + 0.5f, y + 0.5f);
      const double t = -r.o.z / r.d.z, px = r.o.x + t * r.d.x, py = r.o.y + t * r.d.y;
      const int i = int(std::floor((px + 1) / 2 * 4)), j = int(std::floor((py + 1) / 2 * 4));
      ASSERT_TRUE(i >= 0 && i < 4 && j >= 0 && j < 4);
      for (int c = 0; c < 3; ++c) {
        const size_t k = 3 * (size_t(y) * 16 + x) + c;
        const double mean = f.sum[k] / f.count[size_t(y) * 16 + x];
        const double want = tex.rgb[3 * (size_t(j) * 4 + i) + c];
        ASSERT_NEAR(mean, want, 1e-5 * want) << x << "," << y << " channel " << c;
        mismatched_mirror += std::fabs(mean - tex.rgb[3 * (size_t(3 - j) * 4 + i) + c]) > 1e-3;
      }
    }
  EXPECT_GT(mismatched_mirror, 384) << "the test cannot tell the texture from its mirror image";
}

// The textured rectangle above a diffuse floor: light samples (NEE only) and
// BSDF samples (emission found by rays only) must agree. Compared over 4×4
// pixel blocks at 256 spp: far from the light the BSDF estimator's pixels
// are mostly 0 with rare hits, and a per-pixel sample variance would be
// unreliable there.
TEST_F(Lights, TexturedAreaLightAgreesAcrossEstimators) {
  Image tex;
  tex.width = 3, tex.height = 2;
  tex.rgb = {8, 0.5f, 0.5f, 0.2f, 6, 0.2f, 1, 1, 1, 0.1f, 0.1f, 9, 4, 4, 0, 0, 0.3f, 3};
  write_image((dir / "glow.pfm").string(), tex);
  const std::string light = R"(<shape type="rectangle">
    <transform name="to_world"><scale x="1.5" y="1"/><rotate x="1" angle="180"/><translate z="1.2"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
    <emitter type="area"><texture type="bitmap" name="radiance"><string name="filename" value="glow.pfm"/></texture></emitter>
  </shape>)";
  expect_light_matches_bsdf(light, false, "textured area light", 100);
}

// A textured sphere light (Mitsuba 3's uv: (φ / 2π, θ / π) in the object
// space of to_world · translate(center) · scale(radius)): a W×H float
// bitmap, nearest texels, and a rotated to_world. The texel a point shows,
// in closed form (sphere_helpers.h).
struct TexturedSphere {
  static constexpr int kW = 8, kH = 4;
  Image tex;
  luz_test::Affine object_to_world;
  std::string xml;

  TexturedSphere(const std::string& file, luz_test::Dvec center, double radius, bool nearest) {
    tex.width = kW, tex.height = kH;
    for (int j = 0; j < kH; ++j)
      for (int i = 0; i < kW; ++i)
        for (float c : {0.3f + 1.1f * float(i % 4), 0.2f + 2.5f * float(j), 6.5f - 0.6f * float(i) - 0.4f * float(j)})
          tex.rgb.push_back(c);
    const luz_test::Affine to_world =
        luz_test::Affine::translate(center) * luz_test::Affine::rotate({1, -0.5, 0.3}, 70);
    object_to_world = to_world * luz_test::Affine::scale({radius, radius, radius});
    xml = "<shape type=\"sphere\"><float name=\"radius\" value=\"" + std::to_string(radius) + "\"/>" +
          to_world.mitsuba() + R"(<bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
      <emitter type="area"><texture type="bitmap" name="radiance"><string name="filename" value=")" + file + "\"/>" +
          (nearest ? R"(<string name="filter_type" value="nearest"/>)" : "") + "</texture></emitter></shape>";
  }
  // The texel (i, j) at the world point p of the sphere; `mirror`: v → 1 - v.
  void texel(luz_test::Dvec p, int& i, int& j, bool mirror = false) const {
    const luz_test::Dvec c = object_to_world.point({});
    luz_test::Dvec w = p - c, l;
    // The object-space direction: the inverse of the rotation (orthonormal columns).
    const luz_test::Dvec ex = luz_test::unit(object_to_world.vector({1, 0, 0})),
                         ey = luz_test::unit(object_to_world.vector({0, 1, 0})),
                         ez = luz_test::unit(object_to_world.vector({0, 0, 1}));
    l = luz_test::unit({dot(w, ex), dot(w, ey), dot(w, ez)});
    const luz_test::Duv uv = luz_test::mitsuba_sphere_uv(l);
    i = std::min(kW - 1, int(std::floor(uv.u * kW)));
    j = std::min(kH - 1, int(std::floor((mirror ? 1.0 - uv.v : uv.v) * kH)));
  }
  double value(int i, int j, int c) const { return tex.rgb[3 * (size_t(j) * kW + i) + c]; }
};

// The sphere seen directly fills much of a 32×32 view: a pixel whose whole
// footprint (a 5×5 grid of its film positions, edges included) finds the
// sphere in one texel shows that texel's radiance exactly; the texture with
// v mirrored does not match.
TEST_F(Lights, TexturedSphereLightShowsItsTexels) {
  const TexturedSphere sphere("glow.pfm", {0.1, -0.05, 0}, 1.0, true);
  write_image((dir / "glow.pfm").string(), sphere.tex);
  const Scene s = load_scene(write("glow.xml", R"(<scene version="3.0.0"><integrator type="path"/>
    <sensor type="perspective"><float name="fov" value="30"/>
      <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
      <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
      <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/><rfilter type="box"/></film>
    </sensor>)" + sphere.xml + "</scene>"));
  ASSERT_EQ(s.lights.size(), 1u);
  ASSERT_EQ(s.lights[0].type, LightType::Sphere);
  Film f = render(s);
  const luz_test::Dvec c = sphere.object_to_world.point({});
  int checked = 0, mismatched_mirror = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      int ti = -1, tj = -1, mi = -1, mj = -1;
      bool one_texel = true;
      for (int b = 0; b <= 4 && one_texel; ++b)
        for (int a = 0; a <= 4 && one_texel; ++a) {
          const Ray r = s.camera.generate_ray(x + 0.25f * float(a), y + 0.25f * float(b));
          const luz_test::Dvec o = luz_test::dvec(r.o), d = luz_test::unit(luz_test::dvec(r.d)), oc = o - c;
          const double bq = dot(oc, d), disc = bq * bq - (dot(oc, oc) - 1.0);
          if (!(disc > 1e-3)) {
            one_texel = false;  // misses or grazes the sphere
            break;
          }
          int i, j, i2, j2;
          sphere.texel(o + (-bq - std::sqrt(disc)) * d, i, j);
          sphere.texel(o + (-bq - std::sqrt(disc)) * d, i2, j2, true);
          if (ti < 0) ti = i, tj = j, mi = i2, mj = j2;
          one_texel = i == ti && j == tj;
        }
      if (!one_texel) continue;
      ++checked;
      const size_t px = size_t(y) * 32 + x;
      for (int ch = 0; ch < 3; ++ch) {
        const double mean = f.sum[3 * px + ch] / f.count[px], want = sphere.value(ti, tj, ch);
        ASSERT_NEAR(mean, want, 1e-5 * want) << x << "," << y << " channel " << ch << " texel " << ti << "," << tj;
        mismatched_mirror += std::fabs(mean - sphere.value(mi, mj, ch)) > 1e-3;
      }
    }
  std::printf("%d pixels within one texel of the sphere, %d channels unlike the mirrored texture\n", checked,
              mismatched_mirror);
  EXPECT_GT(checked, 200) << "test bug: too few pixels see one texel";
  EXPECT_GT(mismatched_mirror, checked) << "the test cannot tell the texture from its mirror image";
}

// The textured sphere light above the diffuse floor: NEE only (sample_li's
// texel) and BSDF samples only (eval at the hit's uv) agree per 4×4-pixel
// block within their error bars, as for the rectangle above. Bilinear
// texels: a smooth texture, the same for both.
TEST_F(Lights, TexturedSphereLightAgreesAcrossEstimators) {
  const TexturedSphere sphere("glow.pfm", {0.2, -0.3, 1.0}, 0.5, false);
  write_image((dir / "glow.pfm").string(), sphere.tex);
  expect_light_matches_bsdf(sphere.xml, true, "textured sphere light", 150);
}

// Emitted rays (sample_le, light paths) start with the texel of their
// origin, as eval gives at that point's uv.
TEST_F(Lights, TexturedSphereLightEmitsItsTexels) {
  const TexturedSphere sphere("glow.pfm", {0.2, -0.3, 1.0}, 0.5, true);
  write_image((dir / "glow.pfm").string(), sphere.tex);
  const Scene s = load(sphere.xml);
  const SceneView v = s.view();
  luz_test::Rng rng(5);
  for (int k = 0; k < 200; ++k) {
    const LightLeSample ls = sample_le(v.lights[0], {rng.uniform(), rng.uniform()}, {rng.uniform(), rng.uniform()},
                                       v.lights.data, v.bounds_center, v.bounds_radius);
    ASSERT_GT(ls.pdf_pos, 0.f);
    int i, j;
    sphere.texel(luz_test::dvec(ls.p), i, j);
    for (int ch = 0; ch < 3; ++ch) ASSERT_NEAR(ls.radiance[ch], sphere.value(i, j, ch), 1e-5 * sphere.value(i, j, ch)) << k;
  }
}

// A two-sided rectangle (pbrt-v4's twosided area lights) turned away from
// the floor lights it with its back alone: by light samples, by BSDF samples
// and by both with MIS alike, and as the same rectangle turned toward the
// floor one-sided does. 4×4-pixel blocks at 256 spp, each pair within a
// noise-derived bound (Šidák over the blocks and the three comparisons).
TEST_F(Lights, TwoSidedAreaLightLightsWithItsBack) {
  auto rect = [](bool toward_floor) {
    return std::string(R"(<shape type="rectangle"><transform name="to_world"><scale x="1.5" y="1"/>)") +
           (toward_floor ? R"(<rotate x="1" angle="180"/>)" : "") +
           R"(<translate z="1.2"/></transform><bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
           <emitter type="area"><rgb name="radiance" value="3, 2, 1"/></emitter></shape>)";
  };
  auto blocks = [&](bool toward_floor, bool two_sided, const std::string& integrator, std::vector<double>& mean,
                    std::vector<double>& var) {
    Scene s = load(rect(toward_floor), integrator);
    ASSERT_EQ(s.lights.size(), 1u);
    ASSERT_EQ(s.lights[0].type, LightType::Parallelogram);
    s.lights[0].parallelogram.two_sided = two_sided;
    s.compile();
    s.settings.spp = 256;
    s.settings.integrator.hide_emitters = true;  // the camera sees the floor lit, not the light's own sides
    const Film f = render(s);
    block_means(f, mean, var);
  };
  std::vector<double> front_m, front_v, back_m, back_v, light_m, light_v, bsdf_m, bsdf_v;
  blocks(true, false, "path", front_m, front_v);
  blocks(false, true, "path", back_m, back_v);
  blocks(false, true, "light", light_m, light_v);
  blocks(false, true, "bsdf", bsdf_m, bsdf_v);
  const double z = luz_test::sidak_z(kFamilyAlpha, 3.0 * double(front_m.size()));
  auto worst_z = [&](const std::vector<double>& m1, const std::vector<double>& v1, const std::vector<double>& m2,
                     const std::vector<double>& v2) {
    double worst = 0;
    for (size_t k = 0; k < m1.size(); ++k)
      worst = std::max(worst, std::fabs(m1[k] - m2[k]) / (std::sqrt(v1[k] + v2[k]) + luz_test::rounding_floor(m1[k])));
    return worst;
  };
  const double a = worst_z(back_m, back_v, front_m, front_v), b = worst_z(light_m, light_v, bsdf_m, bsdf_v),
               c = worst_z(back_m, back_v, light_m, light_v);
  int lit = 0;
  for (double m : back_m) lit += m > 0.0;
  std::printf("two-sided light's back: worst |z| vs one-sided front %.2f, light vs bsdf %.2f, mis vs light %.2f "
              "(threshold %.2f), %d of 192 lit\n", a, b, c, z, lit);
  EXPECT_LE(a, z);
  EXPECT_LE(b, z);
  EXPECT_LE(c, z);
  EXPECT_GT(lit, 100);  // the light itself hides 24 of the 64 blocks
  // One-sided, the same rectangle turned away leaves the floor dark.
  blocks(false, false, "path", back_m, back_v);
  EXPECT_EQ(*std::max_element(back_m.begin(), back_m.end()), 0.0);
}

TEST_F(Lights, BadTexturedEmittersAreRefused) {
  Image tex;
  tex.width = 2, tex.height = 1;
  tex.rgb = {1, 1, 1, 1, -1, 1};
  write_image((dir / "neg.pfm").string(), tex);
  auto expect_refused = [&](const std::string& light, const std::string& problem) {
    luz_test::expect_load_refused(write("bad.xml", scene_xml(light)), "bad.xml", problem);
  };
  expect_refused(R"(<shape type="sphere"><emitter type="area"><texture type="bitmap" name="radiance">
    <string name="filename" value="neg.pfm"/></texture></emitter></shape>)", "texel (1, 0) is negative or not finite");
  expect_refused(R"(<shape type="rectangle"><emitter type="area"><texture type="bitmap" name="radiance">
    <string name="filename" value="neg.pfm"/></texture></emitter></shape>)", "texel (1, 0) is negative or not finite");
  expect_refused(R"(<emitter type="spot"><texture type="bitmap" name="texture"><string name="filename" value="none.png"/>
    </texture></emitter>)", "no such file");
}

class LightsCli : public luz_test::LuzCliTest {};

TEST_F(LightsCli, NoLightWarnsThatTheImageWillBeBlack) {
  for (const std::string& light : {std::string(""), std::string(R"(<emitter type="point"><rgb name="intensity" value="0"/></emitter>)")}) {
    write("dark.xml", scene_xml(light));
    luz_test::CliResult r = run({"render", "dark.xml", "-o", "dark.pfm", "--threads", "1", "--spp", "1"});
    EXPECT_TRUE(r.exited && r.status == 0) << r.err;
    EXPECT_NE(r.err.find("warning: dark.xml: the scene has no light that emits, so the image will be black"), std::string::npos)
        << r.err;
    EXPECT_TRUE(std::filesystem::exists(dir / "dark.pfm"));
  }
  write("lit.xml", scene_xml(R"(<emitter type="point"><point name="position" x="0" y="0" z="1"/></emitter>)"));
  luz_test::CliResult r = run({"render", "lit.xml", "-o", "lit.pfm", "--threads", "1", "--spp", "1"});
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err.find("no light"), std::string::npos) << r.err;
}

}  // namespace
