// The auxiliary layers (render/aov.h), against closed forms:
//  * albedo of a Lambertian plane filling the view: its reflectance at every
//    pixel (the BSDF sample's weight is ρ exactly); depth: the plane's
//    distance along the view axis at every pixel; normal: the plane's.
//  * normals of a sphere: at every pixel whose footprint lies inside the
//    silhouette, the analytic normal where the pixel's centre ray meets it,
//    within the spread of normals over the pixel's footprint; pixels off the
//    sphere: no normal, no albedo, infinite depth.
//  * luz render --aov: the layers are channels of the OpenEXR output.
#include <ImfChannelList.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <gtest/gtest.h>

#include <cmath>

#include "cli_helpers.h"
#include "luz/io/load.h"
#include "luz/render/aov.h"
#include "temp_dir.h"

namespace {

using namespace luz;

// A camera on the z axis at `z` looking at the origin (fov 30°), a w × h
// film, `shape`, and a constant sky.
std::string scene(int z, int w, int h, const std::string& shape) {
  return R"(<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="30"/>
    <transform name="to_world"><lookat origin="0, 0, )" + std::to_string(z) + R"(" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
    <film type="hdrfilm"><integer name="width" value=")" + std::to_string(w) + R"("/><integer name="height" value=")" +
         std::to_string(h) + R"("/><rfilter type="box"/></film>
  </sensor>
  )" + shape + R"(
  <emitter type="constant"/>
</scene>)";
}

const std::string kPlane = scene(3, 12, 10, R"(<shape type="rectangle">
    <transform name="to_world"><scale value="10"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.4, 0.6"/></bsdf>
  </shape>)");

const std::string kSphere = scene(5, 32, 32, R"(<shape type="sphere">
    <float name="radius" value="1"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf>
  </shape>)");

class Aov : public TempDirTest {};

TEST_F(Aov, LambertianPlaneAlbedoDepthAndNormal) {
  const Scene s = load_scene(write("plane.xml", kPlane));
  const AovImages a = render_aovs(s, 4, 8, 2);
  ASSERT_EQ(a.width, 12);
  ASSERT_EQ(a.height, 10);
  for (size_t i = 0; i < size_t(12 * 10); ++i) {
    EXPECT_NEAR(a.albedo[3 * i], 0.2f, 1e-6f);
    EXPECT_NEAR(a.albedo[3 * i + 1], 0.4f, 1e-6f);
    EXPECT_NEAR(a.albedo[3 * i + 2], 0.6f, 1e-6f);
    EXPECT_NEAR(a.depth[i], 3.f, 1e-5f);
    EXPECT_NEAR(a.normal[3 * i], 0.f, 1e-6f);
    EXPECT_NEAR(a.normal[3 * i + 1], 0.f, 1e-6f);
    EXPECT_NEAR(a.normal[3 * i + 2], 1.f, 1e-6f);
  }
}

TEST_F(Aov, SphereNormals) {
  const Scene s = load_scene(write("sphere.xml", kSphere));
  const AovImages a = render_aovs(s, 4, 1, 2);
  const Camera& cam = s.camera;
  int inside = 0, outside = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      const size_t i = size_t(y) * 32 + size_t(x);
      // The pixel's corners: all on the sphere, or all off it?
      auto hits = [&](float fx, float fy, Vec3* n) {
        const Ray r = cam.generate_ray(fx, fy);
        const float b = dot(r.o, r.d), c = dot(r.o, r.o) - 1.f, disc = b * b - c;
        if (disc < 0.f) return false;
        if (n) *n = normalize(r.o + r.d * (-b - std::sqrt(disc)));
        return true;
      };
      int corners = 0;
      for (float cx : {0.f, 1.f})
        for (float cy : {0.f, 1.f}) corners += hits(float(x) + cx, float(y) + cy, nullptr);
      if (corners == 4) {
        ++inside;
        Vec3 n;
        hits(float(x) + 0.5f, float(y) + 0.5f, &n);
        // The mean of unit normals over the footprint lies within the
        // footprint's spread of the centre's (its corners', with a margin
        // for the edges' curvature).
        float spread = 0.f;
        for (float cx : {0.f, 1.f})
          for (float cy : {0.f, 1.f}) {
            Vec3 c;
            hits(float(x) + cx, float(y) + cy, &c);
            spread = std::max(spread, 1.1f * length(c - n));
          }
        const Vec3 got{a.normal[3 * i], a.normal[3 * i + 1], a.normal[3 * i + 2]};
        EXPECT_LE(length(got - n), spread) << x << "," << y;
        EXPECT_GT(a.depth[i], 3.99f - 1e-4f);
        EXPECT_LT(a.depth[i], 5.f);
        EXPECT_NEAR(a.albedo[3 * i], 0.5f, 1e-6f);
      } else if (corners == 0 && !hits(float(x) + 0.5f, float(y) + 0.5f, nullptr)) {
        ++outside;
        EXPECT_EQ(a.normal[3 * i] * a.normal[3 * i] + a.normal[3 * i + 2] * a.normal[3 * i + 2], 0.f);
        EXPECT_EQ(a.albedo[3 * i + 1], 0.f);
        EXPECT_TRUE(std::isinf(a.depth[i]));
      }
    }
  EXPECT_GT(inside, 100);
  EXPECT_GT(outside, 100);
}

using AovCli = luz_test::LuzCliTest;

TEST_F(AovCli, LayersAreChannelsOfTheExr) {
  write("plane.xml", kPlane);
  luz_test::CliResult r = run({"render", "plane.xml", "--aov", "albedo,normal,depth,variance", "-o", "out.exr", "-o", "out.png"});
  ASSERT_EQ(r.status, 0) << r.err;
  Imf::InputFile f((dir / "out.exr").c_str());
  for (const char* c : {"R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y", "normal.Z", "depth.Z",
                        "variance.R", "variance.G", "variance.B"})
    EXPECT_NE(f.header().channels().findChannel(c), nullptr) << c;
  r = run({"render", "plane.xml", "--aov", "albedo", "-o", "out.png"});
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--aov: the layers go into an OpenEXR output"), std::string::npos) << r.err;
  r = run({"render", "plane.xml", "--aov", "albedo,bogus", "-o", "out.exr"});
  EXPECT_EQ(r.status, 2);
}

}  // namespace
