// io/spectrum.h: a blackbody's colour against the CIE 1931 chromaticities
// of the Planckian locus (Wyszecki and Stiles' tables: independent of the
// matching functions' fit used here), its luminance, and pbrt-v4's
// "blackbody" lights as the pbrt reader takes them.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "luz/io/load.h"
#include "luz/io/spectrum.h"
#include "scene_helpers.h"
#include "temp_dir.h"

using namespace luz;

namespace {

// xy within 0.003, about one just-noticeable difference (a MacAdam ellipse):
// the analytic matching functions' error, largest for the reddest spectra
// (measured: 0.0025 at 2000 K, 0.0012 at 2856 K, below 0.0006 from 4000 K).
TEST(Spectrum, BlackbodyChromaticityIsOnThePlanckianLocus) {
  struct Point {
    double kelvin, x, y;
  } locus[] = {{2000, 0.5267, 0.4133}, {2856, 0.44757, 0.40745}, {4000, 0.3805, 0.3768},
               {5000, 0.3451, 0.3516}, {6500, 0.3135, 0.3237},   {10000, 0.2807, 0.2884}};
  for (const Point& p : locus) {
    const Vec3 c = blackbody_xyz(p.kelvin);
    const double sum = double(c.x) + c.y + c.z;
    EXPECT_EQ(c.y, 1.f);
    EXPECT_NEAR(c.x / sum, p.x, 0.003) << p.kelvin << " K";
    EXPECT_NEAR(c.y / sum, p.y, 0.003) << p.kelvin << " K";
  }
}

// Luminance 1 in sRGB (the Y row of sRGB's XYZ matrix), blue rising with
// temperature, red falling; negative blue only below ~1,900 K.
TEST(Spectrum, BlackbodyRgbHasLuminanceOne) {
  Color prev{};
  for (double k : {1000.0, 1500.0, 2000.0, 3000.0, 6500.0, 12000.0, 40000.0}) {
    const Color c = blackbody_rgb(k);
    EXPECT_NEAR(0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z, 1.0, 1e-4) << k;
    if (k > 1000.0) {
      EXPECT_GT(c.z, prev.z) << k;
      EXPECT_LT(c.x, prev.x) << k;
    }
    EXPECT_EQ(c.z < 0.f, k < 1900.0) << k;
    prev = c;
  }
  for (double bad : {0.0, -5.0, double(NAN), double(INFINITY), 1.0, 1e300})
    EXPECT_THROW(blackbody_rgb(bad), std::invalid_argument) << bad;
}

class PbrtBlackbody : public TempDirTest {};

TEST_F(PbrtBlackbody, LightsTakeItOthersRefuseIt) {
  const std::string head = "Camera \"perspective\"\nWorldBegin\nShape \"sphere\"\n";
  Scene s = load_scene(write("b.pbrt", head + "LightSource \"point\" \"blackbody I\" [ 2856 ] \"float scale\" 3\n"
                                              "LightSource \"distant\" \"blackbody L\" [ 1200 ]\n"));
  ASSERT_EQ(s.lights.size(), 2u);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("b.pbrt:5: warning: blackbody 1200 K is redder than sRGB can show"), std::string::npos)
      << s.warnings[0];
  const Color want = blackbody_rgb(2856) * 3.f;
  const Color got = s.lights[0].point.intensity;
  for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(got[c], want[c]);
  EXPECT_EQ(s.lights[1].directional.irradiance.z, 0.f);
  luz_test::expect_load_refused(write("m.pbrt", head + "Material \"diffuse\" \"blackbody reflectance\" [ 3000 ]\n"),
                                "m.pbrt:4", "a blackbody spectrum is supported on lights only");
  luz_test::expect_load_refused(write("two.pbrt", head + "LightSource \"point\" \"blackbody I\" [ 3000 1 ]\n"),
                                "two.pbrt:4", "blackbody takes one temperature in kelvin");
  luz_test::expect_load_refused(write("cold.pbrt", head + "LightSource \"point\" \"blackbody I\" [ 0 ]\n"),
                                "cold.pbrt:4", "a blackbody temperature must be positive");
}

}  // namespace
