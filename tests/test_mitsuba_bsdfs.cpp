// The Mitsuba loader's BSDF plugins beyond diffuse/phong: conductor,
// roughconductor, dielectric, roughdielectric, thindielectric, plastic,
// roughplastic, blendbsdf, ward, blinnphong (Luz's own), principled, principledthin, twosided around them
// (with one nested bsdf or a front and a back one); their Mitsuba 3 parameter
// names and defaults, the conductor presets, and the one-line errors (file
// and line) for what is out of range or not supported. A twosided pair is
// also rendered from both sides in a white furnace.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "temp_dir.h"
#include "luz/bsdf/fresnel.h"
#include "luz/device/cpu/render.h"
#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "stat_helpers.h"

namespace fs = std::filesystem;
using luz::Bsdf;
using luz::BsdfType;
using luz::Color;

namespace {

class MitsubaBsdfs : public TempDirTest {
 protected:
  // Lines: 1 <scene>, 2 <sensor/>, `body` from line 3.
  static std::string scene(const std::string& body) {
    return "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n" + body +
           "<shape type=\"sphere\"/>\n</scene>\n";
  }
  luz::Scene load(const std::string& text) {
    fs::path p = dir / "scene.xml";
    std::ofstream(p, std::ios::binary) << text;
    return luz::load_mitsuba(p.string(), {});
  }
  // The material of a sphere made with this one bsdf element.
  Bsdf material(const std::string& bsdf) {
    luz::Scene s = load("<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n<shape type=\"sphere\">\n" + bsdf +
                        "\n</shape>\n</scene>\n");
    EXPECT_EQ(s.spheres.size(), 1u);
    return s.materials[s.spheres[0].material].bsdf;
  }
  // `body` starts on line 3; expects an InputError at `line` containing `problem`.
  void expect_error(const std::string& body, int line, const std::string& problem) {
    try {
      load(scene(body));
      ADD_FAILURE() << "no error for:\n" << body;
    } catch (const luz::InputError& e) {
      EXPECT_EQ(e.file(), (dir / "scene.xml").string());
      EXPECT_EQ(e.line(), line) << e.what();
      EXPECT_NE(e.problem().find(problem), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
    }
  }
};

void expect_color(Color c, float r, float g, float b) {
  EXPECT_FLOAT_EQ(c.x, r);
  EXPECT_FLOAT_EQ(c.y, g);
  EXPECT_FLOAT_EQ(c.z, b);
}

}  // namespace

TEST_F(MitsubaBsdfs, Conductor) {
  // Mitsuba 3's default material is "none": the perfect mirror (F = 1).
  Bsdf d = material("<bsdf type=\"conductor\"/>");
  EXPECT_EQ(d.type, BsdfType::SmoothConductor);
  EXPECT_FALSE(d.two_sided);
  EXPECT_TRUE(d.delta_only());
  expect_color(d.smooth_conductor.eta, 0, 0, 0);
  expect_color(d.smooth_conductor.k, 1, 1, 1);
  expect_color(d.smooth_conductor.specular_reflectance, 1, 1, 1);

  Bsdf au = material("<bsdf type=\"conductor\"><string name=\"material\" value=\"Au\"/></bsdf>");
  Color eta, k;
  ASSERT_TRUE(luz::find_conductor_preset("Au", eta, k));
  expect_color(au.smooth_conductor.eta, eta.x, eta.y, eta.z);
  expect_color(au.smooth_conductor.k, k.x, k.y, k.z);

  Bsdf e = material(
      "<bsdf type=\"conductor\"><rgb name=\"eta\" value=\"0.2, 0.9, 1.1\"/><spectrum name=\"k\" value=\"3\"/>"
      "<rgb name=\"specular_reflectance\" value=\"0.3\"/></bsdf>");
  expect_color(e.smooth_conductor.eta, 0.2f, 0.9f, 1.1f);
  expect_color(e.smooth_conductor.k, 3, 3, 3);
  expect_color(e.smooth_conductor.specular_reflectance, 0.3f, 0.3f, 0.3f);
  Bsdf f = material("<bsdf type=\"conductor\"><float name=\"eta\" value=\"1.5\"/></bsdf>");
  expect_color(f.smooth_conductor.eta, 1.5f, 1.5f, 1.5f);
  expect_color(f.smooth_conductor.k, 1, 1, 1);  // Mitsuba's default k when eta is given

  Bsdf t = material("<bsdf type=\"twosided\"><bsdf type=\"conductor\"/></bsdf>");
  EXPECT_TRUE(t.two_sided);
  EXPECT_EQ(t.type, BsdfType::SmoothConductor);
}

TEST_F(MitsubaBsdfs, RoughConductor) {
  Bsdf d = material("<bsdf type=\"roughconductor\"/>");
  EXPECT_EQ(d.type, BsdfType::RoughConductor);
  EXPECT_EQ(d.rough_conductor.distribution, luz::MicrofacetType::Beckmann);  // Mitsuba's default
  EXPECT_FLOAT_EQ(d.rough_conductor.alpha_u, 0.1f);
  EXPECT_FLOAT_EQ(d.rough_conductor.alpha_v, 0.1f);
  EXPECT_FALSE(d.has_delta());

  Bsdf g = material(
      "<bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"ggx\"/><float name=\"alpha\" value=\"0.3\"/>"
      "<string name=\"material\" value=\"Cu\"/></bsdf>");
  EXPECT_EQ(g.rough_conductor.distribution, luz::MicrofacetType::GGX);
  EXPECT_FLOAT_EQ(g.rough_conductor.alpha_u, 0.3f);
  EXPECT_FLOAT_EQ(g.rough_conductor.alpha_v, 0.3f);
  Color eta, k;
  ASSERT_TRUE(luz::find_conductor_preset("Cu", eta, k));
  expect_color(g.rough_conductor.k, k.x, k.y, k.z);

  Bsdf a = material(
      "<bsdf type=\"roughconductor\"><float name=\"alpha_u\" value=\"0.05\"/><float name=\"alpha_v\" value=\"0.4\"/>"
      "<boolean name=\"sample_visible\" value=\"true\"/></bsdf>");
  EXPECT_FLOAT_EQ(a.rough_conductor.alpha_u, 0.05f);
  EXPECT_FLOAT_EQ(a.rough_conductor.alpha_v, 0.4f);
}

TEST_F(MitsubaBsdfs, Dielectrics) {
  float bk7, air, water;
  ASSERT_TRUE(luz::find_ior_preset("bk7", bk7));
  ASSERT_TRUE(luz::find_ior_preset("air", air));
  ASSERT_TRUE(luz::find_ior_preset("water", water));

  Bsdf d = material("<bsdf type=\"dielectric\"/>");  // Mitsuba: bk7 in air
  EXPECT_EQ(d.type, BsdfType::SmoothDielectric);
  EXPECT_FLOAT_EQ(d.smooth_dielectric.eta, bk7 / air);
  EXPECT_TRUE(d.delta_only());
  EXPECT_TRUE(d.has_transmission());

  Bsdf w = material(
      "<bsdf type=\"dielectric\"><string name=\"int_ior\" value=\"water\"/><float name=\"ext_ior\" value=\"1\"/>"
      "<rgb name=\"specular_transmittance\" value=\"0.5, 0.6, 0.7\"/></bsdf>");
  EXPECT_FLOAT_EQ(w.smooth_dielectric.eta, water);
  expect_color(w.smooth_dielectric.specular_transmittance, 0.5f, 0.6f, 0.7f);
  expect_color(w.smooth_dielectric.specular_reflectance, 1, 1, 1);

  Bsdf t = material("<bsdf type=\"thindielectric\"><float name=\"int_ior\" value=\"1.5\"/></bsdf>");
  EXPECT_EQ(t.type, BsdfType::ThinDielectric);
  EXPECT_FLOAT_EQ(t.thin_dielectric.eta, 1.5f / air);

  Bsdf r = material(
      "<bsdf type=\"roughdielectric\"><string name=\"distribution\" value=\"ggx\"/>"
      "<float name=\"alpha\" value=\"0.2\"/><float name=\"int_ior\" value=\"1.33\"/>"
      "<float name=\"ext_ior\" value=\"1\"/></bsdf>");
  EXPECT_EQ(r.type, BsdfType::RoughDielectric);
  EXPECT_EQ(r.rough_dielectric.distribution, luz::MicrofacetType::GGX);
  EXPECT_FLOAT_EQ(r.rough_dielectric.alpha_u, 0.2f);
  EXPECT_FLOAT_EQ(r.rough_dielectric.eta, 1.33f);
  EXPECT_FALSE(r.has_delta());
  EXPECT_TRUE(r.has_transmission());
}

TEST_F(MitsubaBsdfs, PlasticWardBlinnPhong) {
  Bsdf p = material("<bsdf type=\"plastic\"><rgb name=\"diffuse_reflectance\" value=\"0.1, 0.2, 0.3\"/></bsdf>");
  EXPECT_EQ(p.type, BsdfType::SmoothPlastic);
  expect_color(p.smooth_plastic.diffuse_reflectance, 0.1f, 0.2f, 0.3f);
  expect_color(p.smooth_plastic.specular_reflectance, 1, 1, 1);
  float pp, air;
  ASSERT_TRUE(luz::find_ior_preset("polypropylene", pp));
  ASSERT_TRUE(luz::find_ior_preset("air", air));
  EXPECT_FLOAT_EQ(p.smooth_plastic.eta, pp / air);
  EXPECT_TRUE(p.has_delta());
  EXPECT_FALSE(p.delta_only());
  Bsdf pn = material("<bsdf type=\"plastic\"><boolean name=\"nonlinear\" value=\"false\"/>"
                     "<float name=\"int_ior\" value=\"1.6\"/></bsdf>");
  EXPECT_FLOAT_EQ(pn.smooth_plastic.eta, 1.6f / air);

  Bsdf w = material("<bsdf type=\"ward\"/>");
  EXPECT_EQ(w.type, BsdfType::Ward);
  EXPECT_EQ(w.ward.variant, luz::WardVariant::Balanced);
  Bsdf wo = material(
      "<bsdf type=\"ward\"><string name=\"variant\" value=\"ward\"/><float name=\"alpha_u\" value=\"0.1\"/>"
      "<float name=\"alpha_v\" value=\"0.3\"/><rgb name=\"diffuse_reflectance\" value=\"0.2\"/>"
      "<rgb name=\"specular_reflectance\" value=\"0.5\"/></bsdf>");
  EXPECT_EQ(wo.ward.variant, luz::WardVariant::Ward);
  EXPECT_FLOAT_EQ(wo.ward.alpha_v, 0.3f);
  expect_color(wo.ward.specular_reflectance, 0.5f, 0.5f, 0.5f);

  Bsdf b = material("<bsdf type=\"blinnphong\"><float name=\"exponent\" value=\"50\"/>"
                    "<rgb name=\"diffuse_reflectance\" value=\"0.3\"/><rgb name=\"specular_reflectance\" value=\"0.6\"/></bsdf>");
  EXPECT_EQ(b.type, BsdfType::BlinnPhong);
  EXPECT_FLOAT_EQ(b.blinn_phong.exponent, 50.f);
  expect_color(b.blinn_phong.specular_reflectance, 0.6f, 0.6f, 0.6f);
}

TEST_F(MitsubaBsdfs, BlendAndTwosided) {
  luz::Scene s = load(scene(
      "<bsdf type=\"roughconductor\" id=\"metal\"><float name=\"alpha\" value=\"0.2\"/></bsdf>\n"
      "<bsdf type=\"blendbsdf\" id=\"mix\"><float name=\"weight\" value=\"0.25\"/>"
      "<bsdf type=\"diffuse\"/><ref id=\"metal\"/></bsdf>\n"
      "<bsdf type=\"twosided\" id=\"mix2\"><ref id=\"mix\"/></bsdf>\n"
      "<shape type=\"sphere\"><ref id=\"mix\"/></shape>\n"
      "<shape type=\"sphere\"><ref id=\"mix2\"/></shape>\n"));
  const Bsdf& m = s.materials[s.spheres[0].material].bsdf;
  EXPECT_TRUE(m.blend);
  EXPECT_FLOAT_EQ(m.blend_weight, 0.25f);
  EXPECT_EQ(m.type, BsdfType::Diffuse);
  EXPECT_EQ(m.second.type, BsdfType::RoughConductor);
  EXPECT_FALSE(m.two_sided);
  const Bsdf& m2 = s.materials[s.spheres[1].material].bsdf;
  EXPECT_TRUE(m2.blend);
  EXPECT_TRUE(m2.two_sided);
  // A blend of a diffuse and a dielectric is allowed (not inside twosided).
  Bsdf g = material("<bsdf type=\"blendbsdf\"><bsdf type=\"diffuse\"/><bsdf type=\"dielectric\"/></bsdf>");
  EXPECT_TRUE(g.has_transmission());
  EXPECT_FLOAT_EQ(g.blend_weight, 0.5f);  // Mitsuba's default weight
}

TEST_F(MitsubaBsdfs, Errors) {
  // Body on line 3; errors point at the bsdf element (line 3) unless noted.
  expect_error("<bsdf type=\"roughplastic\"><float name=\"alpha\" value=\"-0.1\"/></bsdf>\n", 3, "must be positive");
  expect_error("<bsdf type=\"roughplastic\"><float name=\"alpha_u\" value=\"0.1\"/>"
               "<float name=\"alpha_v\" value=\"0.2\"/></bsdf>\n",
               3, "isotropic roughness only");
  expect_error("<bsdf type=\"roughplastic\"><float name=\"int_ior\" value=\"1.3\"/>"
               "<float name=\"ext_ior\" value=\"1.3\"/></bsdf>\n",
               3, "int_ior != ext_ior");
  expect_error("<bsdf type=\"roughplastic\"><float name=\"int_ior\" value=\"-1.5\"/></bsdf>\n", 3,
               "'int_ior' must lie in [0.1, 10]");
  expect_error("<bsdf type=\"roughplastic\"><rgb name=\"diffuse_reflectance\" value=\"0.5, 1.2, 0.5\"/></bsdf>\n", 3,
               "[0, 1]");
  expect_error("<bsdf type=\"roughplastic\"><string name=\"distribution\" value=\"phong\"/></bsdf>\n", 3,
               "unknown distribution 'phong'");
  expect_error("<bsdf type=\"roughplastic\"><float name=\"roughness\" value=\"0.1\"/></bsdf>\n", 3,
               "unknown parameter 'roughness'");
  expect_error("<bsdf type=\"twosided\"><bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/>"
               "</bsdf>\n",
               3, "one or two nested bsdfs");
  expect_error("<bsdf type=\"twosided\">\n<bsdf type=\"diffuse\"/>\n<bsdf type=\"blendbsdf\"><bsdf type=\"diffuse\"/>"
               "<bsdf type=\"conductor\"/></bsdf></bsdf>\n",
               5, "as the back side of a twosided is not supported");
  expect_error("<bsdf type=\"twosided\"><bsdf type=\"diffuse\"/><bsdf type=\"dielectric\"/></bsdf>\n", 3,
               "twosided cannot wrap a material that transmits");
  expect_error("<bsdf type=\"blendbsdf\"><bsdf type=\"twosided\"><bsdf type=\"diffuse\"/><bsdf type=\"conductor\"/>"
               "</bsdf><bsdf type=\"twosided\"><bsdf type=\"diffuse\"/></bsdf></bsdf>\n",
               3, "a twosided with two different bsdfs inside a blendbsdf");
  expect_error("<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0\"/></bsdf>\n", 3, "must be positive");
  expect_error("<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"-0.1\"/></bsdf>\n", 3, "must be positive");
  expect_error("<bsdf type=\"roughdielectric\"><float name=\"alpha_u\" value=\"0.1\"/></bsdf>\n", 3,
               "must be given together");
  expect_error("<bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.1\"/>"
               "<float name=\"alpha_u\" value=\"0.1\"/><float name=\"alpha_v\" value=\"0.1\"/></bsdf>\n",
               3, "not both");
  expect_error("<bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"phong\"/></bsdf>\n", 3,
               "unknown distribution 'phong'");
  expect_error("<bsdf type=\"conductor\"><string name=\"material\" value=\"Unobtainium\"/></bsdf>\n", 3,
               "unknown conductor material 'Unobtainium'");
  expect_error("<bsdf type=\"conductor\"><string name=\"material\" value=\"Au\"/><rgb name=\"eta\" value=\"1\"/></bsdf>\n",
               3, "either 'material' or 'eta' and 'k'");
  expect_error("<bsdf type=\"conductor\"><rgb name=\"k\" value=\"1, -1, 1\"/></bsdf>\n", 3, "must not be negative");
  expect_error("<bsdf type=\"conductor\"><rgb name=\"specular_reflectance\" value=\"1.2\"/></bsdf>\n", 3, "[0, 1]");
  expect_error("<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"0\"/></bsdf>\n", 3,
               "'int_ior' must lie in [0.1, 10]");
  expect_error("<bsdf type=\"thindielectric\"><float name=\"ext_ior\" value=\"-1.5\"/></bsdf>\n", 3,
               "'ext_ior' must lie in [0.1, 10]");
  // Far outside real indices the Fresnel terms overflow (plastic at a ratio
  // of 1000: every sample NaN, found by fuzzing): refused.
  for (const char* type : {"plastic", "roughplastic", "dielectric", "roughdielectric", "thindielectric"})
    for (const char* v : {"1e30", "1e-30", "1000", "0.09", "10.5"}) {
      SCOPED_TRACE(std::string(type) + " " + v);
      expect_error(std::string("<bsdf type=\"") + type + "\"><float name=\"int_ior\" value=\"" + v + "\"/></bsdf>\n", 3,
                   "'int_ior' must lie in [0.1, 10]");
    }
  expect_error("<bsdf type=\"dielectric\">\n<string name=\"int_ior\" value=\"kryptonite\"/></bsdf>\n", 4,
               "unknown index of refraction preset 'kryptonite'");
  expect_error("<bsdf type=\"dielectric\"><rgb name=\"specular_transmittance\" value=\"-0.1\"/></bsdf>\n", 3, "[0, 1]");
  expect_error("<bsdf type=\"roughdielectric\"><float name=\"int_ior\" value=\"1.2\"/>"
               "<float name=\"ext_ior\" value=\"1.2\"/></bsdf>\n",
               3, "int_ior != ext_ior");
  expect_error("<bsdf type=\"plastic\"><rgb name=\"diffuse_reflectance\" value=\"1.1\"/></bsdf>\n", 3, "[0, 1]");
  expect_error("<bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"1.5\"/>"
               "<bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/></bsdf>\n",
               3, "'weight' must lie in [0, 1]");
  expect_error("<bsdf type=\"blendbsdf\"><bsdf type=\"diffuse\"/></bsdf>\n", 3, "exactly two nested bsdfs");
  expect_error("<bsdf type=\"blendbsdf\">\n<bsdf type=\"blendbsdf\"><bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/>"
               "</bsdf><bsdf type=\"diffuse\"/></bsdf>\n",
               3, "inside a blendbsdf is not supported");
  expect_error("<bsdf type=\"blendbsdf\"><bsdf type=\"twosided\"><bsdf type=\"diffuse\"/></bsdf>"
               "<bsdf type=\"diffuse\"/></bsdf>\n",
               3, "both be twosided");
  expect_error("<bsdf type=\"twosided\"><bsdf type=\"dielectric\"/></bsdf>\n", 3,
               "twosided cannot wrap a material that transmits");
  expect_error("<bsdf type=\"twosided\"><bsdf type=\"blendbsdf\"><bsdf type=\"diffuse\"/>"
               "<bsdf type=\"roughdielectric\"/></bsdf></bsdf>\n",
               3, "twosided cannot wrap a material that transmits");
  expect_error("<bsdf type=\"ward\"><string name=\"variant\" value=\"lafortune\"/></bsdf>\n", 3,
               "unknown ward variant 'lafortune'");
  expect_error("<bsdf type=\"ward\"><float name=\"alpha_u\" value=\"0\"/></bsdf>\n", 3, "must be positive");
  expect_error("<bsdf type=\"ward\"><rgb name=\"diffuse_reflectance\" value=\"0.9\"/></bsdf>\n", 3, "create energy");
  expect_error("<bsdf type=\"blinnphong\"><rgb name=\"diffuse_reflectance\" value=\"0.5\"/>"
               "<rgb name=\"specular_reflectance\" value=\"0.6\"/></bsdf>\n",
               3, "create energy");
  expect_error("<bsdf type=\"blinnphong\"><float name=\"exponent\" value=\"-1\"/></bsdf>\n", 3, "exponent must be");
  expect_error("<bsdf type=\"roughconductor\"><float name=\"roughness\" value=\"0.1\"/></bsdf>\n", 3,
               "unknown parameter 'roughness'");
}

TEST_F(MitsubaBsdfs, RoughPlastic) {
  // Mitsuba 3's defaults: beckmann, alpha 0.1, polypropylene in air, diffuse 0.5, specular 1, linear.
  Bsdf d = material("<bsdf type=\"roughplastic\"/>");
  EXPECT_EQ(d.type, BsdfType::RoughPlastic);
  EXPECT_FALSE(d.two_sided);
  EXPECT_FALSE(d.has_delta());
  const luz::RoughPlasticBsdf& p = d.rough_plastic;
  EXPECT_EQ(p.distribution, luz::MicrofacetType::Beckmann);
  EXPECT_FLOAT_EQ(p.alpha, 0.1f);
  float pp, air;
  ASSERT_TRUE(luz::find_ior_preset("polypropylene", pp));
  ASSERT_TRUE(luz::find_ior_preset("air", air));
  EXPECT_FLOAT_EQ(p.eta, pp / air);
  expect_color(p.diffuse_reflectance, 0.5f, 0.5f, 0.5f);
  expect_color(p.specular_reflectance, 1, 1, 1);
  EXPECT_FALSE(p.nonlinear);
  EXPECT_FLOAT_EQ(p.specular_sampling_weight, 1.f / 1.5f);  // mean(ks) / (mean(ks) + mean(ρ))
  EXPECT_GT(p.internal_reflectance, 0.f);
  EXPECT_LT(p.internal_reflectance, 1.f);

  Bsdf g = material(
      "<bsdf type=\"roughplastic\"><string name=\"distribution\" value=\"ggx\"/><float name=\"alpha\" value=\"0.3\"/>"
      "<string name=\"int_ior\" value=\"bk7\"/><float name=\"ext_ior\" value=\"1.333\"/>"
      "<rgb name=\"diffuse_reflectance\" value=\"0.1, 0.2, 0.3\"/><rgb name=\"specular_reflectance\" value=\"0.5\"/>"
      "<boolean name=\"nonlinear\" value=\"true\"/><boolean name=\"sample_visible\" value=\"false\"/></bsdf>");
  const luz::RoughPlasticBsdf& q = g.rough_plastic;
  float bk7;
  ASSERT_TRUE(luz::find_ior_preset("bk7", bk7));
  EXPECT_EQ(q.distribution, luz::MicrofacetType::GGX);
  EXPECT_FLOAT_EQ(q.alpha, 0.3f);
  EXPECT_FLOAT_EQ(q.eta, bk7 / 1.333f);
  expect_color(q.diffuse_reflectance, 0.1f, 0.2f, 0.3f);
  expect_color(q.specular_reflectance, 0.5f, 0.5f, 0.5f);
  EXPECT_TRUE(q.nonlinear);
  // alpha_u = alpha_v is isotropic, and accepted.
  Bsdf a = material("<bsdf type=\"roughplastic\"><float name=\"alpha_u\" value=\"0.2\"/>"
                    "<float name=\"alpha_v\" value=\"0.2\"/></bsdf>");
  EXPECT_FLOAT_EQ(a.rough_plastic.alpha, 0.2f);

  Bsdf t = material("<bsdf type=\"twosided\"><bsdf type=\"roughplastic\"/></bsdf>");
  EXPECT_TRUE(t.two_sided);
  EXPECT_EQ(t.type, BsdfType::RoughPlastic);

  Bsdf sp = material("<bsdf type=\"plastic\"><boolean name=\"nonlinear\" value=\"true\"/></bsdf>");
  EXPECT_TRUE(sp.smooth_plastic.nonlinear);
}

TEST_F(MitsubaBsdfs, WardDuer) {
  Bsdf w = material("<bsdf type=\"ward\"><string name=\"variant\" value=\"ward-duer\"/>"
                    "<float name=\"alpha_u\" value=\"0.2\"/><float name=\"alpha_v\" value=\"0.1\"/></bsdf>");
  EXPECT_EQ(w.type, BsdfType::Ward);
  EXPECT_EQ(w.ward.variant, luz::WardVariant::WardDuer);
  EXPECT_FLOAT_EQ(w.ward.alpha_u, 0.2f);
  // Dür's normalisation is Ward's divided by sqrt(cos θo cos θi).
  Bsdf o = w;
  o.ward.variant = luz::WardVariant::Ward;
  o.ward.diffuse_reflectance = luz::Color{};
  w.ward.diffuse_reflectance = luz::Color{};
  luz::Vec3 wo = luz::normalize(luz::Vec3{0.3f, 0.1f, 0.8f}), wi = luz::normalize(luz::Vec3{-0.2f, 0.05f, 0.6f});
  EXPECT_FLOAT_EQ(w.f(wo, wi).x, o.f(wo, wi).x / std::sqrt(wo.z * wi.z));
}

TEST_F(MitsubaBsdfs, TwosidedWithTwoBsdfs) {
  luz::Scene s = load(scene(
      "<bsdf type=\"roughconductor\" id=\"metal\"><float name=\"alpha\" value=\"0.2\"/></bsdf>\n"
      "<bsdf type=\"twosided\" id=\"pair\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.2\"/></bsdf>"
      "<ref id=\"metal\"/></bsdf>\n"
      "<bsdf type=\"twosided\" id=\"pair2\"><bsdf type=\"blendbsdf\"><bsdf type=\"diffuse\"/><ref id=\"metal\"/></bsdf>"
      "<bsdf type=\"roughplastic\"/></bsdf>\n"
      "<shape type=\"sphere\"><ref id=\"pair\"/></shape>\n"
      "<shape type=\"sphere\"><ref id=\"pair2\"/></shape>\n"));
  const Bsdf& m = s.materials[s.spheres[0].material].bsdf;
  EXPECT_TRUE(m.two_sided);
  EXPECT_TRUE(m.has_back);
  EXPECT_FALSE(m.blend);
  EXPECT_EQ(m.type, BsdfType::Diffuse);  // the first nested bsdf: the front
  expect_color(m.diffuse.reflectance, 0.2f, 0.2f, 0.2f);
  EXPECT_EQ(m.back.type, BsdfType::RoughConductor);  // the second: the back
  const Bsdf& m2 = s.materials[s.spheres[1].material].bsdf;
  EXPECT_TRUE(m2.blend && m2.has_back);
  EXPECT_EQ(m2.second.type, BsdfType::RoughConductor);
  EXPECT_EQ(m2.back.type, BsdfType::RoughPlastic);
}

// Mitsuba's conductor presets are its spectral data integrated to RGB
// (fresnel.h). Bitterli's Veach-MIS scene, converted to Mitsuba 3, spells out
// Mitsuba's RGB copper by number (computed by an older Mitsuba with a finer
// CIE table): the preset must agree with it to 1% (the older 650/550/450 nm
// point samples differed by up to 35%).
TEST_F(MitsubaBsdfs, ConductorPresetsAreMitsubasRgb) {
  Color eta, k;
  ASSERT_TRUE(luz::find_conductor_preset("Cu", eta, k));
  const Color bitterli_eta = {0.200438f, 0.924033f, 1.10221f}, bitterli_k = {3.91295f, 2.45285f, 2.14219f};
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(eta[c], bitterli_eta[c], 0.01f * bitterli_eta[c]) << c;
    EXPECT_NEAR(k[c], bitterli_k[c], 0.01f * bitterli_k[c]) << c;
  }
  for (const char* name : {"Au", "Ag", "Cu", "Al", "Cr", "none"})
    EXPECT_TRUE(luz::find_conductor_preset(name, eta, k)) << name;
  // Normal-incidence reflectance of gold: reddish-yellow (R > G > B).
  ASSERT_TRUE(luz::find_conductor_preset("Au", eta, k));
  Color f0 = luz::fresnel_conductor(1.f, eta, k);
  EXPECT_GT(f0.x, f0.y);
  EXPECT_GT(f0.y, f0.z);
}

// A twosided pair seen from both sides, through the loader and the path
// tracer: a unit square (one-sided geometry, normal +z) with the pair
// (diffuse front, diffuse back of another colour) in a constant environment
// of radiance 1. Nothing else is in the scene, so every pixel on the square
// is, in expectation, the albedo of the side the camera sees: the front's
// from +z, the back's from -z. Per channel, the mean over the square's
// pixels must lie within z·σ of it (σ from the pixels' spread; z Šidák over
// 2 views × 3 channels at α = 1e-3).
TEST_F(MitsubaBsdfs, TwosidedPairRendersEachSide) {
  const Color front = {0.2f, 0.4f, 0.6f}, back = {0.7f, 0.5f, 0.3f};
  for (int view = 0; view < 2; ++view) {
    const char* origin = view == 0 ? "0, 0, 4" : "0, 0, -4";
    std::string xml =
        std::string("<scene version=\"3.0.0\">\n<integrator type=\"path\"/>\n<sensor type=\"perspective\">"
                    "<float name=\"fov\" value=\"20\"/><transform name=\"to_world\"><lookat origin=\"") +
        origin +
        "\" target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>"
        "<sampler type=\"independent\"><integer name=\"sample_count\" value=\"16\"/></sampler>"
        "<film type=\"hdrfilm\"><integer name=\"width\" value=\"24\"/><integer name=\"height\" value=\"24\"/>"
        "<rfilter type=\"box\"/></film></sensor>\n"
        "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/></emitter>\n"
        "<shape type=\"rectangle\"><bsdf type=\"twosided\">"
        "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.2, 0.4, 0.6\"/></bsdf>"
        "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.7, 0.5, 0.3\"/></bsdf>"
        "</bsdf></shape>\n</scene>\n";
    luz::Scene sc = load(xml);
    luz::CpuRenderOptions opt;
    opt.threads = 2;
    luz::RenderStats stats;
    luz::Film film = luz::render_cpu(sc, opt, stats);
    EXPECT_EQ(stats.discarded, 0u);
    std::vector<float> px = film.mean();
    // The square fills the view (it spans ±1 at distance 4; the 20° view ±0.7):
    // the central 16×16 pixels are all on it.
    const Color& expect = view == 0 ? front : back;
    const double z = luz_test::sidak_z(1e-3, 6.0);
    for (int c = 0; c < 3; ++c) {
      double sum = 0, sum2 = 0;
      int n = 0;
      for (int y = 4; y < 20; ++y)
        for (int x = 4; x < 20; ++x) {
          double v = px[size_t(3 * (y * film.width + x) + c)];
          sum += v;
          sum2 += v * v;
          ++n;
        }
      double mean = sum / n, sd = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
      EXPECT_NEAR(mean, expect[c], z * sd + 1e-6) << (view == 0 ? "front" : "back") << " channel " << c;
      std::printf("twosided %s channel %d: %.4f ± %.4f (albedo %.2f)\n", view == 0 ? "front" : "back", c, mean, sd,
                  expect[c]);
    }
  }
}

// Mitsuba 3's principled: its defaults, every parameter by its name,
// specular or eta, spec_trans choosing the transmissive model (a number
// other than 0, or a texture), textures bound to their parameters, and the
// errors.
TEST_F(MitsubaBsdfs, Principled) {
  Bsdf d = material("<bsdf type=\"principled\"/>");
  EXPECT_EQ(d.type, BsdfType::Principled);
  EXPECT_FALSE(d.two_sided);
  expect_color(d.principled.base_color, .5f, .5f, .5f);
  EXPECT_FLOAT_EQ(d.principled.roughness, .5f);
  EXPECT_NEAR(d.principled.eta, 1.5f, 1e-6f);  // specular 0.5
  EXPECT_EQ(d.principled.metallic + d.principled.sheen + d.principled.clearcoat + d.principled.spec_tint, 0.f);
  EXPECT_FLOAT_EQ(d.principled.spec_rate + d.principled.clearcoat_rate + d.principled.diffuse_rate, 3.f);

  // The example of Mitsuba 3's documentation.
  Bsdf e = material(
      "<bsdf type=\"principled\"><rgb name=\"base_color\" value=\"1.0,0.5,0.25\"/><float name=\"metallic\" value=\"0.7\"/>"
      "<float name=\"specular\" value=\"0.6\"/><float name=\"roughness\" value=\"0.2\"/>"
      "<float name=\"spec_tint\" value=\"0.4\"/><float name=\"anisotropic\" value=\"0.5\"/>"
      "<float name=\"sheen\" value=\"0.3\"/><float name=\"sheen_tint\" value=\"0.2\"/>"
      "<float name=\"clearcoat\" value=\"0.6\"/><float name=\"clearcoat_gloss\" value=\"0.3\"/>"
      "<float name=\"spec_trans\" value=\"0.4\"/><float name=\"flatness\" value=\"0.1\"/>"
      "<float name=\"main_specular_sampling_rate\" value=\"2\"/><float name=\"clearcoat_sampling_rate\" value=\"0.5\"/>"
      "<float name=\"diffuse_reflectance_sampling_rate\" value=\"3\"/></bsdf>");
  ASSERT_EQ(e.type, BsdfType::PrincipledTransmission);
  EXPECT_TRUE(e.has_transmission());
  const luz::PrincipledParams& q = e.principled_transmission;
  expect_color(q.base_color, 1.f, .5f, .25f);
  EXPECT_FLOAT_EQ(q.metallic, .7f);
  EXPECT_FLOAT_EQ(q.eta, 2.f / (1.f - std::sqrt(0.08f * .6f)) - 1.f);
  EXPECT_FLOAT_EQ(q.roughness, .2f);
  EXPECT_FLOAT_EQ(q.spec_tint, .4f);
  EXPECT_FLOAT_EQ(q.anisotropic, .5f);
  EXPECT_FLOAT_EQ(q.sheen, .3f);
  EXPECT_FLOAT_EQ(q.sheen_tint, .2f);
  EXPECT_FLOAT_EQ(q.clearcoat, .6f);
  EXPECT_FLOAT_EQ(q.clearcoat_gloss, .3f);
  EXPECT_FLOAT_EQ(q.spec_trans, .4f);
  EXPECT_FLOAT_EQ(q.flatness, .1f);
  EXPECT_FLOAT_EQ(q.spec_rate, 2.f);
  EXPECT_FLOAT_EQ(q.clearcoat_rate, .5f);
  EXPECT_FLOAT_EQ(q.diffuse_rate, 3.f);

  // spec_trans 0 is no transmission (Mitsuba's get_flag); eta as given, and
  // 1 raised to 1.001 (specular 0 to 1e-3) where the material transmits, as
  // Mitsuba; within 1e-3 of 1 likewise (NaN weights in float there).
  EXPECT_EQ(material("<bsdf type=\"principled\"><float name=\"spec_trans\" value=\"0\"/></bsdf>").type, BsdfType::Principled);
  EXPECT_FLOAT_EQ(material("<bsdf type=\"principled\"><float name=\"eta\" value=\"1.33\"/></bsdf>").principled.eta, 1.33f);
  EXPECT_FLOAT_EQ(material("<bsdf type=\"principled\"><float name=\"eta\" value=\"1\"/></bsdf>").principled.eta, 1.f);
  EXPECT_FLOAT_EQ(material("<bsdf type=\"principled\"><float name=\"eta\" value=\"1\"/>"
                           "<float name=\"spec_trans\" value=\"1\"/></bsdf>").principled_transmission.eta, 1.001f);
  EXPECT_FLOAT_EQ(material("<bsdf type=\"principled\"><float name=\"eta\" value=\"0.9995\"/>"
                           "<float name=\"spec_trans\" value=\"1\"/></bsdf>").principled_transmission.eta, 1.f / 1.001f);
  EXPECT_FLOAT_EQ(material("<bsdf type=\"principled\"><float name=\"specular\" value=\"0\"/>"
                           "<float name=\"spec_trans\" value=\"1\"/></bsdf>").principled_transmission.eta,
                  2.f / (1.f - std::sqrt(0.08f * 1e-3f)) - 1.f);
  EXPECT_TRUE(material("<bsdf type=\"twosided\"><bsdf type=\"principled\"/></bsdf>").two_sided);

  // Textures: each bound to its parameter; a textured spec_trans transmits.
  luz::Scene s = load(
      "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n<shape type=\"sphere\">\n<bsdf type=\"principled\">"
      "<texture type=\"checkerboard\" name=\"base_color\"/>"
      "<texture type=\"checkerboard\" name=\"roughness\"><rgb name=\"color0\" value=\"0.8\"/></texture>"
      "<texture type=\"checkerboard\" name=\"spec_trans\"/><texture type=\"checkerboard\" name=\"clearcoat_gloss\"/>"
      "</bsdf>\n</shape>\n</scene>\n");
  const luz::Material& m = s.materials[s.spheres[0].material];
  ASSERT_EQ(m.bsdf.type, BsdfType::PrincipledTransmission);
  ASSERT_EQ(m.num_bindings, 4u);
  const luz::BsdfParam expect[] = {luz::BsdfParam::BaseColor, luz::BsdfParam::Roughness, luz::BsdfParam::Transmission,
                                   luz::BsdfParam::ClearcoatGloss};
  for (uint32_t k = 0; k < 4; ++k) EXPECT_EQ(s.texture_bindings[m.first_binding + k].param, expect[k]) << k;
  EXPECT_FLOAT_EQ(m.bsdf.principled_transmission.roughness, 0.5f);  // the mean of 0.8 and color1 0.2

  // A float texture straying above 1 (an EXR roughness map) is clamped
  // where looked up, with a warning; a constant outside [0, 1] is an error.
  luz::Image rough;
  rough.width = rough.height = 2;
  rough.rgb = {1.25f, 1.25f, 1.25f, .5f, .5f, .5f, .5f, .5f, .5f, .2f, .2f, .2f};
  luz::write_image((dir / "rough.pfm").string(), rough);
  luz::Scene c = load("<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n<shape type=\"sphere\">\n"
                      "<bsdf type=\"principled\"><texture type=\"bitmap\" name=\"roughness\">"
                      "<string name=\"filename\" value=\"rough.pfm\"/></texture></bsdf>\n</shape>\n</scene>\n");
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_NE(c.warnings[0].find("principled 'roughness' texture has texels outside [0, 1]: clamped"), std::string::npos)
      << c.warnings[0];
  const luz::Material& cm = c.materials[c.spheres[0].material];
  ASSERT_EQ(cm.num_bindings, 1u);
  EXPECT_EQ(c.texture_bindings[cm.first_binding].map, luz::TextureMap::Clamp01);
  const luz::SceneView cv = c.view();
  EXPECT_FLOAT_EQ(cv.materials.bsdf(0, cv.textures, {0.25f, 0.25f}).principled.roughness, 1.f);   // 1.25, clamped
  EXPECT_FLOAT_EQ(cv.materials.bsdf(0, cv.textures, {0.25f, 0.75f}).principled.roughness, .5f);
  EXPECT_FLOAT_EQ(cv.materials.bsdf(0, cv.textures, {0.75f, 0.75f}).principled.roughness, .2f);

  // A sampling rate of 0 still samples its lobe, with a warning.
  luz::Scene w = load(scene("<bsdf type=\"principled\"><float name=\"clearcoat_sampling_rate\" value=\"0\"/></bsdf>\n"));
  ASSERT_EQ(w.warnings.size(), 1u);
  EXPECT_NE(w.warnings[0].find("scene.xml:3: warning: principled 'clearcoat_sampling_rate' 0"), std::string::npos)
      << w.warnings[0];

  expect_error("<bsdf type=\"principled\"><float name=\"roughness\" value=\"1.5\"/></bsdf>\n", 3,
               "principled 'roughness' must lie in [0, 1]");
  expect_error("<bsdf type=\"principled\"><float name=\"sheen\" value=\"-0.1\"/></bsdf>\n", 3,
               "principled 'sheen' must lie in [0, 1]");
  expect_error("<bsdf type=\"principled\"><rgb name=\"base_color\" value=\"1.2, 0.5, 0.5\"/></bsdf>\n", 3,
               "'base_color' must lie in [0, 1]");
  expect_error("<bsdf type=\"principled\"><float name=\"eta\" value=\"1.5\"/><float name=\"specular\" value=\"0.5\"/>"
               "</bsdf>\n",
               3, "either 'eta' or 'specular', not both");
  expect_error("<bsdf type=\"principled\"><float name=\"eta\" value=\"0\"/></bsdf>\n", 3, "'eta' must lie in [0.1, 10]");
  expect_error("<bsdf type=\"principled\"><float name=\"specular\" value=\"2\"/></bsdf>\n", 3,
               "'specular' must lie in [0, 1]");
  expect_error("<bsdf type=\"principled\"><float name=\"main_specular_sampling_rate\" value=\"-1\"/></bsdf>\n", 3,
               "'main_specular_sampling_rate' must be a finite number ≥ 0");
  expect_error("<bsdf type=\"principled\"><texture type=\"checkerboard\" name=\"eta\"/></bsdf>\n", 3, "eta");
  expect_error("<bsdf type=\"principled\"><float name=\"subsurface\" value=\"0.5\"/></bsdf>\n", 3,
               "unknown parameter 'subsurface'");
  expect_error("<bsdf type=\"twosided\">\n<bsdf type=\"principled\"><float name=\"spec_trans\" value=\"0.5\"/></bsdf>"
               "</bsdf>\n",
               4, "twosided cannot wrap a material that transmits light");
}

// Mitsuba 3's principledthin: its defaults, its parameters (diff_trans in
// [0, 2], eta a number or a texture), what the mitsuba-blender add-on
// writes for Blender's Translucent BSDF, and the errors.
TEST_F(MitsubaBsdfs, PrincipledThin) {
  Bsdf d = material("<bsdf type=\"principledthin\"/>");
  ASSERT_EQ(d.type, BsdfType::PrincipledThin);
  EXPECT_TRUE(d.has_transmission());
  expect_color(d.principled_thin.base_color, .5f, .5f, .5f);
  EXPECT_FLOAT_EQ(d.principled_thin.roughness, .5f);
  EXPECT_FLOAT_EQ(d.principled_thin.eta, 1.5f);
  EXPECT_EQ(d.principled_thin.spec_trans + d.principled_thin.diff_trans, 0.f);
  // The example of Mitsuba 3's documentation, and the sampling rates.
  Bsdf e = material(
      "<bsdf type=\"principledthin\"><rgb name=\"base_color\" value=\"0.7,0.1,0.1\"/>"
      "<float name=\"roughness\" value=\"0.15\"/><float name=\"spec_tint\" value=\"0.1\"/>"
      "<float name=\"anisotropic\" value=\"0.5\"/><float name=\"spec_trans\" value=\"0.8\"/>"
      "<float name=\"diff_trans\" value=\"0.3\"/><float name=\"eta\" value=\"1.33\"/>"
      "<float name=\"sheen\" value=\"0.2\"/><float name=\"sheen_tint\" value=\"0.4\"/><float name=\"flatness\" value=\"0.6\"/>"
      "<float name=\"specular_reflectance_sampling_rate\" value=\"2\"/>"
      "<float name=\"specular_transmittance_sampling_rate\" value=\"3\"/>"
      "<float name=\"diffuse_reflectance_sampling_rate\" value=\"4\"/>"
      "<float name=\"diffuse_transmittance_sampling_rate\" value=\"5\"/></bsdf>");
  const luz::PrincipledThinBsdf& q = e.principled_thin;
  expect_color(q.base_color, .7f, .1f, .1f);
  EXPECT_FLOAT_EQ(q.roughness, .15f);
  EXPECT_FLOAT_EQ(q.spec_tint, .1f);
  EXPECT_FLOAT_EQ(q.anisotropic, .5f);
  EXPECT_FLOAT_EQ(q.spec_trans, .8f);
  EXPECT_FLOAT_EQ(q.diff_trans, .3f);
  EXPECT_FLOAT_EQ(q.eta, 1.33f);
  EXPECT_FLOAT_EQ(q.sheen, .2f);
  EXPECT_FLOAT_EQ(q.sheen_tint, .4f);
  EXPECT_FLOAT_EQ(q.flatness, .6f);
  EXPECT_FLOAT_EQ(q.spec_rate, 2.f);
  EXPECT_FLOAT_EQ(q.spec_trans_rate, 3.f);
  EXPECT_FLOAT_EQ(q.diffuse_rate, 4.f);
  EXPECT_FLOAT_EQ(q.diff_trans_rate, 5.f);
  // Blender's Translucent BSDF as the mitsuba-blender add-on exports it.
  EXPECT_FLOAT_EQ(material("<bsdf type=\"principledthin\"><rgb name=\"base_color\" value=\"0.2,0.6,0.4\"/>"
                           "<float name=\"diff_trans\" value=\"2\"/></bsdf>").principled_thin.diff_trans, 2.f);
  // eta and diff_trans as textures.
  luz::Scene s = load(
      "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n<shape type=\"sphere\">\n<bsdf type=\"principledthin\">"
      "<texture type=\"checkerboard\" name=\"eta\"><rgb name=\"color0\" value=\"1.2\"/><rgb name=\"color1\" value=\"1.6\"/></texture>"
      "<texture type=\"checkerboard\" name=\"diff_trans\"><rgb name=\"color0\" value=\"2\"/></texture>"
      "</bsdf>\n</shape>\n</scene>\n");
  const luz::Material& m = s.materials[s.spheres[0].material];
  ASSERT_EQ(m.num_bindings, 2u);
  EXPECT_EQ(s.texture_bindings[m.first_binding].param, luz::BsdfParam::DiffuseTransmission);
  EXPECT_EQ(s.texture_bindings[m.first_binding + 1].param, luz::BsdfParam::Eta);
  EXPECT_FLOAT_EQ(m.bsdf.principled_thin.eta, 1.4f);  // the texture's mean
  EXPECT_FLOAT_EQ(m.bsdf.principled_thin.diff_trans, 1.1f);

  expect_error("<bsdf type=\"principledthin\"><float name=\"diff_trans\" value=\"2.5\"/></bsdf>\n", 3,
               "principledthin 'diff_trans' must lie in [0, 2]");
  expect_error("<bsdf type=\"principledthin\"><float name=\"eta\" value=\"20\"/></bsdf>\n", 3,
               "principledthin 'eta' must lie in [0.1, 10]");
  expect_error("<bsdf type=\"principledthin\"><texture type=\"checkerboard\" name=\"eta\">"
               "<rgb name=\"color0\" value=\"0.05\"/></texture></bsdf>\n", 3,
               "principledthin 'eta' texture's texels must lie in [0.1, 10]");
  expect_error("<bsdf type=\"principledthin\"><float name=\"metallic\" value=\"0.5\"/></bsdf>\n", 3,
               "unknown parameter 'metallic'");
  expect_error("<bsdf type=\"principledthin\"><float name=\"roughness\" value=\"2\"/></bsdf>\n", 3,
               "principledthin 'roughness' must lie in [0, 1]");
  expect_error("<bsdf type=\"twosided\">\n<bsdf type=\"principledthin\"/></bsdf>\n", 4,
               "twosided cannot wrap a material that transmits light");
}
