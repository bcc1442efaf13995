// The luz command line on bad input and on good input. Each test runs the
// real binary (LUZ_BINARY) in a fresh temporary directory and checks, for bad
// input: exit status 2 (never a signal), exactly one line on stderr naming the
// file, the line (where the input has lines) and the problem, and no output
// image (nor a temporary .part file) left behind. Good input: tiny renders to
// every image format, -D overrides, the bundled OBJ and Mitsuba scenes.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli_helpers.h"
#include "luz/io/error.h"
#include "luz/io/image.h"

namespace fs = std::filesystem;

namespace {

using luz_test::CliResult;
using luz_test::slurp;
using Result = CliResult;

void write_file(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary);
  out << text;
  ASSERT_TRUE(out.good()) << p;
}

// 1-based line of the first occurrence of needle in text.
int line_of(const std::string& text, const std::string& needle) {
  size_t at = text.find(needle);
  if (at == std::string::npos) return -1;
  return 1 + int(std::count(text.begin(), text.begin() + std::ptrdiff_t(at), '\n'));
}

std::string replace(std::string s, const std::string& from, const std::string& to) {
  size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << "test bug: '" << from << "' not in the scene";
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

// A tiny valid scene: an emitting rectangle above a diffuse floor, seen from
// above; 8×6 pixels, 2 samples. Markers in it are replaced by the bad cases.
const char* kScene = R"(<?xml version="1.0"?>
<scene version="3.0.0">
  <default name="w" value="8"/>
  <default name="h" value="6"/>
  <integrator type="path">
    <integer name="max_depth" value="4"/>
  </integrator>
  <sensor type="perspective">
    <float name="fov" value="60"/>
    <transform name="to_world">
      <lookat origin="0, 3, 0" target="0, 0, 0" up="0, 0, 1"/>
    </transform>
    <sampler type="independent">
      <integer name="sample_count" value="2"/>
    </sampler>
    <film type="hdrfilm">
      <integer name="width" value="$w"/>
      <integer name="height" value="$h"/>
      <rfilter type="box"/>
    </film>
  </sensor>
  <bsdf type="diffuse" id="floor">
    <rgb name="reflectance" value="0.5, 0.5, 0.5"/>
  </bsdf>
  <shape type="rectangle">
    <transform name="to_world">
      <rotate x="1" angle="-90"/>
      <scale value="2"/>
    </transform>
    <ref id="floor"/>
  </shape>
  <shape type="rectangle">
    <transform name="to_world">
      <scale value="0.5"/>
      <rotate x="1" angle="90"/>
      <translate y="2"/>
    </transform>
    <emitter type="area">
      <rgb name="radiance" value="4, 4, 4"/>
    </emitter>
  </shape>
</scene>
)";

class Cli : public luz_test::LuzCliTest {
 protected:
  // Runs luz on bad input and checks the contract: status 2, one stderr line
  // that contains `file` (and ":line:" when line > 0) and `problem`, nothing written.
  void expect_bad(const std::vector<std::string>& args, const std::string& file, int line, const std::string& problem) {
    std::set<std::string> before = listing();
    Result r = run(args);
    std::string cmd;
    for (const std::string& a : args) cmd += " " + a;
    SCOPED_TRACE("luz" + cmd + "\nstderr: " + r.err);
    ASSERT_TRUE(r.exited) << "killed by signal " << r.signal;
    EXPECT_EQ(r.status, 2);
    ASSERT_FALSE(r.err.empty());
    EXPECT_EQ(r.err.back(), '\n');
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "stderr must be exactly one line";
    std::string msg = r.err.substr(0, r.err.size() - 1);
    if (!file.empty()) {
      EXPECT_EQ(msg.rfind(file, 0), 0u) << "the message must start with the file";
      if (line > 0) {
        EXPECT_EQ(msg.rfind(file + ":" + std::to_string(line) + ": error: ", 0), 0u) << "expected line " << line;
      } else if (line < 0) {  // some line, no matter which
        size_t after = file.size() + 1, digits = 0;
        while (after + digits < msg.size() && std::isdigit((unsigned char)msg[after + digits])) ++digits;
        EXPECT_TRUE(msg.compare(file.size(), 1, ":") == 0 && digits > 0 &&
                    msg.compare(after + digits, 9, ": error: ") == 0)
            << "expected file:line: error:";
      } else {
        EXPECT_EQ(msg.rfind(file + ": error: ", 0), 0u);
      }
    } else {
      EXPECT_EQ(msg.rfind("luz: error: ", 0), 0u);
    }
    EXPECT_NE(msg.find(problem), std::string::npos) << "expected the problem '" << problem << "'";
    EXPECT_EQ(listing(), before) << "nothing may be written on bad input";
    last_message = msg;
  }

  // Writes scene text as name and expects it to be refused at the line of marker.
  void expect_bad_scene(const std::string& text, const std::string& marker, const std::string& problem,
                        const std::string& name = "scene.xml") {
    write_file(dir / name, text);
    // No marker: the problem is somewhere in the file, any line will do.
    int line = marker.empty() ? -1 : line_of(text, marker);
    ASSERT_TRUE(marker.empty() || line != -1) << "test bug: marker '" << marker << "' not found";
    expect_bad({"render", name, "-o", "out.exr", "--threads", "1"}, name, line, problem);
  }

  std::string last_message;
};

// ---------------------------------------------------------------- bad input

TEST_F(Cli, MissingSceneFile) {
  expect_bad({"render", "missing.xml", "-o", "out.exr"}, "missing.xml", 0, "cannot open file");
  expect_bad({"render", "missing.obj", "-o", "out.exr"}, "missing.obj", 0, "cannot open file");
}

TEST_F(Cli, SceneIsADirectory) {
  fs::create_directory(dir / "d.xml");
  expect_bad({"render", "d.xml", "-o", "out.exr"}, "d.xml", 0, "directory");
}

TEST_F(Cli, UnknownSceneFormat) {
  write_file(dir / "scene.stl", "solid x\n");
  expect_bad({"render", "scene.stl", "-o", "out.exr"}, "scene.stl", 0, "unknown scene format");
}

TEST_F(Cli, MalformedXmlUnclosedTag) {
  std::string text = replace(kScene, "  </shape>\n</scene>", "\n</scene>");  // the last <shape> never closes
  expect_bad_scene(text, "</scene>", "malformed XML");
}

TEST_F(Cli, MalformedXmlTruncated) {
  std::string text = kScene;
  text.resize(text.find("<bsdf type=\"diffuse\" id=\"floor\">") + 10);  // cut inside a tag, no newline after
  int last = int(std::count(text.begin(), text.end(), '\n')) + 1;
  write_file(dir / "scene.xml", text);
  expect_bad({"render", "scene.xml", "-o", "out.exr"}, "scene.xml", last, "malformed XML");
}

TEST_F(Cli, MalformedXmlGarbage) {
  expect_bad_scene("this is not a scene\n", "", "");
  EXPECT_NE(last_message.find("malformed XML"), std::string::npos);
  expect_bad_scene(std::string("\x7f" "ELF\x01\x02\x00\x00<<<>>>&&&\n", 17), "", "malformed XML");
  expect_bad_scene("", "", "malformed XML");
  expect_bad_scene("<?xml version=\"1.0\"?>\n<notascene/>\n", "<notascene", "root element must be <scene>");
}

TEST_F(Cli, UnknownPlugins) {
  expect_bad_scene(replace(kScene, "<bsdf type=\"diffuse\" id=\"floor\">", "<bsdf type=\"foo\" id=\"floor\">"),
                   "<bsdf type=\"foo\"", "unknown bsdf 'foo'");
  expect_bad_scene(replace(kScene, "<shape type=\"rectangle\">", "<shape type=\"bsplinecurve\">"),
                   "<shape type=\"bsplinecurve\">", "unknown shape 'bsplinecurve'");
  expect_bad_scene(replace(kScene, "<rfilter type=\"box\"/>", "<rfilter type=\"lanczos\"/>"), "<rfilter",
                   "unknown rfilter 'lanczos'");
  expect_bad_scene(replace(kScene, "<sampler type=\"independent\">", "<sampler type=\"multijitter\">"), "<sampler",
                   "unknown sampler 'multijitter'");
  expect_bad_scene(replace(kScene, "<emitter type=\"area\">", "<emitter type=\"point\">"), "<emitter",
                   "unknown shape emitter 'point'");
  expect_bad_scene(replace(kScene, "<sensor type=\"perspective\">", "<sensor type=\"radiancemeter\">"), "<sensor",
                   "unknown sensor 'radiancemeter'");
  expect_bad_scene(replace(kScene, "  <bsdf type=\"diffuse\" id=\"floor\">", "  <medium type=\"homogeneous\"/>\n  <bsdf type=\"diffuse\" id=\"floor\">"),
                   "<medium", "unsupported element <medium>");
}

TEST_F(Cli, UnknownParameter) {
  std::string text = replace(kScene, "<rgb name=\"reflectance\" value=\"0.5, 0.5, 0.5\"/>",
                             "<rgb name=\"reflectance\" value=\"0.5, 0.5, 0.5\"/>\n    <float name=\"bogus\" value=\"1\"/>");
  expect_bad_scene(text, "bogus", "unknown parameter 'bogus'");
  expect_bad_scene(replace(kScene, "<integer name=\"max_depth\" value=\"4\"/>", "<integer name=\"maxdepth\" value=\"4\"/>"),
                   "maxdepth", "unknown parameter 'maxdepth'");
}

TEST_F(Cli, WrongParameterType) {
  expect_bad_scene(replace(kScene, "<rgb name=\"reflectance\" value=\"0.5, 0.5, 0.5\"/>",
                           "<string name=\"reflectance\" value=\"red\"/>"),
                   "<string name=\"reflectance\"", "wrong type <string>");
  expect_bad_scene(replace(kScene, "<integer name=\"max_depth\" value=\"4\"/>", "<float name=\"max_depth\" value=\"4\"/>"),
                   "<float name=\"max_depth\"", "wrong type <float>");
  expect_bad_scene(replace(kScene, "<integer name=\"max_depth\" value=\"4\"/>", "<integer name=\"max_depth\" value=\"4.5\"/>"),
                   "max_depth", "must be an integer");
  expect_bad_scene(replace(kScene, "<float name=\"fov\" value=\"60\"/>", "<float name=\"fov\" value=\"sixty\"/>"),
                   "fov", "'sixty' is not a number");
}

TEST_F(Cli, PhongCreatingEnergy) {
  std::string text = replace(kScene, "<bsdf type=\"diffuse\" id=\"floor\">\n    <rgb name=\"reflectance\" value=\"0.5, 0.5, 0.5\"/>",
                             "<bsdf type=\"phong\" id=\"floor\">\n    <rgb name=\"diffuse_reflectance\" value=\"0.7, 0.5, 0.5\"/>\n"
                             "    <rgb name=\"specular_reflectance\" value=\"0.4\"/>");
  expect_bad_scene(text, "<bsdf type=\"phong\"", "diffuse_reflectance + specular_reflectance > 1");
}

TEST_F(Cli, NonFiniteNumbers) {
  for (const char* bad : {"nan", "NaN", "inf", "-inf", "1e999", "1e39"}) {
    SCOPED_TRACE(bad);
    expect_bad_scene(replace(kScene, "<float name=\"fov\" value=\"60\"/>", std::string("<float name=\"fov\" value=\"") + bad + "\"/>"),
                     "<float name=\"fov\"", "'" + std::string(bad) + "'");
    expect_bad_scene(replace(kScene, "value=\"4, 4, 4\"", std::string("value=\"4, ") + bad + ", 4\""), "name=\"radiance\"",
                     "'" + std::string(bad) + "'");
    expect_bad_scene(replace(kScene, "<scale value=\"2\"/>", std::string("<matrix value=\"1 0 0 0 0 1 0 ") + bad +
                                                                 " 0 0 1 0 0 0 0 1\"/>"),
                     "<matrix", "'" + std::string(bad) + "'");
  }
  EXPECT_NE(last_message.find("32-bit float"), std::string::npos) << last_message;  // 1e39: finite, but not as a float
}

// An OBJ referenced by a scene; its problems are reported in the OBJ's own lines.
class CliObj : public Cli {
 protected:
  std::string scene_with_obj() {
    return replace(kScene, "<shape type=\"rectangle\">\n    <transform name=\"to_world\">\n      <rotate x=\"1\" angle=\"-90\"/>\n      <scale value=\"2\"/>\n    </transform>",
                   "<shape type=\"obj\">\n    <string name=\"filename\" value=\"mesh.obj\"/>");
  }
  void expect_bad_obj(const std::string& obj, const std::string& marker, const std::string& problem) {
    write_file(dir / "scene.xml", scene_with_obj());
    write_file(dir / "mesh.obj", obj);
    int line = marker.empty() ? 0 : line_of(obj, marker);  // no marker: a problem of the whole file
    ASSERT_NE(line, -1);
    expect_bad({"render", "scene.xml", "-o", "out.exr", "--threads", "1"}, "mesh.obj", line, problem);
  }
};

TEST_F(CliObj, GoodObjRenders) {
  write_file(dir / "scene.xml", scene_with_obj());
  write_file(dir / "mesh.obj", "# floor\nv -2 0 -2\nv 2 0 -2\nv 2 0 2\nv -2 0 2\nf 1 3 2\nf 1 4 3\n");
  Result r = run({"render", "scene.xml", "-o", "out.pfm", "--threads", "1"});
  ASSERT_TRUE(r.exited);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "out.pfm"));
}

TEST_F(CliObj, NonFiniteVertex) {
  const std::string head = "# a quad\nv -1 0 -1\nv 1 0 -1\n";
  const std::string tail = "v -1 0 1\nf 1 2 3\nf 1 3 4\n";
  for (const char* bad : {"nan", "inf", "-inf", "1e999", "1e39"}) {
    SCOPED_TRACE(bad);
    expect_bad_obj(head + "v 1 " + bad + " 1\n" + tail, std::string("v 1 ") + bad, std::string("'") + bad + "'");
  }
  expect_bad_obj(head + "v 1 0 1\nvn 0 nan 1\n" + tail, "vn 0 nan", "'nan' is not a finite number");
  expect_bad_obj(head + "v 1 zero 1\n" + tail, "v 1 zero", "'zero' is not a number");
  expect_bad_obj(head + "v 1 0\n" + tail, "v 1 0\n", "needs 3 numbers");
}

TEST_F(CliObj, BadFaces) {
  const std::string v = "v -1 0 -1\nv 1 0 -1\nv 1 0 1\n";
  expect_bad_obj(v + "f 1 2 4\n", "f 1 2 4", "vertex index 4 is out of range");
  expect_bad_obj(v + "f 1 2 0\n", "f 1 2 0", "vertex index 0 is out of range");
  expect_bad_obj(v + "f -1 -2 -4\n", "f -1 -2 -4", "vertex index -4 is out of range");
  expect_bad_obj(v + "f 1//1 2//1 3//1\n", "f 1//1", "normal index 1 is out of range");
  expect_bad_obj(v + "f 1 2\n", "f 1 2", "at least 3 vertices");
  expect_bad_obj(v + "f 1 2 x\n", "f 1 2 x", "'x' is not an index");
}

TEST_F(CliObj, EmptyMesh) {
  expect_bad_obj("# vertices, but no faces\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", "", "mesh has no faces");
  expect_bad_obj("", "", "mesh has no faces");
}

TEST_F(CliObj, MissingObjIsReportedAtTheShape) {
  std::string text = scene_with_obj();
  write_file(dir / "scene.xml", text);
  expect_bad({"render", "scene.xml", "-o", "out.exr"}, "scene.xml", line_of(text, "<shape type=\"obj\">"),
             "cannot open OBJ file");
}

TEST_F(CliObj, EmptyObjAsScene) {
  write_file(dir / "model.obj", "v 0 0 0\n");
  expect_bad({"render", "model.obj", "-o", "out.exr"}, "model.obj", 0, "mesh has no faces");
}

TEST_F(Cli, UndefinedReference) {
  expect_bad_scene(replace(kScene, "<ref id=\"floor\"/>", "<ref id=\"flor\"/>"), "<ref id=\"flor\"/>",
                   "no bsdf with id 'flor'");
}

TEST_F(Cli, UndefinedParameter) {
  expect_bad_scene(replace(kScene, "value=\"$h\"", "value=\"$height\""), "$height", "undefined parameter '$height'");
}

TEST_F(Cli, DefineForUndeclaredParameter) {
  write_file(dir / "scene.xml", kScene);
  expect_bad({"render", "scene.xml", "-o", "out.exr", "-D", "spp=4"}, "scene.xml", 0, "-D spp");
  expect_bad({"render", "scene.xml", "-o", "out.exr", "-D", "w"}, "", 0, "-D w: expected name=value");
  expect_bad({"render", "scene.xml", "-o", "out.exr", "-D", "w=4", "-D", "w=5"}, "", 0, "-D w: given twice");
  expect_bad({"render", "scene.xml", "-o", "out.exr", "-D", "w=abc"}, "scene.xml", line_of(kScene, "value=\"$w\""),
             "'abc' is not a number");
  expect_bad({"render", "scene.xml", "-o", "out.exr", "-D", "w=0"}, "scene.xml", line_of(kScene, "<film"),
             "film size");
}

// MTL values are read by tinyobjloader, which turns "nan" into 0 silently: Luz
// checks the MTL files an OBJ names, line by line.
TEST_F(Cli, NonFiniteMtlValue) {
  write_file(dir / "model.obj", "mtllib model.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n");
  write_file(dir / "model.mtl", "newmtl a\nKd 0.5 nan 0.5\n");
  expect_bad({"render", "model.obj", "-o", "out.exr"}, "model.mtl", 2, "'nan' is not a finite number");
  write_file(dir / "model.mtl", "newmtl a\nKd 0.5 0.5 0.5\nNs 1e999\n");
  expect_bad({"render", "model.obj", "-o", "out.exr"}, "model.mtl", 3, "not a finite number");
}

TEST_F(Cli, DefineForObjScene) {
  write_file(dir / "model.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  expect_bad({"render", "model.obj", "-o", "out.exr", "-D", "w=4"}, "model.obj", 0, "-D applies to Mitsuba XML");
}

TEST_F(Cli, BadFlags) {
  write_file(dir / "scene.xml", kScene);
  expect_bad({"render", "scene.xml", "--spp", "0"}, "", 0, "--spp");
  expect_bad({"render", "scene.xml", "--spp", "-3"}, "", 0, "--spp");
  expect_bad({"render", "scene.xml", "--spp", "many"}, "", 0, "--spp");
  expect_bad({"render", "scene.xml", "--sampler", "bogus"}, "", 0, "--sampler");
  expect_bad({"render", "scene.xml", "--integrator", "bdpt"}, "", 0, "--integrator");
  expect_bad({"render", "scene.xml", "--light-sampler", "uniform"}, "", 0, "--light-sampler");
  expect_bad({"render", "scene.xml", "--reconstruction", "gather"}, "", 0, "--reconstruction");
  expect_bad({"render", "scene.xml", "--env-guide", "yes"}, "", 0, "--env-guide");
  expect_bad({"render", "scene.xml", "--max-depth", "0"}, "", 0, "--max-depth");
  expect_bad({"render", "scene.xml", "--threads", "-1"}, "", 0, "--threads");
  expect_bad({"render", "scene.xml", "--bogus"}, "", 0, "--bogus");
  expect_bad({"render", "scene.xml", "--bogus"}, "", 0, "(see luz render --help)");
  expect_bad({"info", "scene.xml", "--res", "8x8"}, "", 0, "(see luz info --help)");
  expect_bad({"render"}, "", 0, "scene");
  expect_bad({}, "", 0, "subcommand");
  expect_bad({}, "", 0, "(see luz --help)");
  expect_bad({"paint", "scene.xml"}, "", 0, "subcommand");
}

TEST_F(Cli, BadOutputs) {
  write_file(dir / "scene.xml", kScene);
  expect_bad({"render", "scene.xml", "-o", "out.jpg"}, "out.jpg", 0, "unknown image format '.jpg'");
  expect_bad({"render", "scene.xml", "-o", "out"}, "out", 0, "no image extension");
  expect_bad({"render", "scene.xml", "-o", "good.exr", "-o", "bad.tiff"}, "bad.tiff", 0, "unknown image format");
  expect_bad({"render", "scene.xml", "-o", "nodir/out.exr"}, "nodir/out.exr", 0, "does not exist");
  fs::create_directory(dir / "d.exr");
  expect_bad({"render", "scene.xml", "-o", "d.exr"}, "d.exr", 0, "is a directory");
}

// ---------------------------------------------------------------- found by fuzzing
// (a mutation campaign over the bundled scenes, OBJ/MTL files and flags, with
// ASan and UBSan, 2026-11-25: each case here crashed, hung, exited 0 on bad
// input or gave an unclear message before its fix)

// Cameras whose rays Embree refuses (it asserts that every origin and
// direction component is finite and below 1.844e18, and aborts): refused at
// the scene's line instead.
TEST_F(Cli, DegenerateOrFarCameras) {
  const std::string lookat = "<lookat origin=\"0, 3, 0\" target=\"0, 0, 0\" up=\"0, 0, 1\"/>";
  for (const char* up : {"0, 0, 0", "0, 0, 1e-30"}) {
    SCOPED_TRACE(up);
    expect_bad_scene(replace(kScene, lookat, std::string("<lookat origin=\"0, 3, 0\" target=\"0, 0, 0\" up=\"") + up + "\"/>"),
                     "<lookat", "up must be a non-zero vector");
  }
  expect_bad_scene(replace(kScene, lookat, "<lookat origin=\"0, 1.9e18, 0\" target=\"0, 0, 0\" up=\"0, 0, 1\"/>"),
                   "<sensor", "too far from the origin");
  expect_bad_scene(replace(kScene, lookat, lookat + "<scale value=\"1e30\"/><scale value=\"1e30\"/>"), "<sensor",
                   "degenerate orientation");
  // An OBJ rendered directly is framed by a camera outside its bounds.
  // Vertices within Embree's range whose framing camera would not be.
  write_file(dir / "huge.obj", "v 0 0 0\nv 9e17 0 0\nv 0 1 0\nf 1 2 3\n");
  expect_bad({"render", "huge.obj", "-o", "out.exr", "--threads", "1"}, "huge.obj", 0, "too large to frame");
  write_file(dir / "far.obj", "v 0 0 0\nv 1e38 0 0\nv 0 1 0\nf 1 2 3\n");
  expect_bad({"render", "far.obj", "-o", "out.exr", "--threads", "1"}, "far.obj", 0, "vertex 1 is not finite or lies beyond 1e18");
}

// Nested bsdfs recurse in the loader: a deep nesting is an error, not a
// stack overflow (5,000 levels crashed). n bsdf elements in all, the floor's
// included: 32 pass the depth check (and are refused for nesting one map in
// another), 33 do not.
TEST_F(Cli, DeeplyNestedBsdfs) {
  luz::Image tex;
  tex.width = tex.height = 2;
  tex.rgb.assign(12, 0.5f);
  luz::write_image((dir / "tex.png").string(), tex);
  const std::string floor = "<bsdf type=\"diffuse\" id=\"floor\">\n    <rgb name=\"reflectance\" value=\"0.5, 0.5, 0.5\"/>\n  </bsdf>";
  auto nested = [&](const std::string& wrapper, int n) {
    std::string open, close;
    for (int k = 0; k < n - 1; ++k) {
      open += "<bsdf type=\"" + wrapper + "\"" + (k == 0 ? " id=\"floor\">" : ">");
      if (wrapper == "bumpmap")
        open += "<texture name=\"map\" type=\"bitmap\"><string name=\"filename\" value=\"tex.png\"/></texture>";
      else
        open += "<float name=\"weight\" value=\"0.5\"/><bsdf type=\"diffuse\"/>";
      close += "</bsdf>";
    }
    return replace(kScene, floor, open + "<bsdf type=\"diffuse\"/>" + close);
  };
  for (int n : {33, 5000}) {
    for (const char* wrapper : {"bumpmap", "blendbsdf"}) {
      SCOPED_TRACE(std::string(wrapper) + " " + std::to_string(n));
      expect_bad_scene(nested(wrapper, n), "", "bsdfs nested more than 32 deep");
    }
  }
  expect_bad_scene(nested("bumpmap", 32), "", "a normalmap or bumpmap inside another is not supported");
}

// sample_count is bounded as --spp is (2^24; it went up to 2^31).
TEST_F(Cli, SampleCountBounds) {
  for (const char* bad : {"0", "-4", "16777217", "5000000000"}) {
    SCOPED_TRACE(bad);
    expect_bad_scene(replace(kScene, "<integer name=\"sample_count\" value=\"2\"/>",
                             std::string("<integer name=\"sample_count\" value=\"") + bad + "\"/>"),
                     "", "");
    EXPECT_NE(last_message.find("sample_count"), std::string::npos) << last_message;
  }
}

TEST_F(Cli, SecondSceneRoot) {
  const std::string text = std::string(kScene) + "<scene version=\"3.0.0\"><shape type=\"ply\"/></scene>\n";
  expect_bad_scene(text, "<scene version=\"3.0.0\"><shape", "unexpected top-level element <scene>");
}

// tinyobjloader also ends lines at a lone "\r" (old Mac files): the checks
// must see the same lines, or what follows a "\r" escapes them.
TEST_F(Cli, CarriageReturnLineEnds) {
  write_file(dir / "cr.obj", "o x\rv 0 0 0\rv 1 0 0\rv 0 nan 0\rf 1 2 3\r");
  expect_bad({"render", "cr.obj", "-o", "out.exr", "--threads", "1"}, "cr.obj", 4, "'nan' is not a finite number");
  write_file(dir / "crm.obj", "mtllib crm.mtl\r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nusemtl a\r\nf 1 2 3\r\n");
  write_file(dir / "crm.mtl", "newmtl a\rKd 0.5 nan 0.5\r");
  expect_bad({"render", "crm.obj", "-o", "out.exr", "--threads", "1"}, "crm.mtl", 2, "'nan' is not a finite number");
  // A valid file with lone "\r" line ends loads.
  write_file(dir / "ok.obj", "v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r");
  Result r = run({"render", "ok.obj", "-o", "ok.pfm", "--threads", "1", "--spp", "1"});
  ASSERT_TRUE(r.exited);
  EXPECT_EQ(r.status, 0) << r.err;
}

// An MTL named by mtllib that is not a regular file (a device that never
// ends, a FIFO that blocks) is refused at the mtllib line; it hung.
TEST_F(Cli, MtllibThatIsNotAFile) {
  write_file(dir / "m.obj", "mtllib /dev/zero\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  expect_bad({"render", "m.obj", "-o", "out.exr"}, "m.obj", 1, "mtllib '/dev/zero' is not a regular file");
  fs::create_directory(dir / "sub.mtl");
  write_file(dir / "d.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nmtllib sub.mtl\nf 1 2 3\n");
  expect_bad({"render", "d.obj", "-o", "out.exr"}, "d.obj", 4, "is not a regular file");
}

// MTL colours of two numbers are refused at their line (one is a grey,
// three an RGB), and out-of-range values were reported against the OBJ
// without a line.
TEST_F(Cli, MtlColoursAndRanges) {
  write_file(dir / "model.obj", "mtllib model.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n");
  for (const char* key : {"Kd", "Ks", "Ke"}) {
    SCOPED_TRACE(key);
    write_file(dir / "model.mtl", std::string("newmtl a\nNs 10\n") + key + " 0.5 0.5\n");
    expect_bad({"render", "model.obj", "-o", "out.exr"}, "model.mtl", 3, std::string("'") + key + "' needs 3 numbers (r g b) or one");
  }
  write_file(dir / "model.mtl", "newmtl a\nKd 0.2 0.2 0.2\nKs 0.1 -2 0.1\n");
  expect_bad({"render", "model.obj", "-o", "out.exr"}, "model.mtl", 3, "'Ks': '-2' must not be negative");
  write_file(dir / "model.mtl", "newmtl a\nKe 1 -1 1\n");
  expect_bad({"render", "model.obj", "-o", "out.exr"}, "model.mtl", 2, "'Ke': '-1' must not be negative");
}

TEST_F(Cli, MaxDepthMessagesSayWhatIsAllowed) {
  write_file(dir / "scene.xml", kScene);
  for (const char* bad : {"0", "3x", "-2", "2000000"}) {
    SCOPED_TRACE(bad);
    expect_bad({"render", "scene.xml", "--max-depth", bad}, "", 0, "--max-depth");
    EXPECT_NE(last_message.find(std::string("'") + bad + "' is not -1 (unbounded) or a depth from 1 to 1048576"),
              std::string::npos) << last_message;
  }
}

// Flags take whole decimal integers in range, and say which (an overflowing
// seed was accepted as another, "0x10" samples as 16).
TEST_F(Cli, IntegerFlagsSayWhatIsAllowed) {
  write_file(dir / "scene.xml", kScene);
  const struct {
    const char *flag, *value, *allowed;
  } cases[] = {{"--seed", "99999999999999999999", "a seed from 0 to 9223372036854775807"},
               {"--seed", "-1", "a seed from 0"},
               {"--spp", "0x10", "a sample count from 1 to 16777216"},
               {"--spp", "16777217", "a sample count"},
               {"--threads", "4097", "a thread count from 0 (all cores) to 4096"},
               {"--threads", "2.5", "a thread count"}};
  for (const auto& c : cases) {
    SCOPED_TRACE(std::string(c.flag) + " " + c.value);
    expect_bad({"render", "scene.xml", c.flag, c.value}, "", 0, c.flag);
    EXPECT_NE(last_message.find(std::string("'") + c.value + "' is not " + c.allowed), std::string::npos)
        << last_message;
  }
}

// A control byte in the input shows as \xNN in the message (it was printed
// raw: invisible, or acted on by the terminal).
TEST_F(Cli, ControlBytesInMessagesAreEscaped) {
  write_file(dir / "c.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 \x1c" "1\n");
  expect_bad({"render", "c.obj", "-o", "out.exr"}, "c.obj", 4, "'\\x1c1' is not an index");
}

// The temporary file beside the output has a short name of its own: an
// output name the directory accepts (here 250 characters) always works.
TEST_F(Cli, LongOutputNames) {
  write_file(dir / "scene.xml", kScene);
  for (const char* ext : {".pfm", ".png", ".exr"}) {
    SCOPED_TRACE(ext);
    const std::string name = std::string(250, 'a') + ext;
    Result r = run({"render", "scene.xml", "-o", name, "--threads", "1"});
    ASSERT_TRUE(r.exited);
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_TRUE(fs::exists(dir / name));
    fs::remove(dir / name);
  }
  EXPECT_EQ(listing(), (std::set<std::string>{"scene.xml"}));
}

// stbi_write_png reported success when its writes failed (a full disk left
// a truncated PNG under the final name, and luz exited 0). With the file size
// limited (RLIMIT_FSIZE: a write past it fails with EFBIG), every format must
// throw and leave no file behind, the temporary included.
TEST_F(Cli, FailedImageWritesThrowAndLeaveNothing) {
  luz::Image img;
  img.width = img.height = 64;
  img.rgb.resize(size_t(64) * 64 * 3);
  uint32_t x = 12345;
  for (float& v : img.rgb) v = float((x = x * 1664525u + 1013904223u) >> 8) * 0x1p-24f;  // noise: no compression
  const std::set<std::string> before = listing();
  std::vector<std::string> not_thrown;
  with_file_size_limit(4096, [&] {
    for (const char* ext : {".png", ".pfm", ".exr"}) {
      try {
        luz::write_image((dir / (std::string("out") + ext)).string(), img);
        not_thrown.push_back(ext);
      } catch (const luz::InputError&) {
      }
    }
  });
  EXPECT_TRUE(not_thrown.empty()) << "no error for " << not_thrown.front();
  EXPECT_EQ(listing(), before);
  // The same image is written when there is room.
  luz::write_image((dir / "out.png").string(), img);
  EXPECT_GT(fs::file_size(dir / "out.png"), 4096u);
}

TEST_F(Cli, HelpSucceeds) {
  Result r = run({"render", "--help"});
  ASSERT_TRUE(r.exited);
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("--spp"), std::string::npos);
  r = run({"--help"});
  ASSERT_TRUE(r.exited);
  EXPECT_EQ(r.status, 0);
}

// ---------------------------------------------------------------- good input

void expect_sane(const luz::Image& img, int w, int h, bool lit = true) {
  ASSERT_EQ(img.width, w);
  ASSERT_EQ(img.height, h);
  ASSERT_EQ(img.rgb.size(), size_t(w) * h * 3);
  double sum = 0;
  for (float v : img.rgb) {
    ASSERT_TRUE(std::isfinite(v));
    ASSERT_GE(v, 0.f);
    sum += v;
  }
  if (lit) EXPECT_GT(sum, 0.0) << "the floor is lit; the image must not be black";
}

TEST_F(Cli, RendersEveryFormat) {
  write_file(dir / "scene.xml", kScene);
  Result r = run({"render", "scene.xml", "-o", "a.exr", "-o", "b.pfm", "-o", "c.png", "--threads", "1"});
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.status, 0) << r.err;
  luz::Image exr = luz::read_exr((dir / "a.exr").string());
  luz::Image pfm = luz::read_pfm((dir / "b.pfm").string());
  expect_sane(exr, 8, 6);
  expect_sane(pfm, 8, 6);
  EXPECT_EQ(exr.rgb, pfm.rgb) << "both float formats hold the same pixels, rows in the same order";
  std::string png = slurp(dir / "c.png");
  ASSERT_GE(png.size(), 24u);
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  // IHDR width and height, big-endian, at bytes 16..23.
  auto be32 = [&](size_t at) {
    return (uint32_t(uint8_t(png[at])) << 24) | (uint32_t(uint8_t(png[at + 1])) << 16) |
           (uint32_t(uint8_t(png[at + 2])) << 8) | uint32_t(uint8_t(png[at + 3]));
  };
  EXPECT_EQ(be32(16), 8u);
  EXPECT_EQ(be32(20), 6u);
  EXPECT_EQ(listing(), (std::set<std::string>{"scene.xml", "a.exr", "b.pfm", "c.png"})) << "no .part file left";
}

TEST_F(Cli, DefaultOutputNameFollowsTheScene) {
  write_file(dir / "box.xml", kScene);
  Result r = run({"render", "box.xml", "--threads", "1", "--spp", "1"});
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.status, 0) << r.err;
  expect_sane(luz::read_exr((dir / "box.exr").string()), 8, 6);
}

TEST_F(Cli, DefineOverridesDefault) {
  write_file(dir / "scene.xml", kScene);
  Result r = run({"render", "scene.xml", "-o", "out.pfm", "--threads", "1", "-D", "w=5", "-D", "h=3"});
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.status, 0) << r.err;
  expect_sane(luz::read_pfm((dir / "out.pfm").string()), 5, 3);
}

TEST_F(Cli, FlagsOverrideTheScene) {
  write_file(dir / "scene.xml", kScene);
  for (const char* sampler : {"independent", "stratified", "sobol"})
    for (const char* integrator : {"path", "bsdf", "light"}) {
      SCOPED_TRACE(std::string(sampler) + " " + integrator);
      Result r = run({"render", "scene.xml", "-o", "out.pfm", "--threads", "1", "--spp", "1", "--seed", "7",
                      "--max-depth", "2", "--sampler", sampler, "--integrator", integrator});
      ASSERT_TRUE(r.exited);
      ASSERT_EQ(r.status, 0) << r.err;
      EXPECT_NE(r.err.find("1 spp"), std::string::npos) << r.err;
      // One sample of 48 pixels: only the path tracer (with light sampling) surely sees light.
      expect_sane(luz::read_pfm((dir / "out.pfm").string()), 8, 6, std::string(integrator) != "bsdf");
    }
  for (const auto& [flag, value] : std::vector<std::pair<std::string, std::string>>{
           {"--light-sampler", "bvh"}, {"--light-sampler", "power"}, {"--reconstruction", "splat"}, {"--reconstruction", "filter"},
           {"--env-guide", "on"}, {"--env-guide", "off"}}) {
    SCOPED_TRACE(flag + " " + value);
    Result r = run({"render", "scene.xml", "-o", "out.pfm", "--threads", "1", "--spp", "1", flag, value});
    ASSERT_TRUE(r.exited);
    ASSERT_EQ(r.status, 0) << r.err;
    expect_sane(luz::read_pfm((dir / "out.pfm").string()), 8, 6, true);
  }
}

TEST_F(Cli, RendersMcGuireObjDirectly) {
  fs::path obj = fs::path(LUZ_SHARED_DIR) / "scenes/cornell-box-mcguire/CornellBox-Original.obj";
  if (!fs::exists(obj)) GTEST_SKIP() << obj << " is not there";
  // The OBJ camera is 512²; one sample per pixel keeps it about a second.
  Result r = run({"render", obj.string(), "-o", "box.pfm", "--spp", "1", "--threads", "1", "--max-depth", "3"});
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.status, 0) << r.err;
  expect_sane(luz::read_pfm((dir / "box.pfm").string()), 512, 512);
}

TEST_F(Cli, RendersBitterliSceneV3Unchanged) {
  fs::path xml = fs::path(LUZ_SHARED_DIR) / "scenes/cornell-box-bitterli/mitsuba3/scene_v3.xml";
  if (!fs::exists(xml)) GTEST_SKIP() << xml << " is not there";
  // Only its own <default>s are overridden: resolution and samples.
  Result r = run({"render", xml.string(), "-o", "box.exr", "-D", "resx=16", "-D", "resy=12", "-D", "spp=2", "--threads",
                  "1"});
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.status, 0) << r.err;
  expect_sane(luz::read_exr((dir / "box.exr").string()), 16, 12);
}

}  // namespace

// luz info: what was loaded, without rendering, and every warning; bad
// input as for render.
TEST_F(Cli, InfoDescribesTheScene) {
  Result r = run({"info", std::string(LUZ_SOURCE_DIR) + "/scenes/cornell-box.xml"});
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* want : {"shapes: 32 triangles, 0 spheres, 0 instances", "lights: 1: 1 area (parallelogram)",
                           "film: 512×512", "integrator: path", "warnings: 0"})
    EXPECT_NE(r.out.find(want), std::string::npos) << want << "\n" << r.out;
  EXPECT_TRUE(listing().empty());  // nothing rendered or written
  write_file(dir / "w.obj", "mtllib none.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  r = run({"info", "w.obj"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("warnings: 2\n  w.obj:1: warning: mtllib 'none.mtl' not found"), std::string::npos) << r.out;
  expect_bad({"info", "missing.xml"}, "missing.xml", 0, "cannot open file");
}

// --res and --scale render any scene at another size (the stats line says
// which, and the load time); bad values are one line, exit 2, before loading.
TEST_F(Cli, ResAndScaleSetTheImageSize) {
  const std::string box = std::string(LUZ_SOURCE_DIR) + "/scenes/cornell-box.xml";
  Result r = run({"render", box, "--res", "24x16", "--spp", "1", "-o", "a.pfm", "--threads", "1"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find(": 24×16, 1 spp"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("loaded in "), std::string::npos) << r.err;
  luz::Image a = luz::read_pfm((dir / "a.pfm").string());
  EXPECT_EQ(a.width, 24);
  EXPECT_EQ(a.height, 16);
  r = run({"render", box, "--scale", "0.05", "--spp", "1", "-o", "b.pfm", "--threads", "1"});
  ASSERT_EQ(r.status, 0) << r.err;
  luz::Image b = luz::read_pfm((dir / "b.pfm").string());
  EXPECT_EQ(b.width, 26);  // 512 × 0.05 = 25.6, rounded
  EXPECT_EQ(b.height, 26);
  expect_bad({"render", box, "--res", "24by16", "-o", "c.pfm"}, "", 0, "--res 24by16: expected WIDTHxHEIGHT");
  expect_bad({"render", box, "--res", "0x16", "-o", "c.pfm"}, "", 0, "each side must be between 1 and 65536");
  expect_bad({"render", box, "--scale", "-1", "-o", "c.pfm"}, "", 0, "not a scale above 0");
}

// Frame sequences: several scenes, or --frames NAME=values, each frame the
// image its own render gives, named by the '#'s of -o; outputs that would
// collide or lack a frame number, and bad --frames values, are one line,
// exit 2, before any rendering.
TEST_F(Cli, FramesRenderEachValueAndScene) {
  const std::string box = std::string(LUZ_SOURCE_DIR) + "/scenes/cornell-box.xml";
  Result r = run({"render", box, "--frames", "res=8,12", "--spp", "2", "-o", "f_###.pfm", "-q"});
  ASSERT_EQ(r.status, 0) << r.err;
  r = run({"render", box, "--frames", "spp=1..2", "-D", "res=8", "-o", "s#.pfm", "-q"});
  ASSERT_EQ(r.status, 0) << r.err;
  const std::vector<std::pair<std::string, std::vector<std::string>>> alone = {
      {"f_001.pfm", {"-D", "res=8", "--spp", "2"}},
      {"f_002.pfm", {"-D", "res=12", "--spp", "2"}},
      {"s1.pfm", {"-D", "res=8", "-D", "spp=1"}},
      {"s2.pfm", {"-D", "res=8", "-D", "spp=2"}}};
  for (const auto& [name, flags] : alone) {
    std::vector<std::string> args = {"render", box, "-o", "alone.pfm", "-q"};
    args.insert(args.end(), flags.begin(), flags.end());
    ASSERT_EQ(run(args).status, 0);
    EXPECT_TRUE(slurp(dir / name) == slurp(dir / "alone.pfm")) << name;
  }
  // Two scenes: each named after its own file by default.
  write_file(dir / "a.xml", slurp(box));
  r = run({"render", box, "a.xml", "-a", std::string(LUZ_SOURCE_DIR) + "/scenes", "-D", "res=8", "--spp", "1", "-q"});
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "cornell-box.exr") && fs::exists(dir / "a.exr"));
  for (const auto& f : {"cornell-box.exr", "a.exr", "alone.pfm", "f_001.pfm", "f_002.pfm", "s1.pfm", "s2.pfm"})
    fs::remove(dir / f);

  expect_bad({"render", box, "--frames", "res=8,12", "-o", "out.pfm"}, "", 0,
             "-o out.pfm: 2 frames need a '#' in the name");
  expect_bad({"render", box, box, "-o", "x#.pfm", "-o", "y.pfm"}, "", 0, "-o y.pfm: 2 frames need a '#'");
  expect_bad({"render", box, box}, "", 0, "-o cornell-box.exr: two frames would write it");
  expect_bad({"render", box, "--frames", "res"}, "", 0, "--frames res: expected NAME=V1,V2,... or NAME=A..B");
  expect_bad({"render", box, "--frames", "res=8,,9", "-o", "#.pfm"}, "", 0, "an empty value");
  expect_bad({"render", box, "--frames", "res=9..8", "-o", "#.pfm"}, "", 0, "a range is A..B");
  expect_bad({"render", box, "--frames", "res=8,12", "-o", "#.pfm", "--checkpoint", "c.ckpt"}, "", 0,
             "--checkpoint c.ckpt: 2 frames need a '#'");
}
