// pbrt-v4 scenes (io/pbrt/): the tokenizer and parser on small texts, every
// malformed input as one InputError naming file and line, the translation's
// conventions (camera orientation and field of view, depth, emitting side),
// every shared pbrt-v4 scene loading and rendering with no non-finite
// sample, and Bitterli's Cornell box in pbrt-v4 against its Mitsuba 3
// version within noise.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <functional>
#include <string>
#include <vector>

#include "luz/device/cpu/render.h"
#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "luz/io/pbrt/parser.h"
#include "luz/io/pbrt/tokenizer.h"
#include "luz/scene/scene_info.h"
#include "scene_helpers.h"
#include "stat_helpers.h"
#include "temp_dir.h"

using namespace luz;
using namespace luz::pbrt;

namespace {

const std::string kScenes = LUZ_SHARED_DIR "/scenes";

std::vector<std::string> tokens(const std::string& text, std::vector<int>* lines = nullptr) {
  Tokenizer tz("t.pbrt", text);
  Token t;
  std::vector<std::string> out;
  while (tz.next(t)) {
    out.emplace_back(t.text);
    if (lines) lines->push_back(t.line);
  }
  return out;
}

// A target that records each directive as a line of text.
class Recorder final : public ParserTarget {
 public:
  std::vector<std::string> log;
  std::vector<ParamSet> params;
  void add(const SourceLoc& at, const std::string& s) { log.push_back(std::to_string(at.line) + " " + s); }
  void identity(const SourceLoc& at) override { add(at, "Identity"); }
  void translate(const SourceLoc& at, Vec3 d) override { add(at, "Translate " + v(d)); }
  void scale(const SourceLoc& at, Vec3 s) override { add(at, "Scale " + v(s)); }
  void rotate(const SourceLoc& at, double a, Vec3 x) override { add(at, "Rotate " + n(a) + " " + v(x)); }
  void look_at(const SourceLoc& at, Vec3 e, Vec3 t, Vec3 u) override { add(at, "LookAt " + v(e) + " " + v(t) + " " + v(u)); }
  void concat_transform(const SourceLoc& at, const double m[16]) override { add(at, "ConcatTransform " + n(m[0]) + ".." + n(m[15])); }
  void transform(const SourceLoc& at, const double m[16]) override { add(at, "Transform " + n(m[0]) + ".." + n(m[15])); }
  void coordinate_system(const SourceLoc& at, const std::string& s) override { add(at, "CoordinateSystem " + s); }
  void coord_sys_transform(const SourceLoc& at, const std::string& s) override { add(at, "CoordSysTransform " + s); }
  void active_transform(const SourceLoc& at, const std::string& s) override { add(at, "ActiveTransform " + s); }
  void transform_times(const SourceLoc& at, double a, double b) override { add(at, "TransformTimes " + n(a) + " " + n(b)); }
  void reverse_orientation(const SourceLoc& at) override { add(at, "ReverseOrientation"); }
  void option(const SourceLoc& at, const Param& p) override { add(at, "Option " + p.name); }
  void color_space(const SourceLoc& at, const std::string& s) override { add(at, "ColorSpace " + s); }
  void camera(const SourceLoc& at, const std::string& s, ParamSet p) override { rec(at, "Camera " + s, p); }
  void film(const SourceLoc& at, const std::string& s, ParamSet p) override { rec(at, "Film " + s, p); }
  void sampler(const SourceLoc& at, const std::string& s, ParamSet p) override { rec(at, "Sampler " + s, p); }
  void pixel_filter(const SourceLoc& at, const std::string& s, ParamSet p) override { rec(at, "PixelFilter " + s, p); }
  void integrator(const SourceLoc& at, const std::string& s, ParamSet p) override { rec(at, "Integrator " + s, p); }
  void accelerator(const SourceLoc& at, const std::string& s, ParamSet p) override { rec(at, "Accelerator " + s, p); }
  void make_named_medium(const SourceLoc& at, const std::string& s, ParamSet p) override { rec(at, "MakeNamedMedium " + s, p); }
  void medium_interface(const SourceLoc& at, const std::string& a, const std::string& b) override { add(at, "MediumInterface " + a + "|" + b); }
  void world_begin(const SourceLoc& at) override { add(at, "WorldBegin"); }
  void attribute_begin(const SourceLoc& at) override { add(at, "AttributeBegin"); }
  void attribute_end(const SourceLoc& at) override { add(at, "AttributeEnd"); }
  void transform_begin(const SourceLoc& at) override { add(at, "TransformBegin"); }
  void transform_end(const SourceLoc& at) override { add(at, "TransformEnd"); }
  void attribute(const SourceLoc& at, const std::string& s, ParamSet p) override { rec(at, "Attribute " + s, p); }
  void texture(const SourceLoc& at, const std::string& a, const std::string& b, const std::string& c, ParamSet p) override {
    rec(at, "Texture " + a + " " + b + " " + c, p);
  }
  void material(const SourceLoc& at, const std::string& s, ParamSet p) override { rec(at, "Material " + s, p); }
  void make_named_material(const SourceLoc& at, const std::string& s, ParamSet p) override { rec(at, "MakeNamedMaterial " + s, p); }
  void named_material(const SourceLoc& at, const std::string& s) override { add(at, "NamedMaterial " + s); }
  void light_source(const SourceLoc& at, const std::string& s, ParamSet p) override { rec(at, "LightSource " + s, p); }
  void area_light_source(const SourceLoc& at, const std::string& s, ParamSet p) override { rec(at, "AreaLightSource " + s, p); }
  void shape(const SourceLoc& at, const std::string& s, ParamSet p) override { rec(at, "Shape " + s, p); }
  void object_begin(const SourceLoc& at, const std::string& s) override { add(at, "ObjectBegin " + s); }
  void object_end(const SourceLoc& at) override { add(at, "ObjectEnd"); }
  void object_instance(const SourceLoc& at, const std::string& s) override { add(at, "ObjectInstance " + s); }
  void end_of_files() override { log.push_back("end"); }

 private:
  static std::string n(double x) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", x);
    return b;
  }
  static std::string v(Vec3 x) { return n(x.x) + "," + n(x.y) + "," + n(x.z); }
  void rec(const SourceLoc& at, const std::string& s, ParamSet p) {
    std::string t = s;
    for (const Param& q : p.params) t += " [" + q.type + " " + q.name + ":" + std::to_string(q.loc.line) + "]";
    add(at, t);
    params.push_back(std::move(p));
  }
};

// The one-line message of parsing `text` as file `name` in `dir`.
std::string parse_error(const std::string& path) {
  Recorder r;
  try {
    parse_file(path, r);
  } catch (const InputError& e) {
    return e.what();
  }
  return "accepted";
}

// A small scene: a camera looking down -z from z = 5 and what `world` adds.
std::string scene_text(const std::string& options, const std::string& world) {
  return "LookAt 0 0 5  0 0 0  0 1 0\n"
         "Camera \"perspective\" \"float fov\" [ 40 ]\n"
         "Film \"rgb\" \"integer xresolution\" [ 32 ] \"integer yresolution\" [ 16 ]\n"
         "Sampler \"independent\" \"integer pixelsamples\" [ 64 ]\n" +
         options + "WorldBegin\n" + world;
}

// An emitting square at world x in [xa, xb], y in [-1, 1], z = 0, facing +z
// (toward the camera of scene_text) unless `flip`.
std::string quad(float xa, float xb, bool flip = false) {
  char b[512];
  std::snprintf(b, sizeof b,
                "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ]\n"
                "Shape \"trianglemesh\" \"point3 P\" [ %g -1 0  %g -1 0  %g 1 0  %g 1 0 ] \"integer indices\" [ %s ]\n"
                "AttributeEnd\n",
                xa, xb, xb, xa, flip ? "0 2 1 0 3 2" : "0 1 2 0 2 3");
  return b;
}

// Mean of the film's left and right halves (luminance-free: channel 0).
void halves(const Film& f, double& left, double& right) {
  std::vector<double> m = luz_test::pixel_means(f);
  left = right = 0;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) (x < f.width / 2 ? left : right) += m[3 * (size_t(y) * f.width + x)];
}

}  // namespace

// ---- tokenizer ----

TEST(PbrtTokenizer, WordsNumbersStringsBracketsComments) {
  std::vector<int> lines;
  auto t = tokens("Shape \"trianglemesh\" # a comment \"not a string\"\n  \"point3 P\" [0 -1.5e3 +2]\n", &lines);
  const std::vector<std::string> want = {"Shape", "\"trianglemesh\"", "\"point3 P\"", "[", "0", "-1.5e3", "+2", "]"};
  EXPECT_EQ(t, want);
  EXPECT_EQ(lines, (std::vector<int>{1, 1, 2, 2, 2, 2, 2, 2}));
  EXPECT_EQ(tokens("[1]#c\n\"a\"[\"b\"]"), (std::vector<std::string>{"[", "1", "]", "\"a\"", "[", "\"b\"", "]"}));
}

TEST(PbrtTokenizer, EscapesInStrings) {
  Tokenizer tz("t.pbrt", R"("a\"b\\c\n\t")");
  Token t;
  ASSERT_TRUE(tz.next(t));
  EXPECT_EQ(unquote("t.pbrt", t), "a\"b\\c\n\t");
  Tokenizer bad("t.pbrt", R"("x\q")");
  ASSERT_TRUE(bad.next(t));
  EXPECT_THROW(unquote("t.pbrt", t), InputError);
}

TEST(PbrtTokenizer, UnterminatedStringNamesItsLine) {
  for (const char* text : {"\n\n\"abc", "\n\n\"abc\ndef\"", "\n\n\"ab\\"}) {
    Tokenizer tz("t.pbrt", text);
    Token t;
    try {
      while (tz.next(t)) {
      }
      ADD_FAILURE() << "accepted " << text;
    } catch (const InputError& e) {
      EXPECT_EQ(e.line(), 3) << e.what();
      EXPECT_NE(std::string(e.what()).find("t.pbrt:3: "), std::string::npos) << e.what();
    }
  }
}

// ---- parser ----

class PbrtParser : public TempDirTest {};

TEST_F(PbrtParser, DirectivesAndParameterLists) {
  const std::string path = write("a.pbrt",
                                 "LookAt 1 2 3 4 5 6 7 8 9\n"
                                 "Transform [ 1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 2 ]\n"
                                 "Camera \"perspective\" \"float fov\" 45\n"
                                 "  \"bool b\" true \"bool c\" [ \"false\" ]\n"
                                 "WorldBegin\n"
                                 "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"x.png\"\n"
                                 "Shape \"trianglemesh\"\n"
                                 "  \"point3 P\" [ 0 0 0 1 0 0\n 0 1 0 ] \"integer indices\" [ 0 1 2 ]\n"
                                 "Rotate 90 0 0 1\n");
  Recorder r;
  parse_file(path, r);
  const std::vector<std::string> want = {
      "1 LookAt 1,2,3 4,5,6 7,8,9",
      "2 Transform 1..2",
      "3 Camera perspective [float fov:3] [bool b:4] [bool c:4]",
      "5 WorldBegin",
      "6 Texture t spectrum imagemap [string filename:6]",
      "7 Shape trianglemesh [point3 P:8] [integer indices:9]",
      "10 Rotate 90 0,0,1",
      "end"};
  EXPECT_EQ(r.log, want);
  const ParamSet& cam = r.params[0];
  EXPECT_EQ(cam.get_float("fov", 0), 45);
  EXPECT_TRUE(cam.get_bool("b", false));
  EXPECT_FALSE(cam.get_bool("c", true));
  const ParamSet& shape = r.params[2];
  EXPECT_EQ(shape.get_point3s("P").size(), 3u);
  EXPECT_EQ(shape.get_ints("indices"), (std::vector<int>{0, 1, 2}));
  // Looked up as another type: an error naming the parameter's line.
  try {
    shape.get_float("indices", 0);
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 9) << e.what();
  }
  // What was never looked up is reported.
  std::vector<std::string> unused;
  r.params[1].report_unused([&](const Param& p) { unused.push_back(p.name); });
  EXPECT_EQ(unused, (std::vector<std::string>{"filename"}));
}

TEST_F(PbrtParser, IncludeIsRelativeToTheSceneDirectory) {
  std::filesystem::create_directory(dir / "sub");
  write("sub/inner.pbrt", "Shape \"sphere\"\n");
  write("sub/mid.pbrt", "\nInclude \"sub/inner.pbrt\"\nAttributeEnd\n");
  const std::string path = write("main.pbrt", "WorldBegin\nAttributeBegin\nImport \"sub/mid.pbrt\"\nShape \"disk\"\n");
  Recorder r;
  parse_file(path, r);
  const std::vector<std::string> want = {"1 WorldBegin", "2 AttributeBegin", "1 Shape sphere", "3 AttributeEnd",
                                         "4 Shape disk", "end"};
  EXPECT_EQ(r.log, want);
}

// Every malformed input: one InputError, naming the file and the line.
TEST_F(PbrtParser, MalformedInputIsOneErrorWithFileAndLine) {
  struct Case {
    const char* text;
    int line;
    const char* problem;
  } cases[] = {
      {"WorldBegin\nShape \"sphere\" \"float radius\" [ 1 ]\n\"string x\" \"abc", 3, "unterminated string"},
      {"WorldBegin\nShape \"sphere\"\n  \"float radius\" [ 1.x ]\n", 3, "bad number '1.x'"},
      {"WorldBegin\nShape \"sphere\" \"float radius\" 1e999\n", 2, "bad number"},
      {"WorldBegin\n\nFrobnicate 1 2\n", 3, "unknown directive 'Frobnicate'"},
      {"WorldBegin\nShape \"sphere\" \"flaot radius\" [ 1 ]\n", 2, "unknown parameter type 'flaot'"},
      {"WorldBegin\nShape \"sphere\" \"float radius\" [ \"big\" ]\n", 2, "takes numbers, found a string"},
      {"WorldBegin\nShape \"trianglemesh\" \"integer indices\" [ 0 1.5 2 ]\n", 2, "is an integer"},
      {"WorldBegin\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0\n\nShape \"sphere\"\n", 4, "missing ']'"},
      {"WorldBegin\nShape \"sphere\" \"float radius\" [ 1 2\n", 2, "missing ']'"},
      {"WorldBegin\nShape \"sphere\" \"point3 P\" [ 0 0 ]\n", 2, "multiple of 3"},
      {"WorldBegin\nShape \"sphere\" \"float radius\"\n", 2, "has no value"},
      {"WorldBegin\nShape \"sphere\" \"radius\" 1\n", 2, "expected a parameter \"type name\""},
      {"WorldBegin\nShape \"sphere\" \"float r\" 1 \"float r\" 2\n", 2, "given twice"},
      {"WorldBegin\nShape\n", 2, "Shape needs a type"},
      {"Translate 1 2\n", 1, "needs more numbers"},
      {"WorldBegin\n\"sphere\"\n", 2, "expected a directive"},
      {"WorldBegin\n]\n", 2, "expected a directive"},
      {"WorldBegin\nShape \"sphere\" \"bool b\" maybe\n", 2, "bool value must be true or false"},
  };
  for (const Case& c : cases) {
    const std::string path = write("bad.pbrt", c.text);
    const std::string what = parse_error(path);
    EXPECT_NE(what.find("bad.pbrt:" + std::to_string(c.line) + ": "), std::string::npos) << c.text << " -> " << what;
    EXPECT_NE(what.find(c.problem), std::string::npos) << c.text << " -> " << what;
    EXPECT_EQ(what.find('\n'), std::string::npos);
  }
}

TEST_F(PbrtParser, IncludeCycleAndMissingInclude) {
  write("a.pbrt", "WorldBegin\nInclude \"b.pbrt\"\n");
  write("b.pbrt", "\n\nInclude \"a.pbrt\"\n");
  const std::string what = parse_error((dir / "a.pbrt").string());
  EXPECT_NE(what.find("b.pbrt:3: include cycle: a.pbrt -> b.pbrt -> a.pbrt"), std::string::npos) << what;
  const std::string self = write("self.pbrt", "Include \"self.pbrt\"\n");
  EXPECT_NE(parse_error(self).find("self.pbrt:1: include cycle"), std::string::npos) << parse_error(self);
  const std::string missing = write("m.pbrt", "\nInclude \"nothere.pbrt\"\n");
  EXPECT_NE(parse_error(missing).find("m.pbrt:2: cannot include"), std::string::npos) << parse_error(missing);
}

// Every prefix of a valid scene is either accepted or one InputError with a
// line (truncated files): never a crash.
TEST_F(PbrtParser, TruncatedScenesAreErrorsOrAccepted) {
  const std::string full = scene_text("", quad(-1, 1) + "Material \"conductor\" \"float roughness\" 0.1\n"
                                                          "Shape \"sphere\" \"float radius\" 0.5\n");
  for (size_t n = 0; n <= full.size(); n += 3) {
    const std::string path = write("cut.pbrt", full.substr(0, n));
    try {
      load_scene(path);
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("cut.pbrt"), std::string::npos) << e.what();
    }
  }
}

// Random corruptions (bytes replaced by characters the grammar cares about)
// of a scene that exercises most directives: each is accepted or one
// InputError naming the file, never a crash or a hang (fixed seed).
TEST_F(PbrtParser, CorruptedScenesAreErrorsOrAccepted) {
  const std::string full = scene_text("Integrator \"path\" \"integer maxdepth\" 3\n",
                                      "Texture \"c\" \"spectrum\" \"checkerboard\" \"float uscale\" 4\n"
                                      "Material \"coateddiffuse\" \"texture reflectance\" \"c\"\n" + quad(-1, 1) +
                                          "Shape \"bilinearmesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 1 1 1 ]\n"
                                          "ObjectBegin \"o\"\nShape \"disk\"\nObjectEnd\nObjectInstance \"o\"\n");
  const char alphabet[] = "\"[]#\\ \n0-.eAZ";
  uint64_t state = 12345;
  auto rnd = [&](uint64_t n) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return (state >> 33) % n;
  };
  int errors = 0;
  for (int k = 0; k < 300; ++k) {
    std::string text = full;
    for (int j = 0, n = 1 + int(rnd(3)); j < n; ++j) text[rnd(text.size())] = alphabet[rnd(sizeof alphabet - 1)];
    const std::string path = write("corrupt.pbrt", text);
    try {
      load_scene(path);
    } catch (const InputError& e) {
      ++errors;
      EXPECT_NE(std::string(e.what()).find("corrupt.pbrt"), std::string::npos) << e.what();
    }
  }
  EXPECT_GT(errors, 0);
}

// ---- translation ----

class PbrtScene : public TempDirTest {};

// pbrt's image right is camera +x, and its LookAt builds a left-handed
// frame: looking down -z with +y up, world +x is camera -x, on the image's
// left (pbrt-v4 renders it so). `Scale -1 1 1` before LookAt (what exporters
// write) mirrors it to the right.
TEST_F(PbrtScene, ImageOrientationFollowsPbrt) {
  double l, r;
  Scene s = load_scene(write("left.pbrt", scene_text("PixelFilter \"box\"\n", quad(0.3f, 1.3f))));
  halves(luz_test::render_finite(s), l, r);
  EXPECT_GT(l, 0.0);
  EXPECT_EQ(r, 0.0);
  s = load_scene(write("mirror.pbrt", "Scale -1 1 1\n" + scene_text("PixelFilter \"box\"\n", quad(0.3f, 1.3f))));
  halves(luz_test::render_finite(s), l, r);
  EXPECT_EQ(l, 0.0);
  EXPECT_GT(r, 0.0);
}

// The emitting side: the winding's (counter-clockwise seen from the lit
// side), reversed by ReverseOrientation; with normals, the normals' side.
TEST_F(PbrtScene, AreaLightsEmitOnPbrtsSide) {
  double l, r;
  auto lit = [&](const std::string& world) {
    Scene s = load_scene(write("side.pbrt", scene_text("", world)));
    halves(luz_test::render_finite(s), l, r);
    return l + r > 0.0;
  };
  EXPECT_TRUE(lit(quad(-1, 1)));
  EXPECT_FALSE(lit(quad(-1, 1, true)));
  EXPECT_FALSE(lit("ReverseOrientation\n" + quad(-1, 1)));
  EXPECT_TRUE(lit("ReverseOrientation\n" + quad(-1, 1, true)));
  // Normals toward the camera win over a winding that faces away.
  EXPECT_TRUE(lit("AreaLightSource \"diffuse\"\nShape \"trianglemesh\" \"point3 P\" [ -1 -1 0 1 -1 0 1 1 0 ]"
                  " \"integer indices\" [ 0 2 1 ] \"normal N\" [ 0 0 1 0 0 1 0 0 1 ]\n"));
  EXPECT_FALSE(lit("AreaLightSource \"diffuse\"\nShape \"trianglemesh\" \"point3 P\" [ -1 -1 0 1 -1 0 1 1 0 ]"
                   " \"integer indices\" [ 0 1 2 ] \"normal N\" [ 0 0 -1 0 0 -1 0 0 -1 ]\n"));
  // twosided: both sides, whatever the winding (test_lights.cpp checks its light).
  EXPECT_TRUE(lit("AreaLightSource \"diffuse\" \"bool twosided\" true\nShape \"trianglemesh\" \"point3 P\" "
                  "[ -1 -1 0 1 -1 0 1 1 0 ] \"integer indices\" [ 0 2 1 ]\n"));
  {
    const Scene two = load_scene(write("two.pbrt", scene_text("", "AreaLightSource \"diffuse\" \"bool twosided\" true\n"
                                                                 "Shape \"trianglemesh\" \"point3 P\" [ -1 -1 0 1 -1 0 1 1 0 ]\n")));
    EXPECT_NE(describe_scene(two).find("lights: 1: 1 area (triangle, two-sided)"), std::string::npos) << describe_scene(two);
  }
  // A two-sided sphere emits outward, with a warning.
  Scene sp = load_scene(write("sp.pbrt", scene_text("", "AreaLightSource \"diffuse\" \"bool twosided\" true\n"
                                                         "Shape \"sphere\"\n")));
  ASSERT_EQ(sp.warnings.size(), 1u);
  EXPECT_NE(sp.warnings[0].find("sp.pbrt:7: warning: a two-sided sphere light emits outward only"), std::string::npos)
      << sp.warnings[0];
}

TEST_F(PbrtScene, CameraFilmSamplerIntegrator) {
  Scene s = load_scene(write("c.pbrt", scene_text("Integrator \"volpath\" \"integer maxdepth\" [ 7 ]\n"
                                                  "PixelFilter \"triangle\" \"float xradius\" 1 \"float yradius\" 1\n",
                                                  quad(-1, 1))));
  // fov on the shorter axis (y here: 32 × 16).
  EXPECT_NEAR(s.camera.tan_half_y, std::tan(20 * M_PI / 180), 1e-6);
  EXPECT_NEAR(s.camera.tan_half_x, 2 * std::tan(20 * M_PI / 180), 1e-6);
  EXPECT_EQ(s.camera.width, 32);
  EXPECT_EQ(s.camera.height, 16);
  EXPECT_EQ(s.settings.integrator.max_depth, 8);  // pbrt's 7 scattering events
  EXPECT_EQ(s.settings.spp, 64u);
  EXPECT_EQ(s.settings.sampler, SamplerType::Independent);
  EXPECT_EQ(s.settings.filter, FilterKind::Tent);
  EXPECT_TRUE(s.warnings.empty()) << s.warnings[0];
  // pbrt's default maxdepth is 5; other integrators warn and render as path.
  s = load_scene(write("d.pbrt", scene_text("Integrator \"bdpt\"\n", quad(-1, 1))));
  EXPECT_EQ(s.settings.integrator.max_depth, 6);
  // No Sampler: Luz's default (pbrt-v4's own is zsobol), its spp 16.
  std::string no_sampler = scene_text("", quad(-1, 1));
  no_sampler.erase(no_sampler.find("Sampler"), no_sampler.find("WorldBegin") - no_sampler.find("Sampler"));
  Scene n = load_scene(write("e.pbrt", no_sampler));
  EXPECT_EQ(n.settings.sampler, SamplerType::Sobol);
  // No Integrator and no PixelFilter: pbrt-v4's volpath of maxdepth 5 and its gaussian.
  EXPECT_EQ(n.settings.integrator.max_depth, 6);
  EXPECT_EQ(n.settings.filter, FilterKind::Gaussian);
  EXPECT_EQ(n.settings.spp, 16u);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("d.pbrt:5: warning: integrator 'bdpt'"), std::string::npos) << s.warnings[0];
  // A screen window shifted right: the film's left edge moves right (Luz's x is pbrt's -x).
  s = load_scene(write("e.pbrt", "Camera \"perspective\" \"float fov\" 90 \"float screenwindow\" [ 0 2 -1 1 ]\n"
                                 "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\nWorldBegin\n" +
                                     quad(-1, 1)));
  EXPECT_NEAR(s.camera.edge_x, 0.f, 1e-6);
  EXPECT_NEAR(s.camera.tan_half_x, 1.f, 1e-6);
}

TEST_F(PbrtScene, UnusedParametersWarnAndUnsupportedThingsAreNamed) {
  Scene s = load_scene(write("u.pbrt", scene_text("", "Material \"diffuse\" \"float sheen\" 1\n" + quad(-1, 1))));
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("u.pbrt:6: warning: unused parameter \"float sheen\""), std::string::npos) << s.warnings[0];
  struct Case {
    const char* world;
    const char* problem;
  } cases[] = {
      {"Shape \"curve\" \"point3 P\" [ 0 0 0 1 1 1 2 2 2 3 3 3 ]\n", "shape 'curve' is not supported"},
      {"Shape \"loopsubdiv\"\n", "shape 'loopsubdiv' is not supported"},
      {"Shape \"sphere\" \"float zmax\" 0.5\n", "partial spheres"},
      {"Material \"hair\"\n", "material 'hair' is not supported"},
      {"LightSource \"goniometric\"\n", "light 'goniometric' is not supported"},
      {"NamedMaterial \"nothing\"\n", "no material named 'nothing'"},
      {"Texture \"t\" \"spectrum\" \"marble\"\n", "texture 'marble' is not supported"},
      {"Material \"diffuse\" \"texture reflectance\" \"nope\"\n", "no spectrum texture named 'nope'"},
      {"AttributeBegin\n", "AttributeBegin without a matching End"},
      {"AttributeEnd\n", "AttributeEnd without a matching AttributeBegin"},
      {"Material \"conductor\" \"spectrum eta\" \"metal-Unobtainium-eta\"\n", "not supported"},
  };
  for (const Case& c : cases) {
    const std::string text = scene_text("", quad(-1, 1) + c.world);
    luz_test::expect_load_refused(write("bad.pbrt", text), "bad.pbrt", c.problem);
  }
  luz_test::expect_load_refused(write("cam.pbrt", "Camera \"realistic\"\nWorldBegin\n" + quad(-1, 1)), "cam.pbrt:1",
                                "camera 'realistic' is not supported");
  luz_test::expect_load_refused(write("crop.pbrt", "Film \"rgb\" \"float cropwindow\" [ 0 .5 .5 .5 ]\nWorldBegin\n" + quad(-1, 1)),
                                "crop.pbrt:1", "cropwindow needs 4 numbers x0 x1 y0 y1 with 0 ≤ x0 < x1 ≤ 1");
  luz_test::expect_load_refused(
      write("bounds.pbrt", "Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 16 \"integer pixelbounds\" [ 40 50 0 8 ]\n"
                           "WorldBegin\n" + quad(-1, 1)),
      "bounds.pbrt:1", "pixelbounds [40, 50) × [0, 8) holds no pixel of the 32×16 film");
}

TEST_F(PbrtScene, MaterialsMapOntoLuzModels) {
  Scene s = load_scene(write("m.pbrt", scene_text("",
                                                  "MakeNamedMaterial \"a\" \"string type\" \"conductor\" \"spectrum eta\" \"metal-Au-eta\"\n"
                                                  "  \"spectrum k\" \"metal-Au-k\" \"float roughness\" 0.04\n"
                                                  "MakeNamedMaterial \"b\" \"string type\" \"coateddiffuse\" \"rgb reflectance\" [ .5 .2 .1 ]\n"
                                                  "  \"float roughness\" 0.01 \"bool remaproughness\" false\n"
                                                  "MakeNamedMaterial \"c\" \"string type\" \"dielectric\" \"spectrum eta\" \"glass-BK7\"\n"
                                                  "MakeNamedMaterial \"d\" \"string type\" \"mix\" \"string materials\" [ \"a\" \"b\" ] \"float amount\" 0.25\n"
                                                  "NamedMaterial \"d\"\n" + quad(-1, 1))));
  ASSERT_GE(s.materials.size(), 4u);
  const Bsdf& a = s.materials[0].bsdf;
  EXPECT_EQ(a.type, BsdfType::RoughConductor);
  EXPECT_NEAR(a.rough_conductor.alpha_u, 0.2f, 1e-6);  // remapped: sqrt(0.04)
  Color eta, k;
  find_conductor_preset("Au", eta, k);
  EXPECT_EQ(a.rough_conductor.eta.x, eta.x);
  EXPECT_TRUE(a.two_sided);
  EXPECT_EQ(s.materials[1].bsdf.type, BsdfType::RoughPlastic);
  EXPECT_EQ(s.materials[2].bsdf.type, BsdfType::SmoothDielectric);
  const Bsdf& d = s.materials[3].bsdf;
  EXPECT_TRUE(d.blend);
  EXPECT_EQ(d.blend_weight, 0.25f);
  EXPECT_EQ(d.second.type, BsdfType::RoughPlastic);
}

// pbrt-v4's diffusetransmission: R = clamp(scale reflectance, 0, 1) and T
// likewise, textures scaled too. Rendered: a large quad under a distant
// light of irradiance 1 at cos θ = 2/√5, seen from the camera's side, shows
// T cos θ / π where the light is behind it and R cos θ / π where it is in
// front (nothing else is in the scene), in every pixel.
TEST_F(PbrtScene, DiffuseTransmissionScalesAndTransmits) {
  const std::string big_quad =
      "Shape \"trianglemesh\" \"point3 P\" [ -10 -10 0  10 -10 0  10 10 0  -10 10 0 ] \"integer indices\" [ 0 1 2 0 2 3 ]\n"
      "  \"point2 uv\" [ 0 0  1 0  1 1  0 1 ]\n";
  auto material = [](const std::string& params) {
    return "Material \"diffusetransmission\" " + params + "\n";
  };
  Scene s = load_scene(write("dt.pbrt", scene_text("", material("\"rgb reflectance\" [ .3 .2 .1 ] \"rgb transmittance\" "
                                                                "[ .2 .4 .6 ] \"float scale\" 0.5") + big_quad)));
  ASSERT_EQ(s.materials.size(), 1u);
  const Bsdf& b = s.materials[0].bsdf;
  ASSERT_EQ(b.type, BsdfType::DiffuseTransmission);
  EXPECT_TRUE(b.has_transmission());
  EXPECT_NEAR(b.diffuse_transmission.reflectance.x, .15f, 1e-7f);
  EXPECT_NEAR(b.diffuse_transmission.transmittance.z, .3f, 1e-7f);
  // Defaults (0.25 each), and a scale that takes them past 1: clamped, with a warning.
  Scene d = load_scene(write("dd.pbrt", scene_text("", material("\"float scale\" 5") + big_quad)));
  EXPECT_EQ(d.materials[0].bsdf.diffuse_transmission.transmittance.y, 1.f);
  EXPECT_EQ(d.warnings.size(), 2u);
  // A scaled texture.
  Scene t = load_scene(write("dx.pbrt", scene_text("",
      "Texture \"c\" \"spectrum\" \"checkerboard\" \"rgb tex1\" [ .8 .6 .4 ] \"rgb tex2\" [ .2 .2 .2 ]\n" +
      material("\"texture transmittance\" \"c\" \"float scale\" 0.5") + big_quad)));
  const Material& tm = t.materials[0];
  ASSERT_EQ(tm.num_bindings, 1u);
  EXPECT_EQ(t.texture_bindings[tm.first_binding].param, BsdfParam::Transmittance);
  EXPECT_NEAR(tm.bsdf.diffuse_transmission.transmittance.x, .25f, 1e-6f);  // the scaled texture's mean
  EXPECT_NEAR(tm.bsdf.diffuse_transmission.transmittance.z, .15f, 1e-6f);
  try {
    load_scene(write("bad.pbrt", scene_text("", material("\"float scale\" -1") + big_quad)));
    ADD_FAILURE() << "a negative scale loaded";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'scale' must be a finite number"), std::string::npos) << e.what();
  }

  const double cos_t = 2.0 / std::sqrt(5.0);
  for (const bool behind : {true, false}) {
    const std::string from = behind ? "0 -1 -2" : "0 -1 2";  // the camera is at z = 5
    Scene r = load_scene(write("dr.pbrt", scene_text("PixelFilter \"box\"\n", material("\"rgb reflectance\" [ .3 .2 .1 ] \"rgb transmittance\" "
                                                                 "[ .2 .4 .6 ]") +
                                                      "LightSource \"distant\" \"point3 from\" [ " + from +
                                                      " ] \"point3 to\" [ 0 0 0 ]\n" + big_quad)));
    const std::vector<double> m = luz_test::pixel_means(luz_test::render_finite(r));
    const double expect[3] = {(behind ? .2 : .3) * cos_t / M_PI, (behind ? .4 : .2) * cos_t / M_PI,
                              (behind ? .6 : .1) * cos_t / M_PI};
    for (size_t i = 0; i < m.size(); ++i)
      ASSERT_NEAR(m[i], expect[i % 3], 1e-5 * expect[i % 3]) << (behind ? "behind" : "in front") << ", value " << i;
  }
}

// A film's cropwindow (fractions, from the top left; pbrt-v4's pixel
// bounds: the ceiling of each times the resolution) or pixelbounds: a film
// of the crop's size whose pixels see what the whole film's saw.
TEST_F(PbrtScene, CropWindowAndPixelBounds) {
  const std::string world = "WorldBegin\n" + quad(-1, 1);
  auto film = [&](const std::string& extra) {
    return "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 40 ]\n"
           "Film \"rgb\" \"integer xresolution\" [ 30 ] \"integer yresolution\" [ 20 ] " + extra + "\n" + world;
  };
  const Scene whole = load_scene(write("whole.pbrt", film("")));
  const Scene crop = load_scene(write("crop.pbrt", film("\"float cropwindow\" [ 0.25 0.75 0.1 0.5 ]")));
  ASSERT_EQ(crop.camera.width, 15);   // ceil(7.5) = 8 to ceil(22.5) = 23
  ASSERT_EQ(crop.camera.height, 8);   // ceil(2) = 2 to ceil(10) = 10
  const Scene bounds = load_scene(write("bounds.pbrt", film("\"integer pixelbounds\" [ 8 23 2 10 ]")));
  for (const Scene* s : {&crop, &bounds}) {
    ASSERT_EQ(s->camera.width, 15);
    ASSERT_EQ(s->camera.height, 8);
    for (float fx : {0.f, 6.5f, 15.f})
      for (float fy : {0.f, 3.25f, 8.f}) {
        const Ray a = s->camera.generate_ray(fx, fy), b = whole.camera.generate_ray(fx + 8.f, fy + 2.f);
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(a.d[k], b.d[k], 1e-6f);
      }
  }
  const Scene both =
      load_scene(write("both.pbrt", film("\"float cropwindow\" [ 0.25 0.75 0.1 0.5 ] \"integer pixelbounds\" [ 0 4 0 4 ]")));
  EXPECT_EQ(both.camera.width, 15);
  EXPECT_TRUE(luz_test::has_warning(both, "both cropwindow and pixelbounds given: the cropwindow is used"));
  // Beyond the film: clamped to it, with a warning (pbrt-v4's Film).
  const Scene over = load_scene(write("over.pbrt", film("\"integer pixelbounds\" [ -4 23 2 99 ]")));
  EXPECT_EQ(over.camera.width, 23);
  EXPECT_EQ(over.camera.height, 18);
  EXPECT_TRUE(luz_test::has_warning(over, "pixelbounds extends beyond the 30×20 film: clamped to it"));
}

// An imagemap's `scale` and a `scale` texture over an image: the image's
// values times the factor, at each texel.
TEST_F(PbrtScene, ScaledImageTextures) {
  luz::write_image((dir / "t.pfm").string(), luz::Image{2, 1, {0.25f, 0.5f, 1.f, 1.f, 1.f, 1.f}});
  const std::string square =
      "Shape \"trianglemesh\" \"point3 P\" [ -1 -1 0  1 -1 0  1 1 0  -1 1 0 ] \"point2 uv\" [ 0 0  1 0  1 1  0 1 ]\n"
      "  \"integer indices\" [ 0 1 2 0 2 3 ]\n";
  Scene s = load_scene(write("t.pbrt", scene_text("", quad(2, 3) +
                                                  "Texture \"img\" \"spectrum\" \"imagemap\" \"string filename\" \"t.pfm\" \"float scale\" 0.5\n"
                                                  "Texture \"half\" \"spectrum\" \"scale\" \"texture tex\" \"img\" \"float scale\" 0.5\n"
                                                  "Material \"diffuse\" \"texture reflectance\" \"img\"\n" + square +
                                                  "Material \"diffuse\" \"texture reflectance\" \"half\"\n" + square)));
  std::vector<int32_t> textures;
  for (const Material& m : s.materials)
    if (m.num_bindings == 1) textures.push_back(s.texture_bindings[m.first_binding].texture);
  ASSERT_EQ(textures.size(), 2u);
  const SceneView v = s.view();
  const float want[2][2][3] = {{{0.125f, 0.25f, 0.5f}, {0.5f, 0.5f, 0.5f}}, {{0.0625f, 0.125f, 0.25f}, {0.25f, 0.25f, 0.25f}}};
  for (int k = 0; k < 2; ++k)
    for (int side = 0; side < 2; ++side) {
      const Color c = v.textures.eval(uint32_t(textures[size_t(k)]), {side ? 0.75f : 0.25f, 0.5f});
      EXPECT_FLOAT_EQ(c.x, want[k][side][0]) << k << " " << side;
      EXPECT_FLOAT_EQ(c.y, want[k][side][1]) << k << " " << side;
      EXPECT_FLOAT_EQ(c.z, want[k][side][2]) << k << " " << side;
    }
  luz_test::expect_load_refused(
      write("neg.pbrt", scene_text("", "Texture \"img\" \"spectrum\" \"imagemap\" \"string filename\" \"t.pfm\" \"float scale\" -1\n" +
                                          quad(-1, 1))),
      "neg.pbrt:6", "imagemap 'scale' must be finite and ≥ 0");
}

// A reflectance texture above 1 (an image scaled by 4): pbrt-v4's materials
// clamp its value to [0, 1] where looked up; Luz the same, with a warning.
TEST_F(PbrtScene, ReflectanceTexturesAboveOneAreClamped) {
  luz::write_image((dir / "t.pfm").string(), luz::Image{2, 1, {0.25f, 0.5f, 0.125f, 0.1f, 0.2f, 0.05f}});
  Scene s = load_scene(write("t.pbrt", scene_text("", quad(2, 3) +
      "Texture \"img\" \"spectrum\" \"imagemap\" \"string filename\" \"t.pfm\" \"float scale\" 4\n"
      "Material \"diffuse\" \"texture reflectance\" \"img\"\n"
      "Shape \"trianglemesh\" \"point3 P\" [ -1 -1 0  1 -1 0  1 1 0  -1 1 0 ] \"point2 uv\" [ 0 0  1 0  1 1  0 1 ]\n"
      "  \"integer indices\" [ 0 1 2 0 2 3 ]\n")));
  EXPECT_TRUE(luz_test::has_warning(s, "'reflectance' texture has texels above 1: clamped to 1 where looked up"));
  const SceneView v = s.view();
  uint32_t m = 0;
  while (m < s.materials.size() && s.materials[m].num_bindings == 0) ++m;
  ASSERT_LT(m, s.materials.size());
  const float want[2][3] = {{1.f, 1.f, 0.5f}, {0.4f, 0.8f, 0.2f}};  // 4 × the texels, at most 1
  for (int side = 0; side < 2; ++side) {
    const Bsdf b = v.materials.bsdf(m, v.textures, {side ? 0.75f : 0.25f, 0.5f});
    for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(b.diffuse.reflectance[c], want[side][c]) << side << " " << c;
  }
}

// pbrt-v4's mix (by a constant or a float texture), scale of two textures,
// imagemap `invert` (float and spectrum), checkerboard of textures and a
// float imagemap's first channel, evaluated at the texel centres of 2×1
// images, where a bilinear lookup is the texel: each against its formula.
TEST_F(PbrtScene, MixScaleInvertAndCheckerboardOfTextures) {
  using luz::Image;
  luz::write_image((dir / "t.pfm").string(), Image{2, 1, {0.25f, 0.5f, 1.f, 1.f, 1.f, 1.f}});
  luz::write_image((dir / "u.pfm").string(), Image{2, 1, {0.5f, 0.f, 0.1f, 0.f, 0.5f, 0.2f}});
  luz::write_image((dir / "w.pfm").string(), Image{2, 1, {0.25f, 0.9f, 0.9f, 0.75f, 0.1f, 0.1f}});  // float: red
  const double T[2][3] = {{0.25, 0.5, 1}, {1, 1, 1}}, U[2][3] = {{0.5, 0, 0.1}, {0, 0.5, 0.2}}, W[2] = {0.25, 0.75};
  const double C[3] = {0.2, 0.4, 0.6};
  struct Case {
    const char* name;
    const char* texture;
    std::function<double(int side, int c)> want;
  } cases[] = {
      {"mixc", "\"spectrum\" \"mix\" \"texture tex1\" \"t\" \"texture tex2\" \"u\" \"float amount\" 0.25",
       [&](int i, int c) { return 0.75 * T[i][c] + 0.25 * U[i][c]; }},
      {"mixw", "\"spectrum\" \"mix\" \"texture tex1\" \"t\" \"rgb tex2\" [ 0.2 0.4 0.6 ] \"texture amount\" \"w\"",
       [&](int i, int c) { return (1 - W[i]) * T[i][c] + W[i] * C[c]; }},
      {"mixi", "\"spectrum\" \"mix\" \"texture tex1\" \"t\" \"texture tex2\" \"u\" \"texture amount\" \"winv\"",
       [&](int i, int c) { return W[i] * T[i][c] + (1 - W[i]) * U[i][c]; }},
      {"prod", "\"spectrum\" \"scale\" \"texture tex\" \"t\" \"texture scale\" \"w\"",
       [&](int i, int c) { return T[i][c] * W[i]; }},
      {"prodi", "\"spectrum\" \"scale\" \"texture tex\" \"u\" \"texture scale\" \"winv\"",
       [&](int i, int c) { return U[i][c] * (1 - W[i]); }},
      {"tinv", "\"spectrum\" \"imagemap\" \"string filename\" \"t.pfm\" \"bool invert\" true",
       [&](int i, int c) { return 1 - T[i][c]; }},
      // uscale 2: tex1 on u < 1/2 (floor(s) + floor(t) even), tex2 beyond.
      {"cb", "\"spectrum\" \"checkerboard\" \"texture tex1\" \"t\" \"rgb tex2\" [ 0.2 0.4 0.6 ] \"float uscale\" 2",
       [&](int i, int c) { return i == 0 ? T[0][c] : C[c]; }},
  };
  std::string world = quad(2, 3) +
                      "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"t.pfm\"\n"
                      "Texture \"u\" \"spectrum\" \"imagemap\" \"string filename\" \"u.pfm\"\n"
                      "Texture \"w\" \"float\" \"imagemap\" \"string filename\" \"w.pfm\"\n"
                      "Texture \"winv\" \"float\" \"imagemap\" \"string filename\" \"w.pfm\" \"bool invert\" true\n";
  const std::string square =
      "Shape \"trianglemesh\" \"point3 P\" [ -1 -1 0  1 -1 0  1 1 0  -1 1 0 ] \"point2 uv\" [ 0 0  1 0  1 1  0 1 ]\n"
      "  \"integer indices\" [ 0 1 2 0 2 3 ]\n";
  for (const Case& c : cases)
    world += std::string("Texture \"") + c.name + "\" " + c.texture + "\nMaterial \"diffuse\" \"texture reflectance\" \"" +
             c.name + "\"\n" + square;
  Scene s = load_scene(write("mix.pbrt", scene_text("", world)));
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  std::vector<int32_t> textures;
  for (const Material& m : s.materials)
    if (m.num_bindings == 1) textures.push_back(s.texture_bindings[m.first_binding].texture);
  ASSERT_EQ(textures.size(), std::size(cases));
  const SceneView v = s.view();
  for (size_t k = 0; k < textures.size(); ++k)
    for (int side = 0; side < 2; ++side) {
      const Color got = v.textures.eval(uint32_t(textures[k]), {side ? 0.75f : 0.25f, 0.5f});
      for (int ch = 0; ch < 3; ++ch)
        EXPECT_NEAR(got[ch], cases[k].want(side, ch), 1e-6) << cases[k].name << " side " << side << " channel " << ch;
    }

  const std::string base = quad(2, 3) + "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"t.pfm\"\n";
  struct Bad {
    const char* world;
    const char* problem;
  } bad[] = {
      {"Texture \"m\" \"spectrum\" \"mix\" \"texture tex1\" \"t\"\n"
       "Texture \"mm\" \"spectrum\" \"mix\" \"texture tex1\" \"m\" \"texture tex2\" \"t\"\n",
       "whose operand is itself a mix or scale of textures is not supported"},
      {"Texture \"h\" \"float\" \"imagemap\" \"string filename\" \"w.pfm\" \"float scale\" 2 \"bool invert\" true\n",
       "imagemap 'invert' of values above 1 is not supported"},
      {"Texture \"h\" \"float\" \"imagemap\" \"string filename\" \"w.pfm\" \"float scale\" 3\n"
       "Texture \"m\" \"spectrum\" \"mix\" \"texture tex1\" \"t\" \"texture amount\" \"h\"\n",
       "a mix texture's amount must lie in [0, 1]"},
  };
  for (const Bad& b : bad)
    luz_test::expect_load_refused(write("bad.pbrt", scene_text("", base + b.world)), "bad.pbrt", b.problem);
}

// Textured roughness: a float texture bound to the microfacet alphas, each
// lookup's value through pbrt-v4's RoughnessToAlpha (sqrt) unless
// remaproughness is false; u and v apart for the conductor. At the texel
// centres of a 2×1 image the alphas are the texels' (square roots).
TEST_F(PbrtScene, TexturedRoughnessIsRemappedAtEachLookup) {
  luz::write_image((dir / "r.pfm").string(), luz::Image{2, 1, {0.04f, 0.9f, 0.9f, 0.25f, 0.f, 0.f}});
  const std::string square =
      "Shape \"trianglemesh\" \"point3 P\" [ -1 -1 0  1 -1 0  1 1 0  -1 1 0 ] \"point2 uv\" [ 0 0  1 0  1 1  0 1 ]\n"
      "  \"integer indices\" [ 0 1 2 0 2 3 ]\n";
  Scene s = load_scene(write(
      "r.pbrt", scene_text("", quad(2, 3) + "Texture \"r\" \"float\" \"imagemap\" \"string filename\" \"r.pfm\"\n"
                               "Material \"conductor\" \"texture roughness\" \"r\"\n" + square +
                               "Material \"conductor\" \"texture uroughness\" \"r\" \"float vroughness\" 0.09\n" + square +
                               "Material \"dielectric\" \"texture roughness\" \"r\" \"bool remaproughness\" false\n" +
                               square)));
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  std::vector<uint32_t> textured;
  for (uint32_t m = 0; m < s.materials.size(); ++m)
    if (s.materials[m].num_bindings > 0) textured.push_back(m);
  ASSERT_EQ(textured.size(), 3u);
  const SceneView v = s.view();
  const double r[2] = {0.04, 0.25};
  for (int side = 0; side < 2; ++side) {
    const Vec2 uv{side ? 0.75f : 0.25f, 0.5f};
    const Bsdf a = v.materials.bsdf(textured[0], v.textures, uv), b = v.materials.bsdf(textured[1], v.textures, uv),
               c = v.materials.bsdf(textured[2], v.textures, uv);
    ASSERT_EQ(a.type, BsdfType::RoughConductor);
    ASSERT_EQ(c.type, BsdfType::RoughDielectric);
    EXPECT_NEAR(a.rough_conductor.alpha_u, std::sqrt(r[side]), 1e-6) << side;
    EXPECT_NEAR(a.rough_conductor.alpha_v, std::sqrt(r[side]), 1e-6) << side;
    EXPECT_NEAR(b.rough_conductor.alpha_u, std::sqrt(r[side]), 1e-6) << side;
    EXPECT_NEAR(b.rough_conductor.alpha_v, 0.3, 1e-6) << side;
    EXPECT_NEAR(c.rough_dielectric.alpha_u, r[side], 1e-6) << side;
    EXPECT_NEAR(c.rough_dielectric.alpha_v, r[side], 1e-6) << side;
  }
  luz_test::expect_load_refused(
      write("bad.pbrt", scene_text("", quad(2, 3) + "Texture \"r\" \"float\" \"imagemap\" \"string filename\" \"r.pfm\"\n"
                                       "Material \"coateddiffuse\" \"texture roughness\" \"r\"\n" + square)),
      "bad.pbrt:11", "a textured coateddiffuse roughness is not supported");
}

// pbrt-v4's photometric targets: a point light's `power` spread over 4π, a
// spotlight's over its cone (2π((1 - cos start) + (cos start - cos end) / 2),
// pbrt's smoothstep falloff integrated), a distant light's and a uniform
// infinite light's `illuminance` on an upward patch (E, and π L); the RGB
// and `scale` multiply as in pbrt-v4.
TEST_F(PbrtScene, PowerAndIlluminanceTargets) {
  Scene s = load_scene(write("p.pbrt", scene_text("", quad(-1, 1) +
      "LightSource \"point\" \"rgb I\" [ 0.5 1 2 ] \"float power\" 100 \"float scale\" 2\n"
      "LightSource \"spot\" \"float power\" 60 \"float coneangle\" 40 \"float conedeltaangle\" 10\n"
      "LightSource \"distant\" \"rgb L\" [ 1 0.5 0.25 ] \"float illuminance\" 8\n"
      "LightSource \"infinite\" \"float illuminance\" 3\n")));
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  std::vector<const Light*> by_type(8, nullptr);
  for (const Light& l : s.lights) by_type[size_t(l.type)] = &l;
  ASSERT_TRUE(by_type[size_t(LightType::Point)] && by_type[size_t(LightType::Spot)] &&
              by_type[size_t(LightType::Directional)] && by_type[size_t(LightType::Constant)]);
  const double point = 2 * 100 / (4 * M_PI);
  const Color pi = by_type[size_t(LightType::Point)]->point.intensity;
  EXPECT_NEAR(pi.x, 0.5 * point, 1e-5 * point);
  EXPECT_NEAR(pi.z, 2 * point, 1e-5 * point);
  const double cs = std::cos(30 * M_PI / 180), ce = std::cos(40 * M_PI / 180);
  const double spot = 60 / (2 * M_PI * ((1 - cs) + (cs - ce) / 2));
  EXPECT_NEAR(by_type[size_t(LightType::Spot)]->spot.intensity.y, spot, 1e-5 * spot);
  // pbrt-v4's falloff over the cone: a smoothstep in cos θ from the cone's edge to 30°.
  const SpotLight& sl = by_type[size_t(LightType::Spot)]->spot;
  EXPECT_EQ(sl.falloff_kind, SpotFalloff::SmoothstepCos);
  EXPECT_NEAR(sl.beam, 30 * M_PI / 180, 1e-6);
  EXPECT_NEAR(sl.cutoff, 40 * M_PI / 180, 1e-6);
  const Color e = by_type[size_t(LightType::Directional)]->directional.irradiance;
  EXPECT_NEAR(e.x, 8, 1e-5);
  EXPECT_NEAR(e.z, 2, 1e-5);
  EXPECT_NEAR(by_type[size_t(LightType::Constant)]->constant.radiance.y, 3 / M_PI, 1e-6);

  // Area lights: pbrt-v4 gives each of its shapes the power, radiance
  // L P / (π A), half that two-sided: each triangle of a trianglemesh on its
  // own (A in the world), a disk or a sphere whole (A in its own space).
  Scene a = load_scene(write("a.pbrt", scene_text("",
      "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [ 1 2 3 ] \"float power\" 10\n"
      "Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  1 0 0  0 1 0  0 0 1  3 0 1  0 1 1 ] \"integer indices\" [ 0 1 2 3 4 5 ]\n"
      "AttributeEnd\nAttributeBegin\nAreaLightSource \"diffuse\" \"float power\" 10 \"bool twosided\" true\n"
      "Translate 0 0 5\nScale 3 3 3\nShape \"disk\" \"float radius\" 2\nAttributeEnd\n"
      "AttributeBegin\nAreaLightSource \"diffuse\" \"float power\" 10\nTranslate 0 0 9\nScale 2 2 2\n"
      "Shape \"sphere\" \"float radius\" 0.5\nAttributeEnd\n")));
  EXPECT_TRUE(a.warnings.empty()) << a.warnings.front();
  std::vector<float> tri, disk;
  float sphere = 0;
  for (const Light& l : a.lights) {
    if (l.type == LightType::Sphere) sphere = l.sphere.radiance.x;
    if (l.type != LightType::Triangle) continue;
    (l.triangle.two_sided ? disk : tri).push_back(l.triangle.radiance.z);
  }
  ASSERT_EQ(tri.size(), 2u);
  std::sort(tri.begin(), tri.end());
  EXPECT_NEAR(tri[0], 3 * 10 / (M_PI * 1.5), 1e-5);  // the triangle of area 3/2
  EXPECT_NEAR(tri[1], 3 * 10 / (M_PI * 0.5), 1e-5);  // and of area 1/2
  ASSERT_GT(disk.size(), 8u);
  for (float d : disk) EXPECT_NEAR(d, 10 / (2 * M_PI * (M_PI * 4)), 1e-6);  // object-space area 4π, two-sided
  EXPECT_NEAR(sphere, 10 / (M_PI * (4 * M_PI * 0.25)), 1e-6);
}

// pbrt-v4's shapes under a powered area light: each patch of a bilinearmesh
// and each face of a plymesh (a triangle, or a quad read as a bilinear
// patch), with its area in the world; a polygon pbrt-v4 would skip cannot
// share a power.
TEST_F(PbrtScene, PowerPerPatchAndPlyFace) {
  // Under `Scale 2`: a 1 × 2 rectangle (world area 8) and a parallelogram of
  // base 1 and height 1 (world area 4).
  Scene b = load_scene(write("b.pbrt", scene_text("",
      "AreaLightSource \"diffuse\" \"float power\" 10\nScale 2 2 2\n"
      "Shape \"bilinearmesh\" \"point3 P\" [ 0 0 0  1 0 0  0 2 0  1 2 0   5 0 0  6 0 0  5.5 1 0  6.5 1 0 ]\n"
      "\"integer indices\" [ 0 1 2 3  4 5 6 7 ]\n")));
  EXPECT_TRUE(b.warnings.empty()) << b.warnings.front();
  // The area lights' red radiances, sorted, each value once.
  auto radiances = [](const Scene& s) {
    std::vector<float> r;
    for (const Light& x : s.lights)
      if (x.type == LightType::Triangle || x.type == LightType::Parallelogram)
        r.push_back(x.type == LightType::Triangle ? x.triangle.radiance.x : x.parallelogram.radiance.x);
    std::sort(r.begin(), r.end());
    r.erase(std::unique(r.begin(), r.end()), r.end());
    return r;
  };
  const std::vector<float> l = radiances(b);
  ASSERT_EQ(l.size(), 2u);
  EXPECT_NEAR(l.front(), 10 / (M_PI * 8), 1e-6);
  EXPECT_NEAR(l.back(), 10 / (M_PI * 4), 1e-6);

  // A PLY of one triangle (area 1/2), one 2 × 1 quad (area 2) and one
  // 1 × 3 quad (area 3), under `Scale 1 1 2` (z is the quads' height).
  std::ofstream(dir / "q.ply") << "ply\nformat ascii 1.0\nelement vertex 11\nproperty float x\nproperty float y\n"
                                  "property float z\nelement face 3\nproperty list uchar int vertex_indices\nend_header\n"
                                  "0 0 0\n1 0 0\n0 1 0\n"
                                  "0 0 1\n2 0 1\n2 0 1.5\n0 0 1.5\n"
                                  "5 0 0\n5 1 0\n5 1 3\n5 0 3\n"
                                  "3 0 1 2\n4 3 4 5 6\n4 7 8 9 10\n";
  Scene q = load_scene(write("q.pbrt", scene_text("",
      "AreaLightSource \"diffuse\" \"float power\" 10\nScale 1 1 2\nShape \"plymesh\" \"string filename\" \"q.ply\"\n")));
  EXPECT_TRUE(q.warnings.empty()) << q.warnings.front();
  const std::vector<float> r = radiances(q);
  ASSERT_EQ(r.size(), 3u);
  EXPECT_NEAR(r[0], 10 / (M_PI * 6), 1e-6);  // the 1 × 3 quad, twice as tall
  EXPECT_NEAR(r[1], 10 / (M_PI * 2), 1e-6);  // the 2 × 1 quad: 2 × 0.5 × 2
  EXPECT_NEAR(r[2], 10 / (M_PI * 0.5), 1e-6);

  // A trianglemesh's triangles are its shapes, their areas in the world too:
  // a right triangle of legs 1 under `Scale 2 3 1`, area 3.
  Scene t = load_scene(write("t.pbrt", scene_text("",
      "AreaLightSource \"diffuse\" \"float power\" 10\nScale 2 3 1\n"
      "Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  1 0 0  0 1 0 ] \"integer indices\" [ 0 1 2 ]\n")));
  const std::vector<float> tr = radiances(t);
  ASSERT_EQ(tr.size(), 1u);
  EXPECT_NEAR(tr[0], 10 / (M_PI * 3), 1e-6);

  std::ofstream(dir / "p.ply") << "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
                                  "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                                  "0 0 0\n1 0 0\n1 1 0\n0.5 1.5 0\n0 1 0\n5 0 1 2 3 4\n";
  luz_test::expect_load_refused(
      write("bad.pbrt", scene_text("", "AreaLightSource \"diffuse\" \"float power\" 10\n"
                                       "Shape \"plymesh\" \"string filename\" \"p.ply\"\n")),
      "bad.pbrt:7", "area light 'power' on a plymesh with a face of 5 vertices");
  // Without a power, the pentagon renders as its three triangles.
  Scene pent = load_scene(write("pent.pbrt", scene_text("", "AreaLightSource \"diffuse\" \"rgb L\" [ 1 1 1 ]\n"
                                                           "Shape \"plymesh\" \"string filename\" \"p.ply\"\n")));
  EXPECT_FALSE(pent.lights.empty());
}

// An image infinite light's `illuminance`: pbrt-v4 divides it by Σ Y cos θ
// over the map's upper-hemisphere texels times 2π / N², half the map's true
// illuminance (a texel spans 4π / N²), so pbrt-v4 and Luz render twice the
// target. A map of colour c above the horizon and another below: the scale
// is E / (π/2 Y(c)) (the midpoint sum's error at N = 64 is 1e-3, relative),
// whatever is below.
TEST_F(PbrtScene, ImageInfiniteLightIlluminanceAsPbrt) {
  const int n = 64;
  Image img;
  img.width = img.height = n;
  img.rgb.resize(size_t(n) * n * 3);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const bool up = std::fabs(2 * (x + 0.5) / n - 1) + std::fabs(2 * (y + 0.5) / n - 1) < 1;
      const float c[3] = {up ? 1.f : 9.f, up ? 0.5f : 7.f, up ? 0.25f : 5.f};
      for (int k = 0; k < 3; ++k) img.rgb[(size_t(y) * n + x) * 3 + k] = c[k];
    }
  write_image((dir / "env.pfm").string(), img);
  Scene s = load_scene(write("e.pbrt", scene_text("",
      "LightSource \"infinite\" \"string filename\" \"env.pfm\" \"float illuminance\" 5 \"float scale\" 3\n" + quad(-1, 1))));
  const Light* env = nullptr;
  for (const Light& x : s.lights)
    if (x.type == LightType::Envmap) env = &x;
  ASSERT_NE(env, nullptr);
  const double y_up = 0.2126 * 1 + 0.7152 * 0.5 + 0.0722 * 0.25;
  const double expected = 3 * 5 / (M_PI / 2 * y_up);
  EXPECT_NEAR(env->envmap.scale, expected, 2e-3 * expected);

  Image wide;
  wide.width = 2 * n;
  wide.height = n;
  wide.rgb.assign(size_t(2 * n) * n * 3, 1.f);
  write_image((dir / "wide.pfm").string(), wide);
  luz_test::expect_load_refused(
      write("bad.pbrt", scene_text("", "LightSource \"infinite\" \"string filename\" \"wide.pfm\" \"float illuminance\" 5\n")),
      "bad.pbrt:6", "'illuminance' needs pbrt-v4's square equal-area map");
  Image black;
  black.width = black.height = 8;
  black.rgb.assign(8 * 8 * 3, 0.f);
  write_image((dir / "black.pfm").string(), black);
  luz_test::expect_load_refused(
      write("bad2.pbrt", scene_text("", "LightSource \"infinite\" \"string filename\" \"black.pfm\" \"float illuminance\" 5\n")),
      "bad2.pbrt:6", "it is black over its upper hemisphere");
}

// pbrt-v4's spotlights may open wider than a hemisphere: coneangle up to 180.
TEST_F(PbrtScene, WideSpotlights) {
  Scene s = load_scene(write("w.pbrt", scene_text("", quad(-1, 1) +
      "LightSource \"spot\" \"float coneangle\" 120 \"float conedeltaangle\" 20 \"float power\" 10\n")));
  ASSERT_EQ(s.lights.size(), 2u);
  const SpotLight& l = s.lights[1].spot;
  EXPECT_NEAR(l.cutoff, 120 * M_PI / 180, 1e-6);
  EXPECT_NEAR(l.beam, 100 * M_PI / 180, 1e-6);
  const double cs = std::cos(100 * M_PI / 180), ce = std::cos(120 * M_PI / 180);
  EXPECT_NEAR(l.intensity.x, 10 / (2 * M_PI * ((1 - cs) + (cs - ce) / 2)), 1e-5);
  luz_test::expect_load_refused(write("w2.pbrt", scene_text("", quad(-1, 1) + "LightSource \"spot\" \"float coneangle\" 181\n")),
                                "w2.pbrt:10", "coneangle must be in (0, 180] degrees");
}

// Shapes other than meshes, delta lights, Attribute defaults, instances.
TEST_F(PbrtScene, ShapesLightsAttributesAndInstances) {
  Scene s = load_scene(write("all.pbrt", scene_text("",
      "Attribute \"shape\" \"float radius\" 0.25\n"
      "LightSource \"point\" \"rgb I\" [ 1 2 3 ] \"point3 from\" [ 0 0 2 ] \"float scale\" 2\n"
      "LightSource \"spot\" \"point3 from\" [ 0 0 3 ] \"point3 to\" [ 0 0 0 ] \"float coneangle\" 20\n"
      "LightSource \"distant\" \"point3 from\" [ 0 0 1 ] \"point3 to\" [ 0 0 0 ]\n"
      "Shape \"disk\"\n"
      "Shape \"bilinearmesh\" \"point3 P\" [ -1 -1 -1  1 -1 -1  -1 1 -1  1 1 -1 ]\n"
      "Shape \"sphere\"\n"
      "ObjectBegin \"tri\"\nShape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ]\nObjectEnd\n"
      "Translate 0 0 -2\nObjectInstance \"tri\"\nTranslate 0 0 -2\nObjectInstance \"tri\"\n")));
  EXPECT_EQ(s.num_triangles(), 256u + 2u);  // disk (a fan of 256), planar patch
  EXPECT_EQ(s.instances.size(), 2u);          // the object, stored once, placed twice
  EXPECT_EQ(s.num_instanced_triangles(), 2u);
  ASSERT_EQ(s.spheres.size(), 1u);
  EXPECT_EQ(s.spheres[0].radius, 0.25f);  // from the Attribute
  EXPECT_TRUE(s.warnings.empty()) << s.warnings[0];
  int point = 0, spot = 0, distant = 0;
  for (const Light& l : s.lights) {
    if (l.type == LightType::Point) {
      ++point;
      EXPECT_EQ(l.point.intensity.z, 6.f);
    }
    spot += l.type == LightType::Spot;
    distant += l.type == LightType::Directional;
    if (l.type == LightType::Directional) EXPECT_EQ(l.directional.direction.z, -1.f);  // from → to
  }
  EXPECT_EQ(point + spot + distant, 3);
  EXPECT_EQ(point * spot * distant, 1);
  luz_test::render_finite(s);
}

// Infinite lights from images: a bright patch around light-space direction
// `dir` (pbrt's light space, z up) must appear to a camera looking along
// `dir`, and not to one looking the opposite way. `square`: pbrt-v4's
// equal-area octahedral map (pbrt-v4's EqualAreaSphereToSquare puts +x at
// (1, 0.5), +y at (0.5, 1) and +z at the centre); otherwise pbrt-v3's
// latitude-longitude map (φ = atan2(y, x) across, θ from +z down).
TEST_F(PbrtScene, InfiniteLightImagesAreOrientedAsPbrt) {
  auto check = [&](bool square, Vec3 patch, Vec3 up) {
    const int w = square ? 64 : 128, h = 64;
    Image img;
    img.width = w;
    img.height = h;
    img.rgb.assign(size_t(w) * h * 3, 0.f);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const double u = (x + 0.5) / w, v = (y + 0.5) / h;
        Vec3 d;
        if (square) {
          // Clarberg's inverse (pbrt-v4 EquiAreaSquareToSphere).
          const double uu = 2 * u - 1, vv = 2 * v - 1, up_ = std::fabs(uu), vp = std::fabs(vv);
          const double sd = 1 - (up_ + vp), dd = std::fabs(sd), r = 1 - dd;
          const double phi = (r == 0 ? 1 : (vp - up_) / r + 1) * M_PI / 4;
          const double z = std::copysign(1 - r * r, sd);
          const double cp = std::copysign(std::cos(phi), uu), sp = std::copysign(std::sin(phi), vv);
          const double s = r * std::sqrt(2 - r * r);
          d = {float(cp * s), float(sp * s), float(z)};
        } else {
          const double phi = 2 * M_PI * u, th = M_PI * v;
          d = {float(std::sin(th) * std::cos(phi)), float(std::sin(th) * std::sin(phi)), float(std::cos(th))};
        }
        if (dot(d, patch) > std::cos(25 * M_PI / 180))
          for (int c = 0; c < 3; ++c) img.rgb[(size_t(y) * w + x) * 3 + c] = 1.f;
      }
    write_image((dir / "env.pfm").string(), img);
    char b[512];
    auto look = [&](Vec3 d) {
      std::snprintf(b, sizeof b,
                    "LookAt 0 0 0  %g %g %g  %g %g %g\nCamera \"perspective\" \"float fov\" 10\n"
                    "Film \"rgb\" \"integer xresolution\" 4 \"integer yresolution\" 4\n"
                    "Sampler \"independent\" \"integer pixelsamples\" 16\nWorldBegin\n"
                    "LightSource \"infinite\" \"string filename\" \"env.pfm\"\n"
                    "Translate 50 50 50\nShape \"sphere\" \"float radius\" 0.01\n",
                    d.x, d.y, d.z, up.x, up.y, up.z);
      Scene s = load_scene(write("env.pbrt", b));
      std::vector<double> m = luz_test::pixel_means(luz_test::render_finite(s));
      double sum = 0;
      for (double x : m) sum += x;
      return sum / double(m.size());
    };
    EXPECT_NEAR(look(patch), 1.0, 0.02) << (square ? "square" : "lat-long") << " toward the patch";
    EXPECT_NEAR(look(-patch), 0.0, 1e-6) << (square ? "square" : "lat-long") << " away from the patch";
  };
  check(true, {1, 0, 0}, {0, 0, 1});
  check(true, {0, 1, 0}, {0, 0, 1});
  check(true, {0.f, 0.6f, -0.8f}, {1, 0, 0});
  check(false, {0, 1, 0}, {0, 0, 1});
  check(false, {0.6f, 0.f, 0.8f}, {0, 1, 0});
}

// ---- the shared scenes ----

namespace {

struct SharedScene {
  const char* dir;
  int warnings;  // expected one-line warnings (the SOURCES.md quirks and the refused-as-nearest parts)
};

// Renders at most `width` pixels wide (the aspect kept), `spp` samples.
Film render_small(Scene& s, int width, uint32_t spp, uint64_t seed = 7) {
  const int w = std::min(width, s.camera.width);
  s.camera.height = std::max(1, int(std::lround(double(s.camera.height) * w / s.camera.width)));
  s.camera.width = w;
  s.settings.spp = spp;
  s.settings.seed = seed;
  return luz_test::render_finite(s);
}

}  // namespace

// One ctest per shared pbrt-v4 scene: it loads unchanged, renders 48 pixels
// wide at 4 spp with no non-finite sample and not black; the load time is printed.
class PbrtEveryScene : public ::testing::TestWithParam<const char*> {};

TEST_P(PbrtEveryScene, LoadsAndRenders) {
  const char* d = GetParam();
  const std::string path = kScenes + "/" + d + "/pbrt-v4/scene-v4.pbrt";
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  Scene s = load_scene(path);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = double(std::clock() - c0) / CLOCKS_PER_SEC;
  std::printf("[pbrt] %s: loaded in %.3f s (%.3f s CPU), %zu triangles, %zu lights, %zu warnings\n", d, secs, cpu,
              size_t(s.num_triangles()), s.lights.size(), s.warnings.size());
  for (const std::string& w : s.warnings) std::printf("  %s\n", w.c_str());
  Film f = render_small(s, 48, 4);
  double sum = 0;
  for (double v : f.sum) sum += v;
  EXPECT_GT(sum, 0.0) << "a black image";
}

INSTANTIATE_TEST_SUITE_P(PbrtSharedScenes, PbrtEveryScene,
                         ::testing::Values("cornell-box-bitterli", "veach-mis-bitterli", "veach-bidir",
                                           "material-testball", "staircase"),
                         [](const ::testing::TestParamInfo<const char*>& i) {
                           std::string n = i.param;
                           for (char& c : n) c = c == '-' ? '_' : c;
                           return n;
                         });

// The SOURCES.md quirks: the testball's missing envmap.pfm falls back to
// envmap.hdr, the staircase's .tga names to the .jpg copies beside the
// Mitsuba version, each with one warning.
TEST(PbrtSharedScenes, QuirksFallBackWithOneWarningEach) {
  Scene t = load_scene(kScenes + "/material-testball/pbrt-v4/scene-v4.pbrt");
  int fallback = 0;
  for (const std::string& w : t.warnings) fallback += w.find("'textures/envmap.pfm' not found: using 'textures/envmap.hdr'") != std::string::npos;
  EXPECT_EQ(fallback, 1);
  Scene s = load_scene(kScenes + "/staircase/pbrt-v4/scene-v4.pbrt");
  fallback = 0;
  for (const std::string& w : s.warnings)
    fallback += w.find(".tga' not found: using '../mitsuba/textures/") != std::string::npos;
  EXPECT_EQ(fallback, 10);
}

// Bitterli's Cornell box, pbrt-v4 against Mitsuba 3, both through Luz: the
// same image within noise. 64 × 64 pixels, 8 × 8 blocks of 8 × 8 pixels;
// per block and channel |pbrt − mitsuba| ≤ z · sqrt(σ²_pbrt + σ²_mitsuba), the
// σ² from each film's per-pixel sample variance (independent seeds), z the
// Šidák threshold over all blocks and channels at family level 1e-3. The two
// files differ in conversions only (pbrt trianglemeshes with normals against
// Mitsuba rectangles and cubes, pbrt two-sided diffuse against Mitsuba's
// one-sided, which the camera sees only from the front; pbrt's maxdepth 65
// is Luz's max_depth 66 against the Mitsuba file's 65: the light a 66th
// segment adds is below 0.725^64 ≈ 1e-9 of the image): no extra tolerance.
TEST(PbrtSharedScenes, CornellBoxMatchesMitsubaVersion) {
  constexpr int kRes = 64, kBlock = 8;
  constexpr uint32_t kSpp = 256;
  Scene p = load_scene(kScenes + "/cornell-box-bitterli/pbrt-v4/scene-v4.pbrt");
  Scene m = load_scene(kScenes + "/cornell-box-bitterli/mitsuba3/scene_v3.xml",
                       {{"resx", std::to_string(kRes)}, {"resy", std::to_string(kRes)}});
  EXPECT_EQ(p.settings.integrator.max_depth, 66);  // pbrt maxdepth 65
  EXPECT_EQ(m.settings.integrator.max_depth, 65);
  for (Scene* s : {&p, &m}) {
    s->settings.sampler = SamplerType::Independent;
    s->settings.filter = FilterKind::Box;
  }
  Film fp = render_small(p, kRes, kSpp, 11), fm = render_small(m, kRes, kSpp, 12);
  ASSERT_EQ(fp.width, kRes);
  ASSERT_EQ(fp.height, kRes);
  luz_test::Blocks A = luz_test::make_blocks(fp, kBlock), B = luz_test::make_blocks(fm, kBlock);
  const int nb = kRes / kBlock;
  const double thr = luz_test::sidak_z(1e-3, 3.0 * nb * nb);
  double worst = 0, mean_a = 0, mean_b = 0, var_sum = 0;
  int over = 0;
  for (int by = 0; by < nb; ++by)
    for (int bx = 0; bx < nb; ++bx)
      for (int c = 0; c < 3; ++c) {
        const double z = std::fabs(A.m(bx, by, c) - B.m(bx, by, c)) / std::sqrt(A.v(bx, by, c) + B.v(bx, by, c));
        worst = std::max(worst, z);
        over += z > thr;
        mean_a += A.m(bx, by, c);
        mean_b += B.m(bx, by, c);
        var_sum += A.v(bx, by, c) + B.v(bx, by, c);
      }
  // Power: a 3% brighter image fails the test on the image mean.
  const double z_mean = std::fabs(mean_a - mean_b) / std::sqrt(var_sum);
  EXPECT_GT(std::fabs(1.03 * mean_a - mean_b) / std::sqrt(var_sum), luz_test::sidak_z(1e-3, 1)) << "test has no power";
  std::printf("[pbrt] cornell box pbrt vs mitsuba: worst block z %.2f (threshold %.2f), image mean %.5f vs %.5f "
              "(%+.3f%%, z %.2f)\n",
              worst, thr, mean_a / (3 * nb * nb), mean_b / (3 * nb * nb), 100 * (mean_a / mean_b - 1), z_mean);
  EXPECT_EQ(over, 0);
  EXPECT_LE(z_mean, luz_test::sidak_z(1e-3, 1));
}

// The pbrt-v4 Cornell box against Tungsten's reference render shipped with
// it (1024², half float), as test_reference.cpp does for the Mitsuba file:
// Luz at 64 × 64 with a box filter (each pixel the plain mean of 16 × 16
// reference pixels), 8 × 8 blocks; per block and channel
// |luz − ref| ≤ z · sqrt(σ²_luz + σ²_ref + rounding²), σ²_ref measured from
// the reference's own noise (stat_helpers.h), z Šidák over the 192 blocks
// at family level 1e-3. Conversions: pbrt's maxdepth 65 (Luz 66) against
// Tungsten's max_bounces 64 (Luz 65): below 1e-9 of the image; no other
// tolerance.
TEST(PbrtSharedScenes, CornellBoxMatchesTungstenReference) {
  constexpr int kRes = 64, kBlock = 8;
  Image ref = read_exr(kScenes + "/cornell-box-bitterli/reference/TungstenRender.exr");
  ASSERT_EQ(ref.width, 1024);
  Scene s = load_scene(kScenes + "/cornell-box-bitterli/pbrt-v4/scene-v4.pbrt");
  s.settings.sampler = SamplerType::Independent;
  s.settings.filter = FilterKind::Box;
  Film f = render_small(s, kRes, 512, 2024);
  const int nb = kRes / kBlock;
  luz_test::Blocks L = luz_test::make_blocks(f, kBlock);
  const luz_test::ReferenceBlocks R = luz_test::reference_blocks(ref, nb, nb, kBlock * (ref.width / kRes));
  const double thr = luz_test::sidak_z(1e-3, 3.0 * nb * nb);
  double worst = 0, lm = 0, rm = 0;
  int over = 0;
  for (int by = 0; by < nb; ++by)
    for (int bx = 0; bx < nb; ++bx)
      for (int c = 0; c < 3; ++c) {
        const size_t b = 3 * (size_t(by) * nb + bx) + c;
        const double fl = luz_test::rounding_floor(R.mean[b]);
        const double z = std::fabs(L.m(bx, by, c) - R.mean[b]) / std::sqrt(L.v(bx, by, c) + R.var[b] + fl * fl);
        worst = std::max(worst, z);
        over += z > thr;
        lm += L.m(bx, by, c);
        rm += R.mean[b];
      }
  std::printf("[pbrt] cornell box pbrt vs tungsten: worst block z %.2f (threshold %.2f), image mean %+.3f%%\n", worst,
              thr, 100 * (lm / rm - 1));
  EXPECT_EQ(over, 0);
}
