// io/spectrum.h: a blackbody's colour against the CIE 1931 chromaticities
// of the Planckian locus (Wyszecki and Stiles' tables: independent of the
// matching functions' fit used here), its luminance, and pbrt-v4's
// "blackbody" lights as the pbrt reader takes them. Sampled spectra: the
// equal-energy one at illuminant E's chromaticity (1/3, 1/3) by the CIE's
// definition, a blackbody sampled every 5 nm at the blackbody's, and
// pbrt-v4's lights of any spectrum but RGB at luminance 1.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

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

TEST(Spectrum, SampledSpectraAtTheirChromaticity) {
  // Equal energy over 300-800 nm: E (its tails below 360 nm and above 800 nm
  // weigh under 1e-4 of Y); its sRGB is XYZ (1, 1, 1) through the matrix.
  const Vec3 e = sampled_spectrum_xyz({300, 5, 800, 5});
  EXPECT_EQ(e.y, 1.f);
  EXPECT_NEAR(e.x / (e.x + e.y + e.z), 1.0 / 3, 0.003);
  EXPECT_NEAR(e.y / (e.x + e.y + e.z), 1.0 / 3, 0.003);
  const Color rgb = sampled_spectrum_rgb({300, 5, 800, 5});
  EXPECT_NEAR(0.212671 * rgb.x + 0.715160 * rgb.y + 0.072169 * rgb.z, 1.0, 1e-4);
  EXPECT_NEAR(rgb.x, 1.2048, 0.02);
  EXPECT_NEAR(rgb.y, 0.9484, 0.02);
  EXPECT_NEAR(rgb.z, 0.9087, 0.02);
  // Planck's law sampled every 5 nm (piecewise linear between) against the
  // blackbody summed every 1 nm: the interpolation's error only.
  for (double k : {2856.0, 6500.0}) {
    std::vector<double> pairs;
    for (int nm = 355; nm <= 835; nm += 5) {
      const double m = nm * 1e-9;
      pairs.push_back(nm);
      pairs.push_back(1e-30 / (std::pow(m, 5) * std::expm1(1.438776877e-2 / (m * k))));
    }
    const Vec3 s = sampled_spectrum_xyz(pairs), b = blackbody_xyz(k);
    EXPECT_NEAR(s.x, b.x, 1e-3 * b.x) << k;
    EXPECT_NEAR(s.z, b.z, 1e-3 * b.z) << k;
  }
  // Nothing visible, bad pairs.
  EXPECT_THROW(sampled_spectrum_xyz({900, 1, 1000, 1}), std::invalid_argument);
  EXPECT_THROW(sampled_spectrum_xyz({500, 1, 400, 1}), std::invalid_argument);
  EXPECT_THROW(sampled_spectrum_xyz({500, -1, 600, 1}), std::invalid_argument);
  EXPECT_THROW(sampled_spectrum_xyz({500, 1, 600}), std::invalid_argument);
  EXPECT_THROW(sampled_spectrum_xyz({550, 2}), std::invalid_argument);  // one wavelength only
  EXPECT_THROW(sampled_spectrum_xyz({500, 1, double(NAN), 1}), std::invalid_argument);
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

// pbrt-v4 divides every light's spectrum but RGB by its photometric
// integral: a sampled spectrum emits luminance 1 (times `scale`) whatever
// its magnitude, stdillum-D65 sRGB's white; materials keep refusing
// spectra that are not constant.
TEST_F(PbrtBlackbody, LightsOfSampledSpectraHaveLuminanceOne) {
  const std::string head = "Camera \"perspective\"\nWorldBegin\nShape \"sphere\"\n";
  Scene s = load_scene(write("s.pbrt", head + "LightSource \"point\" \"spectrum I\" [ 300 10 800 10 ] \"float scale\" 2\n"
                                              "LightSource \"distant\" \"spectrum L\" \"stdillum-D65\"\n"
                                              "AttributeBegin\nAreaLightSource \"diffuse\" \"spectrum L\" [ 400 0 700 3 ]\n"
                                              "Shape \"sphere\" \"float radius\" 0.5\nAttributeEnd\n"
                                              "LightSource \"point\" \"spectrum I\" [ 400 1 460 1 ]\n"));
  ASSERT_EQ(s.lights.size(), 4u);
  ASSERT_EQ(s.warnings.size(), 1u);  // the violet one lies outside sRGB
  EXPECT_NE(s.warnings[0].find("s.pbrt:10: warning: spectrum 'I' lies outside sRGB"), std::string::npos) << s.warnings[0];
  const Color e = sampled_spectrum_rgb({300, 10, 800, 10}) * 2.f;
  for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(s.lights[0].point.intensity[c], e[c]);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(s.lights[1].directional.irradiance[c], 1.f);
  const Color ramp = s.lights[2].sphere.radiance;
  EXPECT_NEAR(0.212671 * ramp.x + 0.715160 * ramp.y + 0.072169 * ramp.z, 1.0, 1e-4);
  EXPECT_GT(ramp.x, ramp.z);  // rising toward the red
  luz_test::expect_load_refused(write("r.pbrt", head + "Material \"diffuse\" \"spectrum reflectance\" [ 400 0.2 700 0.8 ]\n"),
                                "r.pbrt:4", "a sampled spectrum that is not constant is not supported");
  luz_test::expect_load_refused(write("ir.pbrt", head + "LightSource \"point\" \"spectrum I\" [ 900 1 1000 1 ]\n"),
                                "ir.pbrt:4", "the spectrum has no luminance");
  luz_test::expect_load_refused(write("cu.pbrt", head + "LightSource \"point\" \"spectrum I\" \"metal-Cu-k\"\n"),
                                "cu.pbrt:4", "spectrum 'metal-Cu-k' is not supported (on lights stdillum-D65");
}

}  // namespace
