// pbrt-v4 scene files, second stage: directives and their parameter lists
// (pbrt-v4's parser.cpp and paramdict.h). The parser reads the tokens of the
// scene file and of the files it includes and calls one ParserTarget method
// per directive, as pbrt-v4's ParserTarget. A parameter list is a sequence
// of `"type name" value` with value a bracketed list or a single item; each
// parameter remembers whether it was looked up, so that what the translation
// never read can be reported (pbrt-v4's ReportUnused).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "luz/math/vec.h"
#include "luz/scene/scene_builder.h"

namespace luz::pbrt {

// One parameter: "type name" and its values (numbers, strings or bools by type).
struct Param {
  std::string type, name;
  std::vector<double> numbers;       // integer, float, point*, vector*, normal*, rgb, blackbody
  std::vector<std::string> strings;  // string, texture, spectrum (a named spectrum or a file)
  std::vector<bool> bools;           // bool
  SourceLoc loc;
  mutable bool used = false;
};

// The parameters of one directive. Lookups mark what they read as used; a
// parameter of the name looked up but of another type is an InputError
// naming its file and line, as is a value of the wrong kind or count.
class ParamSet {
 public:
  std::vector<Param> params;

  const Param* find(const std::string& name) const;
  bool has(const std::string& name) const { return find(name) != nullptr; }

  double get_float(const std::string& name, double def) const;
  int get_int(const std::string& name, int def) const;
  bool get_bool(const std::string& name, bool def) const;
  std::string get_string(const std::string& name, const std::string& def) const;
  Vec3 get_point3(const std::string& name, Vec3 def) const;
  // Arrays: empty when absent.
  std::vector<double> get_floats(const std::string& name) const;
  std::vector<int> get_ints(const std::string& name) const;
  std::vector<Vec3> get_point3s(const std::string& name) const;  // point3 / point
  std::vector<Vec3> get_normals(const std::string& name) const;   // normal / normal3
  std::vector<Vec2> get_point2s(const std::string& name) const;   // point2
  std::vector<std::string> get_strings(const std::string& name) const;
  // A parameter that is a texture (type "texture"): its name; empty when
  // the parameter is absent or of another type (then left for the caller).
  std::string get_texture(const std::string& name) const;

  // Calls `warn` for every parameter not looked up.
  void report_unused(const std::function<void(const Param&)>& warn) const;
  [[noreturn]] static void error(const Param& p, const std::string& problem);

 private:
  const Param* typed(const std::string& name, std::initializer_list<const char*> types) const;
};

// What the parser calls, one method per pbrt-v4 directive. `at` is where the
// directive's name stands.
class ParserTarget {
 public:
  virtual ~ParserTarget() = default;
  virtual void identity(const SourceLoc& at) = 0;
  virtual void translate(const SourceLoc& at, Vec3 d) = 0;
  virtual void scale(const SourceLoc& at, Vec3 s) = 0;
  virtual void rotate(const SourceLoc& at, double degrees, Vec3 axis) = 0;
  virtual void look_at(const SourceLoc& at, Vec3 eye, Vec3 target, Vec3 up) = 0;
  // 16 values as written: pbrt-v4 reads them as the transpose (columns).
  virtual void concat_transform(const SourceLoc& at, const double m[16]) = 0;
  virtual void transform(const SourceLoc& at, const double m[16]) = 0;
  virtual void coordinate_system(const SourceLoc& at, const std::string& name) = 0;
  virtual void coord_sys_transform(const SourceLoc& at, const std::string& name) = 0;
  virtual void active_transform(const SourceLoc& at, const std::string& which) = 0;
  virtual void transform_times(const SourceLoc& at, double start, double end) = 0;
  virtual void reverse_orientation(const SourceLoc& at) = 0;
  virtual void option(const SourceLoc& at, const Param& p) = 0;
  virtual void color_space(const SourceLoc& at, const std::string& name) = 0;
  virtual void camera(const SourceLoc& at, const std::string& name, ParamSet params) = 0;
  virtual void film(const SourceLoc& at, const std::string& name, ParamSet params) = 0;
  virtual void sampler(const SourceLoc& at, const std::string& name, ParamSet params) = 0;
  virtual void pixel_filter(const SourceLoc& at, const std::string& name, ParamSet params) = 0;
  virtual void integrator(const SourceLoc& at, const std::string& name, ParamSet params) = 0;
  virtual void accelerator(const SourceLoc& at, const std::string& name, ParamSet params) = 0;
  virtual void make_named_medium(const SourceLoc& at, const std::string& name, ParamSet params) = 0;
  virtual void medium_interface(const SourceLoc& at, const std::string& inside, const std::string& outside) = 0;
  virtual void world_begin(const SourceLoc& at) = 0;
  virtual void attribute_begin(const SourceLoc& at) = 0;
  virtual void attribute_end(const SourceLoc& at) = 0;
  // TransformBegin / TransformEnd (deprecated in pbrt-v4, still read).
  virtual void transform_begin(const SourceLoc& at) = 0;
  virtual void transform_end(const SourceLoc& at) = 0;
  virtual void attribute(const SourceLoc& at, const std::string& target, ParamSet params) = 0;
  virtual void texture(const SourceLoc& at, const std::string& name, const std::string& type,
                       const std::string& tex_class, ParamSet params) = 0;
  virtual void material(const SourceLoc& at, const std::string& name, ParamSet params) = 0;
  virtual void make_named_material(const SourceLoc& at, const std::string& name, ParamSet params) = 0;
  virtual void named_material(const SourceLoc& at, const std::string& name) = 0;
  virtual void light_source(const SourceLoc& at, const std::string& name, ParamSet params) = 0;
  virtual void area_light_source(const SourceLoc& at, const std::string& name, ParamSet params) = 0;
  virtual void shape(const SourceLoc& at, const std::string& name, ParamSet params) = 0;
  virtual void object_begin(const SourceLoc& at, const std::string& name) = 0;
  virtual void object_end(const SourceLoc& at) = 0;
  virtual void object_instance(const SourceLoc& at, const std::string& name) = 0;
  virtual void end_of_files() = 0;
};

// Parses `path` and every file it includes, calling `target`. Include and
// Import name files relative to the directory of the scene file (pbrt-v4's
// search directory); Import is read as Include (pbrt-v4 allows it to be read
// in parallel; the result is the same). Every problem is an InputError
// "file:line: problem"; an include cycle names the chain.
void parse_file(const std::string& path, ParserTarget& target);
// The same for text in memory, `name` standing for its file (includes
// relative to name's directory).
void parse_string(const std::string& name, std::string text, ParserTarget& target);

}  // namespace luz::pbrt
