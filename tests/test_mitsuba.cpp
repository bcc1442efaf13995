// The Mitsuba 3 XML loader, through luz::load_mitsuba on small scenes written
// to a temporary directory: transforms (order, lookat, rotate, scale, matrix),
// the analytic shapes and their normals, BSDF parameters and Mitsuba's
// defaults, <default>/$name with -D precedence, the sensor's field of view,
// film, filter, sampler and integrator settings, and errors with their lines.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "temp_dir.h"
#include "luz/io/error.h"
#include "luz/io/load.h"

namespace fs = std::filesystem;
using luz::Vec3;

namespace {

constexpr float kTol = 1e-5f;

::testing::AssertionResult VecNear(const char* ea, const char*, Vec3 a, Vec3 b) {
  if (std::fabs(a.x - b.x) <= kTol && std::fabs(a.y - b.y) <= kTol && std::fabs(a.z - b.z) <= kTol)
    return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << ea << " = (" << a.x << ", " << a.y << ", " << a.z << "), expected (" << b.x
                                       << ", " << b.y << ", " << b.z << ")";
}
#define EXPECT_VEC_NEAR(a, ...) EXPECT_PRED_FORMAT2(VecNear, a, (__VA_ARGS__))

class Mitsuba : public TempDirTest {
 protected:

  // A scene with a default sensor, `body` after it, and `sensor` inside the
  // sensor. Lines: 1 <scene>, 2 <sensor>, `sensor` from line 3, and `body`
  // from the line after </sensor> (line 4 when `sensor` is empty).
  static std::string scene(const std::string& body, const std::string& sensor = "") {
    return "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n" + sensor + "</sensor>\n" + body + "</scene>\n";
  }
  luz::Scene load(const std::string& text, const luz::Defines& defines = {}) {
    return luz::load_mitsuba(write("scene.xml", text), defines);
  }
  // A rectangle with this transform: its 4 corners, in the loader's order
  // (-1,-1), (1,-1), (1,1), (-1,1), transformed.
  luz::Scene rectangle(const std::string& transform, const std::string& extra = "") {
    return load(scene("<shape type=\"rectangle\">\n<transform name=\"to_world\">\n" + transform + "</transform>\n" +
                      extra + "</shape>\n"));
  }
  // Expects load to throw an InputError whose line is `line` and whose
  // message contains `problem`.
  void expect_error(const std::string& text, int line, const std::string& problem, const luz::Defines& defines = {}) {
    try {
      load(text, defines);
      ADD_FAILURE() << "no error for:\n" << text;
    } catch (const luz::InputError& e) {
      EXPECT_EQ(e.file(), (dir / "scene.xml").string());
      EXPECT_EQ(e.line(), line) << e.what();
      EXPECT_NE(e.problem().find(problem), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
    }
  }
};

Vec3 geometric_normal(const luz::Scene& s, uint32_t tri) {
  Vec3 p0 = s.positions[s.indices[3 * tri]], p1 = s.positions[s.indices[3 * tri + 1]],
       p2 = s.positions[s.indices[3 * tri + 2]];
  return luz::normalize(luz::cross(p1 - p0, p2 - p0));
}
Vec3 centroid(const luz::Scene& s, uint32_t tri) {
  return (s.positions[s.indices[3 * tri]] + s.positions[s.indices[3 * tri + 1]] + s.positions[s.indices[3 * tri + 2]]) *
         (1.f / 3.f);
}

// ------------------------------------------------------------ transforms

TEST_F(Mitsuba, TransformsComposeInListedOrder) {
  // translate, then rotate 90° about z: M = R·T. Corner (-1,-1,0) → T → (0,-1,0) → R → (1,0,0).
  luz::Scene s = rectangle("<translate x=\"1\"/>\n<rotate z=\"1\" angle=\"90\"/>\n");
  ASSERT_EQ(s.positions.size(), 4u);
  EXPECT_VEC_NEAR(s.positions[0], Vec3{1, 0, 0});
  EXPECT_VEC_NEAR(s.positions[2], Vec3{-1, 2, 0});  // (1,1) → (2,1) → (-1,2)
  // The other order: M = T·R. (-1,-1,0) → R → (1,-1,0) → T → (2,-1,0).
  s = rectangle("<rotate z=\"1\" angle=\"90\"/>\n<translate x=\"1\"/>\n");
  EXPECT_VEC_NEAR(s.positions[0], Vec3{2, -1, 0});
  // scale then translate: the translation is not scaled.
  s = rectangle("<scale value=\"3\"/>\n<translate value=\"0, 0, 5\"/>\n");
  EXPECT_VEC_NEAR(s.positions[0], Vec3{-3, -3, 5});
}

TEST_F(Mitsuba, Rotate) {
  // Right-handed, degrees: 90° about +x takes +y to +z.
  luz::Scene s = rectangle("<rotate x=\"1\" angle=\"90\"/>\n");
  EXPECT_VEC_NEAR(s.positions[2], Vec3{1, 0, 1});
  EXPECT_VEC_NEAR(s.positions[0], Vec3{-1, 0, -1});
  // Axis given as value, not normalised; 120° about (1,1,1) cycles x → y → z.
  s = rectangle("<rotate value=\"2, 2, 2\" angle=\"120\"/>\n");
  EXPECT_VEC_NEAR(s.positions[1], Vec3{0, 1, -1});  // (1,-1,0) → (0,1,-1)
  // About y by 90°: +z goes to +x.
  s = rectangle("<translate z=\"1\"/>\n<rotate y=\"1\" angle=\"90\"/>\n");
  EXPECT_VEC_NEAR(s.positions[0], Vec3{1, -1, 1});  // (-1,-1,1) → (1,-1,1)
}

TEST_F(Mitsuba, Scale) {
  luz::Scene s = rectangle("<scale value=\"2\"/>\n");
  EXPECT_VEC_NEAR(s.positions[2], Vec3{2, 2, 0});
  s = rectangle("<scale x=\"2\" y=\"3\"/>\n");
  EXPECT_VEC_NEAR(s.positions[2], Vec3{2, 3, 0});
  s = rectangle("<scale value=\"4, 5, 6\"/>\n");
  EXPECT_VEC_NEAR(s.positions[3], Vec3{-4, 5, 0});
}

TEST_F(Mitsuba, Matrix) {
  // Row-major, as Mitsuba reads it: the last column is the translation.
  luz::Scene s = rectangle("<matrix value=\"0 -1 0 10  1 0 0 20  0 0 1 30  0 0 0 1\"/>\n");
  EXPECT_VEC_NEAR(s.positions[0], Vec3{11, 19, 30});  // (-1,-1,0) → (1,-1,0) + t
  EXPECT_VEC_NEAR(s.positions[1], Vec3{11, 21, 30});  // (1,-1,0) → (1,1,0) + t
  // A 3×3 matrix is the linear part alone.
  s = rectangle("<matrix value=\"2 0 0 0 3 0 0 0 4\"/>\n");
  EXPECT_VEC_NEAR(s.positions[2], Vec3{2, 3, 0});
}

TEST_F(Mitsuba, LookAtFollowsMitsuba) {
  // Columns: left = up × dir, up' = dir × left, dir, origin.
  luz::Scene s = load(scene("<shape type=\"sphere\"/>\n",
                            "<transform name=\"to_world\"><lookat origin=\"1, 2, 3\" target=\"4, 2, 3\" up=\"0, 1, 0\"/>"
                            "</transform>\n"));
  const luz::Camera& c = s.camera;
  EXPECT_VEC_NEAR(c.origin, Vec3{1, 2, 3});
  EXPECT_VEC_NEAR(c.z_axis, Vec3{1, 0, 0});
  EXPECT_VEC_NEAR(c.x_axis, Vec3{0, 0, -1});  // (0,1,0) × (1,0,0)
  EXPECT_VEC_NEAR(c.y_axis, Vec3{0, 1, 0});
  // An up vector not perpendicular to the view direction is made so.
  s = load(scene("<shape type=\"sphere\"/>\n",
                 "<transform name=\"to_world\"><lookat origin=\"0, 0, 0\" target=\"0, 0, 5\" up=\"1, 1, 1\"/>"
                 "</transform>\n"));
  float r = 1.f / std::sqrt(2.f);
  EXPECT_VEC_NEAR(s.camera.z_axis, Vec3{0, 0, 1});
  EXPECT_VEC_NEAR(s.camera.x_axis, Vec3{r, -r, 0});  // normalize((1,1,1) × (0,0,1)) = (1,-1,0)/√2
  EXPECT_VEC_NEAR(s.camera.y_axis, Vec3{r, r, 0});   // (0,0,1) × x
  // A lookat inside a longer chain: translate after it moves the camera.
  s = load(scene("<shape type=\"sphere\"/>\n",
                 "<transform name=\"to_world\"><lookat origin=\"0, 0, 0\" target=\"0, 0, 1\"/><translate y=\"7\"/>"
                 "</transform>\n"));
  EXPECT_VEC_NEAR(s.camera.origin, Vec3{0, 7, 0});
  EXPECT_VEC_NEAR(s.camera.x_axis, Vec3{1, 0, 0});  // default up (0,1,0): (0,1,0) × (0,0,1) = (1,0,0)
}

// ------------------------------------------------------------ shapes

// Radiance seen leaving triangle `tri` toward direction w.
luz::Color emitted(const luz::Scene& s, uint32_t tri, Vec3 w) {
  luz::SceneView v = s.view();
  luz::Hit hit;
  hit.kind = luz::PrimKind::Triangle;
  hit.prim = tri;
  hit.u = hit.v = 1.f / 3.f;
  hit.t = 1.f;
  luz::Ray ray;
  ray.o = centroid(s, tri) + w;
  ray.d = -w;
  const luz::Interaction it = v.interaction(ray, hit);
  return it.emitter < 0 ? luz::Color{} : luz::eval(v.lights[uint32_t(it.emitter)], it.ng, w, v.hit_uv(hit, it.p), v.lights.data);
}

TEST_F(Mitsuba, RectangleEmitsOnItsNormalSide) {
  const std::string emitter = "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1, 2, 3\"/></emitter>\n";
  luz::Scene s = rectangle("", emitter);
  ASSERT_EQ(s.num_triangles(), 2u);
  // Its two triangles are one parallelogram emitter (Scene::compile merges them).
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].type, luz::LightType::Parallelogram);
  EXPECT_FLOAT_EQ(s.lights[0].parallelogram.area, 4.f);
  EXPECT_VEC_NEAR(s.lights[0].parallelogram.normal, Vec3{0, 0, 1});
  EXPECT_EQ(s.tri_emitter[0], 0);
  EXPECT_EQ(s.tri_emitter[1], 0);
  for (const Vec3& p : s.positions) {
    EXPECT_EQ(std::fabs(p.x), 1.f);
    EXPECT_EQ(std::fabs(p.y), 1.f);
    EXPECT_EQ(p.z, 0.f);
  }
  for (uint32_t t = 0; t < 2; ++t) {
    EXPECT_VEC_NEAR(geometric_normal(s, t), Vec3{0, 0, 1});
    EXPECT_EQ(emitted(s, t, {0, 0, 1}).y, 2.f);
    EXPECT_EQ(emitted(s, t, {0, 0, -1}).y, 0.f);
  }
  // Rotated 90° about x: the normal +z becomes -y.
  s = rectangle("<rotate x=\"1\" angle=\"90\"/>\n", emitter);
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_VEC_NEAR(s.lights[0].parallelogram.normal, Vec3{0, -1, 0});
  for (uint32_t t = 0; t < 2; ++t) {
    EXPECT_VEC_NEAR(geometric_normal(s, t), Vec3{0, -1, 0});
    EXPECT_EQ(emitted(s, t, {0, -1, 0}).z, 3.f);
    EXPECT_EQ(emitted(s, t, {0, 1, 0}).z, 0.f);
  }
  // A mirroring transform still maps the normal by the inverse transpose.
  s = rectangle("<scale z=\"-1\"/>\n", emitter);
  for (uint32_t t = 0; t < 2; ++t) EXPECT_VEC_NEAR(geometric_normal(s, t), Vec3{0, 0, -1});
  // flip_normals: the other side emits.
  s = rectangle("", "<boolean name=\"flip_normals\" value=\"true\"/>\n" + emitter);
  for (uint32_t t = 0; t < 2; ++t) {
    EXPECT_VEC_NEAR(geometric_normal(s, t), Vec3{0, 0, -1});
    EXPECT_EQ(emitted(s, t, {0, 0, -1}).x, 1.f);
    EXPECT_EQ(emitted(s, t, {0, 0, 1}).x, 0.f);
  }
}

TEST_F(Mitsuba, CubeHasOutwardNormals) {
  for (const char* transform : {"", "<scale x=\"-1\"/>", "<rotate value=\"1, 2, 3\" angle=\"33\"/>"}) {
    SCOPED_TRACE(transform);
    luz::Scene s = load(scene("<shape type=\"cube\"><transform name=\"to_world\">" + std::string(transform) +
                              "<translate value=\"5, 6, 7\"/></transform></shape>\n"));
    ASSERT_EQ(s.num_triangles(), 12u);
    Vec3 center{5, 6, 7};
    for (uint32_t t = 0; t < 12; ++t) {
      Vec3 c = centroid(s, t) - center;
      // Face centroids of [-1,1]³ lie at distance 2/3·√(1 + 1/9·…) from the center; the normal points away.
      EXPECT_GT(luz::dot(geometric_normal(s, t), luz::normalize(c)), 0.5f) << "triangle " << t;
    }
    for (const Vec3& p : s.positions) EXPECT_NEAR(luz::length(p - center), std::sqrt(3.f), 1e-5f);
  }
  luz::Scene s = load(scene("<shape type=\"cube\"><boolean name=\"flip_normals\" value=\"true\"/></shape>\n"));
  for (uint32_t t = 0; t < 12; ++t) EXPECT_LT(luz::dot(geometric_normal(s, t), centroid(s, t)), 0.f);
  // The unit cube spans [-1,1]³: every face lies on one of the six planes.
  s = load(scene("<shape type=\"cube\"/>\n"));
  for (uint32_t t = 0; t < 12; ++t) {
    Vec3 n = geometric_normal(s, t);
    EXPECT_NEAR(luz::dot(n, centroid(s, t)), 1.f, kTol);
  }
}

TEST_F(Mitsuba, Sphere) {
  luz::Scene s = load(scene(
      "<shape type=\"sphere\"><point name=\"center\" x=\"1\" y=\"2\" z=\"3\"/><float name=\"radius\" value=\"0.5\"/>"
      "<transform name=\"to_world\"><scale value=\"2\"/><translate x=\"1\"/></transform>"
      "<emitter type=\"area\"><rgb name=\"radiance\" value=\"5\"/></emitter></shape>\n"));
  ASSERT_EQ(s.spheres.size(), 1u);
  EXPECT_VEC_NEAR(s.spheres[0].center, Vec3{3, 4, 6});
  EXPECT_NEAR(s.spheres[0].radius, 1.f, kTol);
  EXPECT_FALSE(s.spheres[0].flip_normals);
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.spheres[0].emitter, 0);
  // Defaults: the unit sphere at the origin.
  s = load(scene("<shape type=\"sphere\"><boolean name=\"flip_normals\" value=\"true\"/></shape>\n"));
  EXPECT_VEC_NEAR(s.spheres[0].center, Vec3{0, 0, 0});
  EXPECT_EQ(s.spheres[0].radius, 1.f);
  EXPECT_TRUE(s.spheres[0].flip_normals);
  // A mirroring to_world flips the normals, as Mitsuba 3's sphere.cpp does
  // (the scale it decomposes takes the determinant's sign); with
  // flip_normals too, the two flips cancel.
  const char* mirror = "<transform name=\"to_world\"><scale value=\"-2\"/><rotate y=\"1\" angle=\"30\"/></transform>";
  s = load(scene(std::string("<shape type=\"sphere\">") + mirror + "</shape>\n"));
  EXPECT_NEAR(s.spheres[0].radius, 2.f, kTol);
  EXPECT_TRUE(s.spheres[0].flip_normals);
  s = load(scene(std::string("<shape type=\"sphere\"><boolean name=\"flip_normals\" value=\"true\"/>") + mirror +
                 "</shape>\n"));
  EXPECT_FALSE(s.spheres[0].flip_normals);
  s = load(scene("<shape type=\"sphere\"><transform name=\"to_world\"><scale x=\"-1\" y=\"-1\" z=\"1\"/></transform>"
                 "</shape>\n"));  // a rotation by 180°: no mirror
  EXPECT_FALSE(s.spheres[0].flip_normals);
  expect_error(scene("<shape type=\"sphere\">\n<transform name=\"to_world\"><scale x=\"2\"/></transform></shape>\n"), 4,
               "scale uniformly");
  expect_error(scene("<shape type=\"sphere\">\n<float name=\"radius\" value=\"-1\"/></shape>\n"), 4,
               "radius must be positive");
}

// ------------------------------------------------------------ materials

TEST_F(Mitsuba, BsdfsAndMitsubaDefaults) {
  luz::Scene s = load(scene(
      "<bsdf type=\"phong\" id=\"p\"/>\n"
      "<bsdf type=\"phong\" id=\"q\"><rgb name=\"diffuse_reflectance\" value=\"0.1, 0.2, 0.3\"/>"
      "<spectrum name=\"specular_reflectance\" value=\"0.4\"/><float name=\"exponent\" value=\"12\"/></bsdf>\n"
      "<bsdf type=\"twosided\" id=\"t\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.7\"/></bsdf></bsdf>\n"
      "<bsdf type=\"twosided\" id=\"tr\"><ref id=\"q\"/></bsdf>\n"
      "<shape type=\"sphere\"><ref id=\"p\"/></shape>\n"
      "<shape type=\"sphere\"><ref id=\"q\"/></shape>\n"
      "<shape type=\"sphere\"><ref id=\"t\"/></shape>\n"
      "<shape type=\"sphere\"><ref id=\"tr\"/></shape>\n"
      "<shape type=\"sphere\"/>\n"));
  ASSERT_EQ(s.spheres.size(), 5u);
  const luz::Bsdf& p = s.materials[s.spheres[0].material].bsdf;
  EXPECT_EQ(p.type, luz::BsdfType::Phong);
  EXPECT_FALSE(p.two_sided);
  EXPECT_EQ(p.phong.kd.x, 0.5f);  // Mitsuba 0.6's defaults: 0.5, 0.2, 30
  EXPECT_EQ(p.phong.ks.y, 0.2f);
  EXPECT_EQ(p.phong.exponent, 30.f);
  const luz::Bsdf& q = s.materials[s.spheres[1].material].bsdf;
  EXPECT_EQ(q.type, luz::BsdfType::Phong);
  EXPECT_EQ(q.phong.kd.z, 0.3f);
  EXPECT_EQ(q.phong.ks.x, 0.4f);
  EXPECT_EQ(q.phong.exponent, 12.f);
  const luz::Bsdf& t = s.materials[s.spheres[2].material].bsdf;
  EXPECT_EQ(t.type, luz::BsdfType::Diffuse);
  EXPECT_TRUE(t.two_sided);
  EXPECT_EQ(t.diffuse.reflectance.y, 0.7f);
  const luz::Bsdf& tr = s.materials[s.spheres[3].material].bsdf;
  EXPECT_EQ(tr.type, luz::BsdfType::Phong);
  EXPECT_TRUE(tr.two_sided);
  EXPECT_EQ(tr.phong.exponent, 12.f);
  EXPECT_FALSE(s.materials[s.spheres[1].material].bsdf.two_sided) << "wrapping q must not change q";
  const luz::Bsdf& d = s.materials[s.spheres[4].material].bsdf;  // no bsdf: diffuse 0.5, one-sided
  EXPECT_EQ(d.type, luz::BsdfType::Diffuse);
  EXPECT_FALSE(d.two_sided);
  EXPECT_EQ(d.diffuse.reflectance.x, 0.5f);

  expect_error(scene("<bsdf type=\"phong\">\n<rgb name=\"diffuse_reflectance\" value=\"0.9\"/></bsdf>\n"), 4,
               "create energy");
  expect_error(scene("<bsdf type=\"diffuse\">\n<rgb name=\"reflectance\" value=\"1.5\"/></bsdf>\n"), 4, "[0, 1]");
  expect_error(scene("<bsdf type=\"twosided\">\n<bsdf type=\"twosided\"><bsdf type=\"diffuse\"/></bsdf></bsdf>\n"), 5,
               "twosided cannot wrap");
  expect_error(scene("<bsdf type=\"twosided\">\n</bsdf>\n"), 4, "one or two nested bsdfs");
}

// ------------------------------------------------------------ parameters

TEST_F(Mitsuba, DefaultsAndDefines) {
  const std::string text =
      "<scene version=\"3.0.0\">\n"
      "<default name=\"g\" value=\"0.25\"/>\n"
      "<default name=\"res\" value=\"32\"/>\n"
      "<sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"$res\"/>"
      "<integer name=\"height\" value=\"1$res\"/></film></sensor>\n"
      "<shape type=\"sphere\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.1, $g, 0.3\"/></bsdf></shape>\n"
      "</scene>\n";
  luz::Scene s = load(text);
  EXPECT_EQ(s.camera.width, 32);
  EXPECT_EQ(s.camera.height, 132);  // substitution inside a value
  EXPECT_EQ(s.materials[s.spheres[0].material].bsdf.diffuse.reflectance.y, 0.25f);
  s = load(text, {{"g", "0.75"}, {"res", "8"}});  // -D wins over <default>
  EXPECT_EQ(s.camera.width, 8);
  EXPECT_EQ(s.camera.height, 18);
  EXPECT_EQ(s.materials[s.spheres[0].material].bsdf.diffuse.reflectance.y, 0.75f);
  expect_error(text, 0, "-D nope", {{"nope", "1"}});
}

TEST_F(Mitsuba, ParameterErrors) {
  expect_error("<scene version=\"3.0.0\">\n<default name=\"a\" value=\"1\"/>\n<default name=\"a\" value=\"2\"/>\n</scene>\n",
               3, "given twice");
  expect_error(scene("<shape type=\"sphere\">\n<float name=\"radius\" value=\"$r\"/></shape>\n"), 5,
               "undefined parameter '$r'");
  expect_error(scene("<shape type=\"sphere\">\n<float name=\"radius\" value=\"1\"/>\n<float name=\"radius\" value=\"2\"/>"
                     "</shape>\n"),
               6, "given twice");
  expect_error(scene("<shape type=\"sphere\">\n<ref id=\"nothing\"/></shape>\n"), 5, "no bsdf with id 'nothing'");
  expect_error(scene("<bsdf type=\"diffuse\" id=\"a\"/>\n<bsdf type=\"diffuse\" id=\"a\"/>\n<shape type=\"sphere\"/>\n"), 5,
               "duplicate id 'a'");
  expect_error(scene("<shape type=\"sphere\"><transform name=\"to_world\">\n<scale value=\"0\"/></transform></shape>\n"),
               4, "singular");
  expect_error(scene("<shape type=\"sphere\"><transform name=\"to_world\">\n<skew value=\"1\"/></transform></shape>\n"),
               5, "unsupported transform operation <skew>");
  expect_error(scene("<shape type=\"sphere\"><transform name=\"to_world\">\n<matrix value=\"1 0 0\"/></transform></shape>\n"),
               5, "16 (or 9) numbers");
  expect_error(scene("<shape type=\"sphere\"><transform name=\"to_world\">\n<rotate angle=\"3\"/></transform></shape>\n"),
               5, "non-zero axis");
  expect_error(scene("", ""), 0, "no shapes");
  expect_error("<scene version=\"3.0.0\">\n<shape type=\"sphere\"/>\n</scene>\n", 0, "no <sensor>");
}

// ------------------------------------------------------------ sensor, film, sampler, integrator

TEST_F(Mitsuba, FieldOfViewAxis) {
  auto load_fov = [&](const std::string& axis, int w, int h) {
    return load(scene("<shape type=\"sphere\"/>\n", "<float name=\"fov\" value=\"90\"/>" +
                                                        (axis.empty() ? "" : "<string name=\"fov_axis\" value=\"" + axis + "\"/>") +
                                                        "<film type=\"hdrfilm\"><integer name=\"width\" value=\"" +
                                                        std::to_string(w) + "\"/><integer name=\"height\" value=\"" +
                                                        std::to_string(h) + "\"/></film>\n"))
        .camera;
  };
  luz::Camera c = load_fov("", 200, 100);  // Mitsuba's default axis is x
  EXPECT_NEAR(c.tan_half_x, 1.f, kTol);
  EXPECT_NEAR(c.tan_half_y, 0.5f, kTol);
  c = load_fov("x", 200, 100);
  EXPECT_NEAR(c.tan_half_x, 1.f, kTol);
  EXPECT_NEAR(c.tan_half_y, 0.5f, kTol);
  c = load_fov("y", 200, 100);
  EXPECT_NEAR(c.tan_half_x, 2.f, kTol);
  EXPECT_NEAR(c.tan_half_y, 1.f, kTol);
  c = load_fov("smaller", 200, 100);  // y is the smaller side
  EXPECT_NEAR(c.tan_half_y, 1.f, kTol);
  c = load_fov("smaller", 100, 200);
  EXPECT_NEAR(c.tan_half_x, 1.f, kTol);
  EXPECT_NEAR(c.tan_half_y, 2.f, kTol);
  c = load_fov("larger", 100, 200);
  EXPECT_NEAR(c.tan_half_y, 1.f, kTol);
  EXPECT_NEAR(c.tan_half_x, 0.5f, kTol);
  c = load_fov("diagonal", 200, 100);
  EXPECT_NEAR(c.tan_half_x * c.tan_half_x + c.tan_half_y * c.tan_half_y, 1.f, kTol);
  EXPECT_NEAR(c.tan_half_x / c.tan_half_y, 2.f, kTol);
  expect_error(scene("<shape type=\"sphere\"/>\n", "<float name=\"fov\" value=\"90\"/><string name=\"fov_axis\" value=\"z\"/>\n"), 2, "fov_axis");
  expect_error(scene("<shape type=\"sphere\"/>\n", "<float name=\"fov\" value=\"180\"/>\n"), 2, "fov must be");
}

// Without a fov, Mitsuba 3's focal_length: "<x>mm" (default 50mm) on a
// 36 × 24 mm film, a diagonal field of view: tan(fov/2) = √(36² + 24²) / 2f
// along the film's diagonal, whatever its aspect.
TEST_F(Mitsuba, FocalLength) {
  auto load_sensor = [&](const std::string& params) {
    return load(scene("<shape type=\"sphere\"/>\n", params +
                                                        "<film type=\"hdrfilm\"><integer name=\"width\" value=\"300\"/>"
                                                        "<integer name=\"height\" value=\"100\"/></film>\n"))
        .camera;
  };
  auto diagonal = [](const luz::Camera& c) { return std::sqrt(c.tan_half_x * c.tan_half_x + c.tan_half_y * c.tan_half_y); };
  const double film_diagonal = std::sqrt(36.0 * 36.0 + 24.0 * 24.0);
  luz::Camera c = load_sensor("");
  EXPECT_NEAR(diagonal(c), film_diagonal / (2 * 50), kTol);
  EXPECT_NEAR(c.tan_half_x / c.tan_half_y, 3.f, kTol);
  c = load_sensor("<string name=\"focal_length\" value=\"35mm\"/>");
  EXPECT_NEAR(diagonal(c), film_diagonal / (2 * 35), kTol);
  c = load_sensor("<string name=\"focal_length\" value=\"28\"/>");  // "mm" may be left out
  EXPECT_NEAR(diagonal(c), film_diagonal / (2 * 28), kTol);
  expect_error(scene("<shape type=\"sphere\"/>\n", "<float name=\"fov\" value=\"40\"/>\n<string name=\"focal_length\" value=\"35mm\"/>\n"), 2,
               "either fov or focal_length");
  expect_error(scene("<shape type=\"sphere\"/>\n", "<string name=\"focal_length\" value=\"wide\"/>\n"), 3, "not a number");
  expect_error(scene("<shape type=\"sphere\"/>\n", "<string name=\"focal_length\" value=\"-35mm\"/>\n"), 3, "focal_length must be");
  expect_error(scene("<shape type=\"sphere\"/>\n", "<float name=\"focal_length\" value=\"35\"/>\n"), 3, "wrong type");
  expect_error(scene("<shape type=\"sphere\"/>\n", "<string name=\"fov_axis\" value=\"y\"/>\n"), 3, "fov_axis applies to a fov");
}

TEST_F(Mitsuba, FilmAndFilter) {
  auto load_film = [&](const std::string& film) { return load(scene("<shape type=\"sphere\"/>\n", film)); };
  luz::Scene s = load_film("");
  EXPECT_EQ(s.camera.width, 768);  // Mitsuba's hdrfilm defaults
  EXPECT_EQ(s.camera.height, 576);
  EXPECT_EQ(s.settings.filter, luz::FilterKind::Gaussian);  // and its default rfilter
  s = load_film("<film type=\"hdrfilm\"><integer name=\"width\" value=\"40\"/><integer name=\"height\" value=\"30\"/></film>");
  EXPECT_EQ(s.camera.width, 40);
  EXPECT_EQ(s.camera.height, 30);
  EXPECT_EQ(s.settings.filter, luz::FilterKind::Gaussian);
  s = load_film("<film type=\"hdrfilm\"><rfilter type=\"box\"/></film>");
  EXPECT_EQ(s.settings.filter, luz::FilterKind::Box);
  s = load_film("<film type=\"hdrfilm\"><rfilter type=\"tent\"/></film>");
  EXPECT_EQ(s.settings.filter, luz::FilterKind::Tent);
  s = load_film("<film type=\"hdrfilm\"><rfilter type=\"gaussian\"/></film>");
  EXPECT_EQ(s.settings.filter, luz::FilterKind::Gaussian);
  expect_error(scene("<shape type=\"sphere\"/>\n", "<film type=\"hdrfilm\">\n<rfilter type=\"mitchell\"/></film>\n"), 4,
               "unknown rfilter 'mitchell'");
  expect_error(scene("<shape type=\"sphere\"/>\n", "<film type=\"mfilm\"/>\n"), 3, "unknown film 'mfilm'");
  expect_error(scene("<shape type=\"sphere\"/>\n", "<film type=\"hdrfilm\"><integer name=\"width\" value=\"0\"/></film>\n"),
               3, "film size");
}

TEST_F(Mitsuba, Sampler) {
  auto load_sampler = [&](const std::string& sampler) { return load(scene("<shape type=\"sphere\"/>\n", sampler)).settings; };
  luz::RenderSettings r = load_sampler("");
  // Mitsuba's default sample count (4), Luz's default sampler where none is named.
  EXPECT_EQ(r.sampler, luz::SamplerType::Sobol);
  EXPECT_EQ(r.spp, 4u);
  r = load_sampler("<sampler type=\"independent\"><integer name=\"sample_count\" value=\"9\"/></sampler>");
  EXPECT_EQ(r.sampler, luz::SamplerType::Independent);
  EXPECT_EQ(r.spp, 9u);
  r = load_sampler("<sampler type=\"stratified\"><integer name=\"sample_count\" value=\"16\"/></sampler>");
  EXPECT_EQ(r.sampler, luz::SamplerType::Stratified);
  EXPECT_EQ(r.spp, 16u);
  r = load_sampler("<sampler type=\"sobol\"><integer name=\"sample_count\" value=\"64\"/>"
                   "<integer name=\"seed\" value=\"3\"/></sampler>");
  EXPECT_EQ(r.sampler, luz::SamplerType::Sobol);
  EXPECT_EQ(r.spp, 64u);
  EXPECT_EQ(r.seed, 3u);
  r = load_sampler("<sampler type=\"ldsampler\"/>");
  EXPECT_EQ(r.sampler, luz::SamplerType::Sobol);
  EXPECT_EQ(r.spp, 4u);
  expect_error(scene("<shape type=\"sphere\"/>\n", "<sampler type=\"independent\">\n<integer name=\"sample_count\" value=\"0\"/></sampler>\n"),
               3, "sample_count");
}

TEST_F(Mitsuba, Integrator) {
  auto inside = [&](const std::string& integrator) {
    return load("<scene version=\"3.0.0\">\n" + integrator +
                "\n<sensor type=\"perspective\"/>\n<shape type=\"sphere\"/>\n</scene>\n")
        .settings.integrator;
  };
  luz::IntegratorParams ip = inside("");
  EXPECT_EQ(ip.type, luz::IntegratorType::Path);
  EXPECT_EQ(ip.max_depth, -1);
  EXPECT_EQ(ip.rr_depth, 5);
  ip = inside("<integrator type=\"path\"><integer name=\"max_depth\" value=\"7\"/><integer name=\"rr_depth\" value=\"3\"/></integrator>");
  EXPECT_EQ(ip.type, luz::IntegratorType::Path);
  EXPECT_EQ(ip.max_depth, 7);
  EXPECT_EQ(ip.rr_depth, 3);
  ip = inside("<integrator type=\"bsdf\"><integer name=\"max_depth\" value=\"-1\"/></integrator>");
  EXPECT_EQ(ip.type, luz::IntegratorType::Bsdf);
  EXPECT_EQ(ip.max_depth, -1);
  ip = inside("<integrator type=\"light\"/>");
  EXPECT_EQ(ip.type, luz::IntegratorType::Light);
  expect_error("<scene version=\"3.0.0\">\n<integrator type=\"path\"><float name=\"max_depth\" value=\"7\"/></integrator>\n"
               "</scene>\n",
               2, "wrong type <float>");
  expect_error("<scene version=\"3.0.0\">\n<integrator type=\"path\"/>\n<integrator type=\"path\"/>\n</scene>\n", 3,
               "only one <integrator>");
  ip = inside("<integrator type=\"volpath\"/>");  // Luz has no media: path (more in test_mitsuba_formats)
  EXPECT_EQ(ip.type, luz::IntegratorType::Path);
  EXPECT_FALSE(ip.hide_emitters);
  ip = inside("<integrator type=\"path\"><boolean name=\"hide_emitters\" value=\"true\"/></integrator>");
  EXPECT_TRUE(ip.hide_emitters);
  // Kept from an integrator Luz renders as path, or one nested in it.
  ip = inside("<integrator type=\"aov\"><integrator type=\"path\"><boolean name=\"hide_emitters\" value=\"true\"/>"
              "</integrator></integrator>");
  EXPECT_TRUE(ip.hide_emitters);
  expect_error("<scene version=\"3.0.0\">\n<integrator type=\"path\"><integer name=\"max_depth\" value=\"0\"/></integrator>\n"
               "</scene>\n",
               2, "max_depth");
}

// ------------------------------------------------------------ the shipped scenes

TEST_F(Mitsuba, BitterliSceneV3LoadsUnchanged) {
  fs::path xml = fs::path(LUZ_SHARED_DIR) / "scenes/cornell-box-bitterli/mitsuba3/scene_v3.xml";
  if (!fs::exists(xml)) GTEST_SKIP() << xml << " is not there";
  luz::Scene s = luz::load_mitsuba(xml.string());
  EXPECT_EQ(s.camera.width, 1024);
  EXPECT_EQ(s.camera.height, 1024);
  EXPECT_EQ(s.settings.spp, 64u);
  EXPECT_EQ(s.settings.integrator.max_depth, 65);
  EXPECT_EQ(s.settings.filter, luz::FilterKind::Tent);
  EXPECT_GT(s.num_triangles(), 0u);
  EXPECT_GT(s.lights.size(), 0u);
  // Camera: matrix "-1 0 0 0 0 1 0 1 0 0 -1 6.8 0 0 0 1", fov 19.5 on x.
  EXPECT_VEC_NEAR(s.camera.origin, Vec3{0, 1, 6.8f});
  EXPECT_VEC_NEAR(s.camera.z_axis, Vec3{0, 0, -1});
  EXPECT_NEAR(s.camera.tan_half_x, std::tan(19.5 * M_PI / 360), 1e-6);
}

TEST_F(Mitsuba, BundledCornellBoxLoads) {
  fs::path xml = fs::path(LUZ_SOURCE_DIR) / "scenes/cornell-box.xml";
  luz::Scene s = luz::load_mitsuba(xml.string(), {{"res", "16"}});
  EXPECT_EQ(s.camera.width, 16);
  EXPECT_GT(s.num_triangles(), 0u);
  EXPECT_GT(s.lights.size(), 0u);
}

}  // namespace
