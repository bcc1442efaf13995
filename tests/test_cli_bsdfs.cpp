// The luz command line on scenes with the newer BSDF plugins: bad parameters
// give exit status 2, exactly one stderr line "file:line: error: problem" and
// no output file; a scene using every supported plugin renders to a finite,
// lit image. The process-running fixture is tests/cli_helpers.h.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli_helpers.h"
#include "luz/io/image.h"

namespace fs = std::filesystem;

namespace {

using Result = luz_test::CliResult;
using luz_test::slurp;

int line_of(const std::string& text, const std::string& needle) {
  size_t at = text.find(needle);
  if (at == std::string::npos) return -1;
  return 1 + int(std::count(text.begin(), text.begin() + std::ptrdiff_t(at), '\n'));
}

// A small scene: a floor, an area light, and a sphere whose bsdf is @BSDF@.
const char* kScene = R"(<?xml version="1.0"?>
<scene version="3.0.0">
  <integrator type="path">
    <integer name="max_depth" value="6"/>
  </integrator>
  <sensor type="perspective">
    <float name="fov" value="60"/>
    <transform name="to_world">
      <lookat origin="0, 1, -3" target="0, 0, 0" up="0, 1, 0"/>
    </transform>
    <sampler type="independent">
      <integer name="sample_count" value="4"/>
    </sampler>
    <film type="hdrfilm">
      <integer name="width" value="8"/>
      <integer name="height" value="6"/>
      <rfilter type="box"/>
    </film>
  </sensor>
  <shape type="rectangle">
    <transform name="to_world">
      <rotate x="1" angle="-90"/>
      <scale value="3"/>
      <translate y="-1"/>
    </transform>
  </shape>
  <shape type="rectangle">
    <transform name="to_world">
      <rotate x="1" angle="90"/>
      <translate y="3"/>
    </transform>
    <emitter type="area">
      <rgb name="radiance" value="4, 4, 4"/>
    </emitter>
  </shape>
  <shape type="sphere">
    @BSDF@
  </shape>
</scene>
)";

std::string with_bsdf(const std::string& bsdf) {
  std::string s = kScene;
  s.replace(s.find("@BSDF@"), 6, bsdf);
  return s;
}

class CliBsdfs : public luz_test::LuzCliTest {
 protected:
  // The scene with this bsdf must be refused at the line of `marker` with `problem`.
  void expect_bad(const std::string& bsdf, const std::string& marker, const std::string& problem) {
    std::string text = with_bsdf(bsdf);
    std::ofstream(dir / "scene.xml", std::ios::binary) << text;
    int line = line_of(text, marker);
    ASSERT_GT(line, 0) << "test bug: marker '" << marker << "' not found";
    std::set<std::string> before = listing();
    Result r = run({"render", "scene.xml", "-o", "out.exr", "--threads", "1"});
    SCOPED_TRACE(bsdf + "\nstderr: " + r.err);
    ASSERT_TRUE(r.exited) << "killed by signal " << r.signal;
    EXPECT_EQ(r.status, 2);
    ASSERT_FALSE(r.err.empty());
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "stderr must be exactly one line";
    std::string prefix = "scene.xml:" + std::to_string(line) + ": error: ";
    EXPECT_EQ(r.err.rfind(prefix, 0), 0u) << "expected the prefix " << prefix;
    EXPECT_NE(r.err.find(problem), std::string::npos) << "expected the problem '" << problem << "'";
    EXPECT_EQ(listing(), before) << "nothing may be written on bad input";
  }
};

}  // namespace

TEST_F(CliBsdfs, BadParameters) {
  expect_bad("<bsdf type=\"roughplastic\">\n      <float name=\"alpha\" value=\"-0.05\"/>\n    </bsdf>",
             "<bsdf type=\"roughplastic\"", "must be positive");
  expect_bad("<bsdf type=\"roughplastic\">\n      <float name=\"int_ior\" value=\"0\"/>\n    </bsdf>",
             "<bsdf type=\"roughplastic\"", "'int_ior' must lie in [0.1, 10]");
  expect_bad("<bsdf type=\"roughplastic\">\n      <float name=\"alpha_u\" value=\"0.1\"/>\n"
             "      <float name=\"alpha_v\" value=\"0.3\"/>\n    </bsdf>",
             "<bsdf type=\"roughplastic\"", "isotropic roughness only");
  expect_bad("<bsdf type=\"twosided\">\n      <bsdf type=\"diffuse\"/>\n"
             "      <bsdf type=\"blendbsdf\"><bsdf type=\"diffuse\"/><bsdf type=\"conductor\"/></bsdf>\n    </bsdf>",
             "<bsdf type=\"blendbsdf\"", "as the back side of a twosided is not supported");
  expect_bad("<bsdf type=\"roughconductor\">\n      <float name=\"alpha\" value=\"-0.2\"/>\n    </bsdf>",
             "<bsdf type=\"roughconductor\"", "must be positive");
  expect_bad("<bsdf type=\"dielectric\">\n      <float name=\"int_ior\" value=\"0\"/>\n    </bsdf>",
             "<bsdf type=\"dielectric\"", "'int_ior' must lie in [0.1, 10]");
  expect_bad("<bsdf type=\"dielectric\">\n      <string name=\"int_ior\" value=\"unobtainium\"/>\n    </bsdf>",
             "unobtainium", "unknown index of refraction preset");
  expect_bad("<bsdf type=\"conductor\">\n      <string name=\"material\" value=\"Xx\"/>\n    </bsdf>",
             "<bsdf type=\"conductor\"", "unknown conductor material 'Xx'");
  expect_bad("<bsdf type=\"blendbsdf\">\n      <float name=\"weight\" value=\"-0.5\"/>\n"
             "      <bsdf type=\"diffuse\"/>\n      <bsdf type=\"conductor\"/>\n    </bsdf>",
             "<bsdf type=\"blendbsdf\"", "'weight' must lie in [0, 1]");
  expect_bad("<bsdf type=\"plastic\">\n      <rgb name=\"specular_reflectance\" value=\"1.5\"/>\n    </bsdf>",
             "<bsdf type=\"plastic\"", "[0, 1]");
  expect_bad("<bsdf type=\"ward\">\n      <rgb name=\"diffuse_reflectance\" value=\"0.7\"/>\n"
             "      <rgb name=\"specular_reflectance\" value=\"0.7\"/>\n    </bsdf>",
             "<bsdf type=\"ward\"", "create energy");
  expect_bad("<bsdf type=\"twosided\">\n      <bsdf type=\"dielectric\"/>\n    </bsdf>", "<bsdf type=\"dielectric\"",
             "twosided cannot wrap a material that transmits");  // the line of the nested dielectric
}

TEST_F(CliBsdfs, EveryPluginRenders) {
  const char* bsdfs[] = {
      "<bsdf type=\"conductor\"><string name=\"material\" value=\"Au\"/></bsdf>",
      "<bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"ggx\"/><float name=\"alpha\" value=\"0.2\"/></bsdf>",
      "<bsdf type=\"dielectric\"/>",
      "<bsdf type=\"roughdielectric\"><float name=\"alpha\" value=\"0.2\"/></bsdf>",
      "<bsdf type=\"thindielectric\"/>",
      "<bsdf type=\"plastic\"/>",
      "<bsdf type=\"plastic\"><boolean name=\"nonlinear\" value=\"true\"/></bsdf>",
      "<bsdf type=\"roughplastic\"/>",
      "<bsdf type=\"roughplastic\"><string name=\"distribution\" value=\"ggx\"/><float name=\"alpha\" value=\"0.3\"/>"
      "<boolean name=\"nonlinear\" value=\"true\"/></bsdf>",
      "<bsdf type=\"ward\"><string name=\"variant\" value=\"ward-duer\"/></bsdf>",
      "<bsdf type=\"twosided\"><bsdf type=\"roughplastic\"/><bsdf type=\"conductor\"><string name=\"material\" "
      "value=\"Cu\"/></bsdf></bsdf>",
      "<bsdf type=\"ward\"/>",
      "<bsdf type=\"blinnphong\"/>",
      "<bsdf type=\"blendbsdf\"><bsdf type=\"diffuse\"/><bsdf type=\"dielectric\"/></bsdf>",
      "<bsdf type=\"twosided\"><bsdf type=\"roughconductor\"/></bsdf>",
  };
  for (const char* b : bsdfs) {
    SCOPED_TRACE(b);
    std::ofstream(dir / "scene.xml", std::ios::binary) << with_bsdf(b);
    Result r = run({"render", "scene.xml", "-o", "out.exr", "--threads", "1"});
    ASSERT_TRUE(r.exited);
    ASSERT_EQ(r.status, 0) << r.err;
    luz::Image img = luz::read_exr((dir / "out.exr").string());
    ASSERT_EQ(img.width, 8);
    ASSERT_EQ(img.height, 6);
    double sum = 0;
    for (float v : img.rgb) {
      ASSERT_TRUE(std::isfinite(v));
      ASSERT_GE(v, 0.f);
      sum += v;
    }
    EXPECT_GT(sum, 0.0);
    fs::remove(dir / "out.exr");
  }
}
