// pbrt-v4 scenes (io/pbrt/): the tokenizer and parser on small texts, every
// malformed input as one InputError naming file and line.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "luz/device/cpu/render.h"
#include "luz/io/error.h"
#include "luz/io/load.h"
#include "luz/io/pbrt/parser.h"
#include "luz/io/pbrt/tokenizer.h"
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

