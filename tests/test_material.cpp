// Materials with textured parameters (material/material.h, the Mitsuba
// loader's textures):
// - one harness over every bsdf model and every parameter a texture can
//   drive, as a Mitsuba scene writes them: a checkerboard of two values on
//   the parameter gives, at a point of each square, the BSDF of the same
//   material with that value as a constant (f at random directions; sampling
//   too where the model's lobe weights do not use the texture's mean), and
//   the material's stored constant is the texture's mean;
// - the same harness on a rotated sphere, at hits whose uv (Mitsuba 3's
//   sphere uv, in closed form) lies inside each square;
// - blend weights, blend seconds and two-sided backs take textures as well;
// - float (PFM) bitmaps as parameters; a textured roughness changes the
//   rendered image where the texture says and nowhere else;
// - bad textures: negative or non-finite texels, reflectance texels above 1,
//   textures where a parameter cannot take one, unknown wrap modes,
//   projective to_uv, a checkerboard of textures, unknown <ref> ids: one
//   file:line error each.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "luz/device/cpu/render.h"
#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "geometry_helpers.h"
#include "scene_helpers.h"
#include "sphere_helpers.h"
#include "temp_dir.h"

using namespace luz;

namespace {

// A rectangle (uv (0,0)-(1,1)) with the given bsdf, seen by a camera.
std::string rect_scene(const std::string& bsdf) {
  return "<scene version=\"3.0.0\">\n"
         "<sensor type=\"perspective\"><transform name=\"to_world\"><lookat origin=\"0,0,3\" target=\"0,0,0\" "
         "up=\"0,1,0\"/></transform><film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/><integer "
         "name=\"height\" value=\"8\"/></film></sensor>\n"
         "<shape type=\"rectangle\">\n" +
         bsdf + "\n</shape>\n</scene>\n";
}

// A value as a Mitsuba property: three numbers for colours, one for floats.
std::string value_xml(const std::string& name, const std::string& v, bool colour) {
  return std::string(colour ? "<rgb" : "<float") + " name=\"" + name + "\" value=\"" + v + "\"/>";
}

struct Case {
  const char* type;      // the bsdf plugin
  const char* fixed;     // other parameters, constant
  const char* param;     // the textured one
  const char* v0;        // its value in the checkerboard's color0 squares
  const char* v1;        // and in color1's
  bool colour;
  bool same_sampling;    // sampling does not depend on the textures' means
};

const Case kCases[] = {
    {"diffuse", "", "reflectance", "0.9, 0.5, 0.1", "0.2, 0.3, 0.7", true, true},
    {"phong", "", "diffuse_reflectance", "0.6, 0.3, 0.1", "0.1, 0.2, 0.5", true, true},
    {"phong", "", "specular_reflectance", "0.3, 0.2, 0.1", "0.1, 0.4, 0.2", true, true},
    {"phong", "", "exponent", "5", "80", false, true},
    {"blinnphong", "", "diffuse_reflectance", "0.6, 0.3, 0.1", "0.1, 0.2, 0.5", true, true},
    {"blinnphong", "", "specular_reflectance", "0.3, 0.2, 0.1", "0.1, 0.4, 0.2", true, true},
    {"blinnphong", "", "exponent", "5", "80", false, true},
    {"conductor", "<rgb name=\"k\" value=\"3, 2.5, 2\"/>", "eta", "0.2, 0.9, 1.1", "1.5, 0.4, 0.3", true, true},
    {"conductor", "<rgb name=\"eta\" value=\"0.2, 0.9, 1.1\"/>", "k", "3, 2.5, 2", "1, 4, 5", true, true},
    {"conductor", "", "specular_reflectance", "0.9, 0.5, 0.1", "0.2, 0.3, 0.7", true, true},
    {"roughconductor", "", "alpha", "0.05", "0.4", false, true},
    {"roughconductor", "<float name=\"alpha_v\" value=\"0.2\"/>", "alpha_u", "0.05", "0.4", false, true},
    {"roughconductor", "<float name=\"alpha_u\" value=\"0.2\"/>", "alpha_v", "0.05", "0.4", false, true},
    {"roughconductor", "<rgb name=\"k\" value=\"3, 2.5, 2\"/>", "eta", "0.2, 0.9, 1.1", "1.5, 0.4, 0.3", true, true},
    {"roughconductor", "<rgb name=\"eta\" value=\"0.2, 0.9, 1.1\"/>", "k", "3, 2.5, 2", "1, 4, 5", true, true},
    {"roughconductor", "<string name=\"distribution\" value=\"ggx\"/>", "specular_reflectance", "0.9, 0.5, 0.1",
     "0.2, 0.3, 0.7", true, true},
    {"dielectric", "", "specular_reflectance", "0.9, 0.5, 0.1", "0.2, 0.3, 0.7", true, true},
    {"dielectric", "", "specular_transmittance", "0.9, 0.5, 0.1", "0.2, 0.3, 0.7", true, true},
    {"thindielectric", "", "specular_reflectance", "0.9, 0.5, 0.1", "0.2, 0.3, 0.7", true, true},
    {"thindielectric", "", "specular_transmittance", "0.9, 0.5, 0.1", "0.2, 0.3, 0.7", true, true},
    {"roughdielectric", "", "alpha", "0.05", "0.4", false, true},
    {"roughdielectric", "", "specular_reflectance", "0.9, 0.5, 0.1", "0.2, 0.3, 0.7", true, true},
    {"roughdielectric", "", "specular_transmittance", "0.9, 0.5, 0.1", "0.2, 0.3, 0.7", true, true},
    {"plastic", "", "diffuse_reflectance", "0.9, 0.5, 0.1", "0.2, 0.3, 0.7", true, false},
    {"plastic", "", "specular_reflectance", "0.9, 0.5, 0.1", "0.2, 0.3, 0.7", true, false},
    {"roughplastic", "", "diffuse_reflectance", "0.9, 0.5, 0.1", "0.2, 0.3, 0.7", true, false},
    {"roughplastic", "", "specular_reflectance", "0.9, 0.5, 0.1", "0.2, 0.3, 0.7", true, false},
    {"ward", "<float name=\"alpha_v\" value=\"0.2\"/>", "alpha_u", "0.05", "0.4", false, true},
    {"ward", "<float name=\"alpha_u\" value=\"0.2\"/>", "alpha_v", "0.05", "0.4", false, true},
    {"ward", "", "diffuse_reflectance", "0.6, 0.3, 0.1", "0.1, 0.2, 0.5", true, true},
    {"ward", "", "specular_reflectance", "0.3, 0.2, 0.1", "0.1, 0.4, 0.2", true, true},
};

// uv points inside a color0 square and inside a color1 square of a
// checkerboard with to_uv = identity (color0 where exactly one of u, v > 1/2).
constexpr Vec2 kUv0{0.8f, 0.3f}, kUv1{0.3f, 0.2f};

// The material of the scene's only shape.
const Material& only_material(const Scene& s) { return s.materials[s.tri_material[0]]; }

// Expects a and b to be the same BSDF: f at random direction pairs (relative
// 1e-5: a float parameter through a texture is a luminance of equal channels,
// one rounding away), and, if `sampling`, the same samples.
void expect_same_bsdf(const Bsdf& a, const Bsdf& b, bool sampling, const std::string& what) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u01(0.f, 1.f);
  auto dir = [&] {
    const float z = 2.f * u01(rng) - 1.f, phi = 6.2831853f * u01(rng), r = std::sqrt(std::max(0.f, 1.f - z * z));
    return Vec3{r * std::cos(phi), r * std::sin(phi), z};
  };
  auto near = [](Color x, Color y) {
    for (int k = 0; k < 3; ++k)
      if (!(std::fabs(x[k] - y[k]) <= 1e-5f * std::max(std::fabs(x[k]), std::fabs(y[k])) + 1e-12f)) return false;
    return true;
  };
  int compared = 0;
  for (int i = 0; i < 400; ++i) {
    // Half the pairs from b's own sampling: sharp lobes are black almost
    // everywhere else.
    Vec3 wo = dir(), wi = dir();
    if (i % 2) {
      const BsdfSample s = b.sample(wo, u01(rng), {u01(rng), u01(rng)});
      if (s.valid) wi = s.wi;
    }
    const Color fa = a.f(wo, wi), fb = b.f(wo, wi);
    ASSERT_TRUE(near(fa, fb)) << what << ": f " << fa.x << " " << fa.y << " " << fa.z << " vs " << fb.x << " "
                              << fb.y << " " << fb.z;
    compared += !is_black(fa);
    if (!sampling) continue;
    const float u1 = u01(rng);
    const Vec2 u2{u01(rng), u01(rng)};
    const BsdfSample sa = a.sample(wo, u1, u2), sb = b.sample(wo, u1, u2);
    ASSERT_EQ(sa.valid, sb.valid) << what;
    if (!sa.valid) continue;
    ASSERT_TRUE(near(sa.weight, sb.weight)) << what << ": sample weight";
    ASSERT_TRUE(near(sa.wi, sb.wi)) << what << ": sampled direction";
  }
  if (!a.delta_only()) EXPECT_GT(compared, 20) << what << ": f was black almost everywhere";
}

}  // namespace

using MaterialTextures = TempDirTest;

TEST_F(MaterialTextures, EveryTexturableParameterOfEveryModelFollowsItsTexture) {
  for (const Case& c : kCases) {
    const std::string what = std::string(c.type) + "." + c.param;
    auto bsdf = [&](const std::string& param_xml) {
      return std::string("<bsdf type=\"") + c.type + "\">" + c.fixed + param_xml + "</bsdf>";
    };
    const std::string checker = "<texture type=\"checkerboard\" name=\"" + std::string(c.param) + "\">" +
                                value_xml("color0", c.v0, true) + value_xml("color1", c.v1, true) + "</texture>";
    const Scene textured = load_scene(write("t.xml", rect_scene(bsdf(checker))));
    const Scene s0 = load_scene(write("a.xml", rect_scene(bsdf(value_xml(c.param, c.v0, c.colour)))));
    const Scene s1 = load_scene(write("b.xml", rect_scene(bsdf(value_xml(c.param, c.v1, c.colour)))));
    const Material& m = only_material(textured);
    ASSERT_GE(m.num_bindings, 1u) << what;
    ASSERT_EQ(only_material(s0).num_bindings, 0u) << what;
    const SceneView v = textured.view();
    const uint32_t id = textured.tri_material[0];
    expect_same_bsdf(v.materials.bsdf(id, v.textures, kUv0), only_material(s0).bsdf, c.same_sampling, what + " (0)");
    expect_same_bsdf(v.materials.bsdf(id, v.textures, kUv1), only_material(s1).bsdf, c.same_sampling, what + " (1)");
    // The two squares differ (the test would pass for a texture bound nowhere otherwise).
    const Bsdf b0 = v.materials.bsdf(id, v.textures, kUv0), b1 = v.materials.bsdf(id, v.textures, kUv1);
    EXPECT_NE(std::memcmp(&b0, &b1, sizeof(Bsdf)), 0) << what;
  }
}

// The same harness on a sphere (uv computed at the hit, sphere_uv) under a
// rotated to_world: at hits on points whose closed-form uv (Mitsuba 3's,
// sphere_helpers.h) lies inside a square of a 4×2-scaled checkerboard,
// SceneView::bsdf gives that square's constant BSDF.
TEST_F(MaterialTextures, CheckerboardOnASphereFollowsItsUv) {
  const luz_test::Affine to_world = luz_test::Affine::translate({0.5, 0.2, -1}) * luz_test::Affine::rotate({0.4, 1, -0.7}, 110);
  auto sphere_scene = [&](const std::string& bsdf) {
    return "<scene version=\"3.0.0\"><sensor type=\"perspective\"/><shape type=\"sphere\">" + to_world.mitsuba() + bsdf +
           "</shape></scene>";
  };
  luz_test::Rng rng(17);
  for (const Case& c : kCases) {
    const std::string what = std::string(c.type) + "." + c.param + " on a sphere";
    auto bsdf = [&](const std::string& param_xml) {
      return std::string("<bsdf type=\"") + c.type + "\">" + c.fixed + param_xml + "</bsdf>";
    };
    const std::string checker = "<texture type=\"checkerboard\" name=\"" + std::string(c.param) + "\">" +
                                value_xml("color0", c.v0, true) + value_xml("color1", c.v1, true) +
                                R"(<transform name="to_uv"><scale x="4" y="2"/></transform></texture>)";
    const Scene textured = load_scene(write("t.xml", sphere_scene(bsdf(checker))));
    const Scene s0 = load_scene(write("a.xml", sphere_scene(bsdf(value_xml(c.param, c.v0, c.colour)))));
    const Scene s1 = load_scene(write("b.xml", sphere_scene(bsdf(value_xml(c.param, c.v1, c.colour)))));
    const SceneView v = textured.view();
    int seen[2] = {};
    for (int k = 0; k < 12; ++k) {
      const luz_test::Dvec l = luz_test::sphere_dir(std::acos(1 - 2 * double(rng.uniform())), 2 * M_PI * double(rng.uniform()));
      const luz_test::Duv uv = luz_test::mitsuba_sphere_uv(l);
      // Mitsuba's checkerboard: color0 where exactly one of frac(4u), frac(2v) exceeds 1/2.
      const double a = 4 * uv.u - std::floor(4 * uv.u), b = 2 * uv.v - std::floor(2 * uv.v);
      auto near_edge = [](double f) { return std::fabs(f - 0.5) < 0.02 || f < 0.02 || f > 0.98; };
      if (near_edge(a) || near_edge(b)) continue;
      const int square = (a > 0.5) != (b > 0.5) ? 0 : 1;
      const luz_test::Dvec p = to_world.point(l);
      Ray ray;
      Hit hit;
      luz_test::sphere_hit_at(0, p, luz_test::unit(to_world.vector(l)), ray, hit);
      const Interaction it = v.interaction(ray, hit);
      Bsdf local;
      const Bsdf& got = v.bsdf(it, hit, local);
      const Scene& want = square == 0 ? s0 : s1;
      expect_same_bsdf(got, want.materials[want.spheres[0].material].bsdf, c.same_sampling,
                       what + " (" + std::to_string(square) + ")");
      ++seen[square];
    }
    EXPECT_GT(seen[0] + seen[1], 6) << what;
  }
}

// The wrappers: a blend's weight and its second bsdf, a two-sided's back.
TEST_F(MaterialTextures, BlendWeightBlendSecondAndTwoSidedBackTakeTextures) {
  const std::string checker = "<texture type=\"checkerboard\" name=\"%s\"><float name=\"color0\" value=\"0.2\"/>"
                              "<float name=\"color1\" value=\"0.9\"/></texture>";
  auto tex = [&](const char* name) {
    std::string t = checker;
    t.replace(t.find("%s"), 2, name);
    return t;
  };
  const std::string a = "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.1, 0.2, 0.3\"/></bsdf>";
  auto b = [&](const std::string& refl) { return "<bsdf type=\"roughconductor\">" + refl + "</bsdf>"; };
  struct Wrapped {
    std::string textured, at0, at1;
  } cases[] = {
      {"<bsdf type=\"blendbsdf\">" + tex("weight") + a + b("") + "</bsdf>",
       "<bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"0.2\"/>" + a + b("") + "</bsdf>",
       "<bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"0.9\"/>" + a + b("") + "</bsdf>"},
      {"<bsdf type=\"blendbsdf\">" + a + b(tex("alpha")) + "</bsdf>",
       "<bsdf type=\"blendbsdf\">" + a + b("<float name=\"alpha\" value=\"0.2\"/>") + "</bsdf>",
       "<bsdf type=\"blendbsdf\">" + a + b("<float name=\"alpha\" value=\"0.9\"/>") + "</bsdf>"},
      {"<bsdf type=\"twosided\">" + a + "<bsdf type=\"diffuse\">" + tex("reflectance") + "</bsdf></bsdf>",
       "<bsdf type=\"twosided\">" + a + "<bsdf type=\"diffuse\"><float name=\"reflectance\" value=\"0.2\"/></bsdf></bsdf>",
       "<bsdf type=\"twosided\">" + a + "<bsdf type=\"diffuse\"><float name=\"reflectance\" value=\"0.9\"/></bsdf></bsdf>"},
  };
  for (const Wrapped& w : cases) {
    const Scene t = load_scene(write("t.xml", rect_scene(w.textured)));
    const Scene s0 = load_scene(write("a.xml", rect_scene(w.at0)));
    const Scene s1 = load_scene(write("b.xml", rect_scene(w.at1)));
    const SceneView v = t.view();
    const uint32_t id = t.tri_material[0];
    expect_same_bsdf(v.materials.bsdf(id, v.textures, kUv0), only_material(s0).bsdf, true, w.textured);
    expect_same_bsdf(v.materials.bsdf(id, v.textures, kUv1), only_material(s1).bsdf, true, w.textured);
  }
}

// A top-level texture shared by <ref name=...>; the stored constant is the
// texture's mean (what lobe sampling weights use, as Mitsuba's mean()).
TEST_F(MaterialTextures, TopLevelTexturesByRefAndTheirMean) {
  const std::string scene =
      "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n"
      "<texture type=\"checkerboard\" id=\"cb\"><rgb name=\"color0\" value=\"0.8, 0.4, 0.2\"/>"
      "<rgb name=\"color1\" value=\"0.2, 0.2, 0.6\"/></texture>\n"
      "<bsdf type=\"plastic\" id=\"p\"><ref name=\"diffuse_reflectance\" id=\"cb\"/></bsdf>\n"
      "<shape type=\"rectangle\"><ref id=\"p\"/></shape>\n"
      "<shape type=\"rectangle\"><bsdf type=\"diffuse\"><ref name=\"reflectance\" id=\"cb\"/></bsdf></shape>\n"
      "</scene>\n";
  const Scene s = load_scene(write("s.xml", scene));
  ASSERT_EQ(s.textures.size(), 1u);
  const Material& p = s.materials[s.tri_material[0]];
  const Material& d = s.materials[s.tri_material.back()];
  ASSERT_EQ(p.num_bindings, 1u);
  ASSERT_EQ(d.num_bindings, 1u);
  EXPECT_NEAR(p.bsdf.smooth_plastic.diffuse_reflectance.x, 0.5f, 1e-6f);
  EXPECT_NEAR(d.bsdf.diffuse.reflectance.z, 0.4f, 1e-6f);
  const SceneView v = s.view();
  EXPECT_NEAR(v.materials.bsdf(s.tri_material.back(), v.textures, kUv0).diffuse.reflectance.x, 0.8f, 1e-6f);
}

// A float bitmap (PFM) as a roughness: its texels are read as they are (not
// sRGB), a float parameter takes their luminance.
TEST_F(MaterialTextures, FloatBitmapDrivesRoughness) {
  Image img;
  img.width = 2, img.height = 1;
  img.rgb = {0.05f, 0.05f, 0.05f, 0.3f, 0.6f, 0.9f};
  write_image((dir / "rough.pfm").string(), img);
  const Scene s = load_scene(write(
      "s.xml", rect_scene("<bsdf type=\"roughconductor\"><texture type=\"bitmap\" name=\"alpha\">"
                          "<string name=\"filename\" value=\"rough.pfm\"/><string name=\"filter_type\" "
                          "value=\"nearest\"/></texture></bsdf>")));
  const SceneView v = s.view();
  const uint32_t id = s.tri_material[0];
  const Bsdf left = v.materials.bsdf(id, v.textures, {0.25f, 0.5f});
  const Bsdf right = v.materials.bsdf(id, v.textures, {0.75f, 0.5f});
  EXPECT_NEAR(left.rough_conductor.alpha_u, 0.05f, 1e-7f);
  EXPECT_NEAR(right.rough_conductor.alpha_v, 0.2126f * 0.3f + 0.7152f * 0.6f + 0.0722f * 0.9f, 1e-6f);
}

TEST_F(MaterialTextures, BadTexturesAreFileLineErrors) {
  Image bad;
  bad.width = 2, bad.height = 1;
  bad.rgb = {0.5f, 0.5f, 0.5f, -0.1f, 0.2f, 0.3f};
  write_image((dir / "negative.pfm").string(), bad);
  bad.rgb = {0.5f, NAN, 0.5f, 0.1f, 0.2f, 0.3f};
  write_image((dir / "nan.pfm").string(), bad);
  bad.rgb = {0.5f, 0.5f, 0.5f, 1.5f, 0.2f, 0.3f};
  write_image((dir / "bright.pfm").string(), bad);
  auto bitmap = [](const std::string& name, const std::string& file, const std::string& extra = "") {
    return "<texture type=\"bitmap\" name=\"" + name + "\"><string name=\"filename\" value=\"" + file + "\"/>" +
           extra + "</texture>";
  };
  struct Bad {
    std::string bsdf, problem;
  } cases[] = {
      {"<bsdf type=\"diffuse\">" + bitmap("reflectance", "negative.pfm") + "</bsdf>", "negative or not finite"},
      {"<bsdf type=\"roughconductor\">" + bitmap("alpha", "nan.pfm") + "</bsdf>", "texel (0, 0) is negative or not finite"},
      {"<bsdf type=\"diffuse\">" + bitmap("reflectance", "bright.pfm") + "</bsdf>", "texels above 1"},
      {"<bsdf type=\"roughplastic\">" + bitmap("alpha", "bright.pfm") + "</bsdf>", "'alpha' cannot take a texture"},
      {"<bsdf type=\"dielectric\">" + bitmap("int_ior", "bright.pfm") + "</bsdf>", "wrong type <texture>"},
      {"<bsdf type=\"diffuse\">" + bitmap("reflectance", "missing.pfm") + "</bsdf>", "no such file"},
      {"<bsdf type=\"diffuse\">" + bitmap("reflectance", "bright.pfm", "<string name=\"wrap_mode\" value=\"wrap\"/>") +
           "</bsdf>",
       "unknown wrap_mode 'wrap'"},
      {"<bsdf type=\"diffuse\">" +
           bitmap("reflectance", "bright.pfm",
                  "<transform name=\"to_uv\"><matrix value=\"1 0 0 0 1 0 0.5 0 1\"/></transform>") +
           "</bsdf>",
       "to_uv must be an affine map"},
      {"<bsdf type=\"diffuse\"><texture type=\"checkerboard\" name=\"reflectance\">" +
           bitmap("color0", "bright.pfm") + "</texture></bsdf>",
       "'reflectance' texture has texels above 1"},  // the nested texture's range
      {"<bsdf type=\"diffuse\"><texture type=\"checkerboard\" name=\"reflectance\"><texture type=\"checkerboard\" "
       "name=\"color0\">" + bitmap("color1", "bright.pfm") + "</texture></texture></bsdf>",
       "itself a mix"},
      {"<bsdf type=\"diffuse\"><texture type=\"checkerboard\" name=\"reflectance\"><float name=\"color1\" "
       "value=\"-1\"/></texture></bsdf>",
       "must be finite and not negative"},
      {"<bsdf type=\"diffuse\"><texture type=\"marble\" name=\"reflectance\"/></bsdf>", "unknown texture 'marble'"},
      {"<bsdf type=\"blendbsdf\">" + bitmap("weight", "bright.pfm") +
           "<bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/></bsdf>",
       "weight' texture has texels above 1"},
  };
  for (const Bad& b : cases) {
    const std::string path = write("bad.xml", rect_scene(b.bsdf));
    luz_test::expect_load_refused(path, path, b.problem);
  }
  // A <ref> to a texture id that does not exist is a bsdf reference, and fails as one.
  const std::string path = write("ref.xml", rect_scene("<bsdf type=\"diffuse\"><ref name=\"reflectance\" id=\"nope\"/></bsdf>"));
  luz_test::expect_load_refused(path, path, "");
}
