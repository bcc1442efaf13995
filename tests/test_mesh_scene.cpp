// Mesh files as scenes (OBJ, PLY) and a scene rendered at another size.
#include <gtest/gtest.h>

#include <cmath>

#include "scene_helpers.h"
#include "temp_dir.h"

namespace {

const std::string kBunny = LUZ_SHARED_DIR "/scenes/bunny/bun_zipper.ply";

// The bunny as a scene: all its triangles, a camera that frames it, the
// white sky announced by one warning, and an image with no lost sample in
// which the bunny covers the centre (darker than the sky around it).
TEST(MeshScene, PlyRendersUnderAWhiteSky) {
  luz::Scene s = luz::load_scene(kBunny);
  EXPECT_EQ(s.num_triangles(), 69451u);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("bun_zipper.ply: warning: no light in the file"), std::string::npos) << s.warnings[0];
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].type, luz::LightType::Constant);
  s.set_resolution(32, 32);
  s.settings.spp = 4;
  luz::Film f = luz_test::render_finite(s);
  const std::vector<float> img = f.mean();
  auto at = [&](int x, int y) { return img[3 * size_t(y * 32 + x) + 1]; };
  EXPECT_EQ(at(0, 0), 1.f);           // the sky, seen directly: radiance 1
  EXPECT_LT(at(16, 18), 0.9f);        // the bunny: a diffuse 0.5 surface under it
}

// set_resolution keeps the field of view along the scene's axis and refits
// the other; at the same aspect ratio it changes nothing but the pixel count.
TEST(MeshScene, SetResolutionKeepsTheFieldOfViewAxis) {
  luz::Scene s;
  s.camera.width = 400, s.camera.height = 200;
  for (luz::FovAxis axis : {luz::FovAxis::X, luz::FovAxis::Y, luz::FovAxis::Diagonal, luz::FovAxis::Smaller,
                            luz::FovAxis::Larger}) {
    s.fov_axis = axis;
    s.camera.width = 400, s.camera.height = 200;
    luz::fit_fov(axis, 0.5, 400, 200, s.camera.tan_half_x, s.camera.tan_half_y);
    const float x0 = s.camera.tan_half_x, y0 = s.camera.tan_half_y;
    s.set_resolution(800, 400);
    EXPECT_FLOAT_EQ(s.camera.tan_half_x, x0);
    EXPECT_FLOAT_EQ(s.camera.tan_half_y, y0);
    s.set_resolution(100, 300);
    EXPECT_EQ(s.camera.width, 100);
    EXPECT_EQ(s.camera.height, 300);
    EXPECT_FLOAT_EQ(s.camera.tan_half_x / s.camera.tan_half_y, 100.f / 300.f);
    const double diag = std::hypot(double(s.camera.tan_half_x), double(s.camera.tan_half_y));
    switch (axis) {
      case luz::FovAxis::X: EXPECT_FLOAT_EQ(s.camera.tan_half_x, x0); break;
      case luz::FovAxis::Y: EXPECT_FLOAT_EQ(s.camera.tan_half_y, y0); break;
      case luz::FovAxis::Diagonal: EXPECT_NEAR(diag, 0.5, 1e-6); break;
      case luz::FovAxis::Smaller: EXPECT_FLOAT_EQ(s.camera.tan_half_x, 0.5f); break;  // was y, now x
      case luz::FovAxis::Larger: EXPECT_FLOAT_EQ(s.camera.tan_half_y, 0.5f); break;
    }
  }
}

class MeshSceneFiles : public TempDirTest {};

// A PLY scene's errors come from the reader, naming the file.
TEST_F(MeshSceneFiles, BadPlyIsRefused) {
  const std::string p = write("bad.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n");
  luz_test::expect_load_refused(p, "bad.ply", "face");
}

}  // namespace
