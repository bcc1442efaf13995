#include "luz/io/pbrt/parser.h"

#include <fast_float/fast_float.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <filesystem>
#include <memory>

#include "luz/io/error.h"
#include "luz/io/pbrt/tokenizer.h"

namespace fs = std::filesystem;

namespace luz::pbrt {

// ---- ParamSet ----

void ParamSet::error(const Param& p, const std::string& problem) {
  throw InputError(p.loc.file, p.loc.line, "parameter '" + p.name + "': " + problem);
}

const Param* ParamSet::find(const std::string& name) const {
  for (const Param& p : params)
    if (p.name == name) return &p;
  return nullptr;
}

const Param* ParamSet::typed(const std::string& name, std::initializer_list<const char*> types) const {
  const Param* p = find(name);
  if (!p) return nullptr;
  for (const char* t : types)
    if (p->type == t) {
      p->used = true;
      return p;
    }
  error(*p, "is of type '" + p->type + "', expected '" + *types.begin() + "'");
}

namespace {
template <typename V>
V single(const Param& p, const std::vector<V>& v) {
  if (v.size() != 1) ParamSet::error(p, "expected one value, found " + std::to_string(v.size()));
  return v[0];
}
}  // namespace

double ParamSet::get_float(const std::string& name, double def) const {
  const Param* p = typed(name, {"float"});
  return p ? single(*p, p->numbers) : def;
}
int ParamSet::get_int(const std::string& name, int def) const {
  const Param* p = typed(name, {"integer"});
  return p ? int(single(*p, p->numbers)) : def;
}
bool ParamSet::get_bool(const std::string& name, bool def) const {
  const Param* p = typed(name, {"bool"});
  return p ? bool(single(*p, p->bools)) : def;
}
std::string ParamSet::get_string(const std::string& name, const std::string& def) const {
  const Param* p = typed(name, {"string"});
  return p ? single(*p, p->strings) : def;
}
Vec3 ParamSet::get_point3(const std::string& name, Vec3 def) const {
  const Param* p = typed(name, {"point3", "point"});
  if (!p) return def;
  if (p->numbers.size() != 3) error(*p, "expected 3 values, found " + std::to_string(p->numbers.size()));
  return {float(p->numbers[0]), float(p->numbers[1]), float(p->numbers[2])};
}
std::vector<double> ParamSet::get_floats(const std::string& name) const {
  const Param* p = typed(name, {"float"});
  return p ? p->numbers : std::vector<double>{};
}
std::vector<int> ParamSet::get_ints(const std::string& name) const {
  const Param* p = typed(name, {"integer"});
  std::vector<int> out;
  if (p) out.assign(p->numbers.begin(), p->numbers.end());
  return out;
}
namespace {
std::vector<Vec3> triples(const Param* p) {
  std::vector<Vec3> out;
  if (!p) return out;
  out.resize(p->numbers.size() / 3);
  for (size_t i = 0; i < out.size(); ++i)
    out[i] = {float(p->numbers[3 * i]), float(p->numbers[3 * i + 1]), float(p->numbers[3 * i + 2])};
  return out;
}
}  // namespace
std::vector<Vec3> ParamSet::get_point3s(const std::string& name) const { return triples(typed(name, {"point3", "point"})); }
std::vector<Vec3> ParamSet::get_normals(const std::string& name) const { return triples(typed(name, {"normal", "normal3"})); }
std::vector<Vec2> ParamSet::get_point2s(const std::string& name) const {
  const Param* p = typed(name, {"point2"});
  std::vector<Vec2> out;
  if (!p) return out;
  out.resize(p->numbers.size() / 2);
  for (size_t i = 0; i < out.size(); ++i) out[i] = {float(p->numbers[2 * i]), float(p->numbers[2 * i + 1])};
  return out;
}
std::vector<std::string> ParamSet::get_strings(const std::string& name) const {
  const Param* p = typed(name, {"string"});
  return p ? p->strings : std::vector<std::string>{};
}
std::string ParamSet::get_texture(const std::string& name) const {
  const Param* p = find(name);
  if (!p || p->type != "texture") return {};
  p->used = true;
  return single(*p, p->strings);
}
void ParamSet::report_unused(const std::function<void(const Param&)>& warn) const {
  for (const Param& p : params)
    if (!p.used) warn(p);
}

// ---- the parser ----

namespace {

// The number of values per item of each type (0: strings or bools), as pbrt-v4 names them.
struct TypeInfo {
  const char* name;
  int per_item;  // values per item; 0: any count (spectrum)
  enum Kind { Number, String, Bool, NumberOrString } kind;
};
constexpr TypeInfo kTypes[] = {
    {"integer", 1, TypeInfo::Number}, {"float", 1, TypeInfo::Number},    {"point2", 2, TypeInfo::Number},
    {"vector2", 2, TypeInfo::Number}, {"point3", 3, TypeInfo::Number},   {"vector3", 3, TypeInfo::Number},
    {"normal3", 3, TypeInfo::Number}, {"normal", 3, TypeInfo::Number},   {"point", 3, TypeInfo::Number},
    {"vector", 3, TypeInfo::Number},  {"rgb", 3, TypeInfo::Number},      {"color", 3, TypeInfo::Number},
    {"blackbody", 1, TypeInfo::Number}, {"bool", 1, TypeInfo::Bool},    {"string", 1, TypeInfo::String},
    {"texture", 1, TypeInfo::String}, {"spectrum", 0, TypeInfo::NumberOrString},
};

struct Tok {
  Token t;
  const std::string* file = nullptr;
};

class Parser {
 public:
  Parser(ParserTarget& target, const std::string& main_file) : target_(target) {
    search_dir_ = fs::path(main_file).parent_path();
  }

  void push(std::unique_ptr<Tokenizer> tz) {
    std::error_code ec;
    fs::path canon = fs::weakly_canonical(tz->file(), ec);
    stack_.push_back({tz.get(), ec ? tz->file() : canon.string()});
    all_.push_back(std::move(tz));
  }

  void run() {
    Tok t;
    while (next(t)) directive(t);
    target_.end_of_files();
  }

 private:
  struct Open {
    Tokenizer* tz;
    std::string canonical;
  };

  bool next(Tok& t) {
    if (has_peek_) {
      has_peek_ = false;
      t = peek_;
      return true;
    }
    while (!stack_.empty()) {
      if (stack_.back().tz->next(t.t)) {
        t.file = &stack_.back().tz->file();
        return true;
      }
      stack_.pop_back();
    }
    return false;
  }
  const Tok* peek() {
    if (!has_peek_) {
      Tok t;
      if (!next(t)) return nullptr;
      peek_ = t;
      has_peek_ = true;
    }
    return &peek_;
  }

  static SourceLoc loc(const Tok& t) { return {*t.file, t.t.line}; }
  [[noreturn]] static void error(const Tok& t, const std::string& problem) {
    throw InputError(*t.file, t.t.line, problem);
  }
  static std::string shown(const Tok& t) {
    std::string s(t.t.text.substr(0, 40));
    return t.t.text.size() > 40 ? s + "..." : s;
  }

  static bool parse_number(const Tok& t, double& v) {
    const char* b = t.t.text.data();
    const char* e = b + t.t.text.size();
    if (b != e && *b == '+') ++b;  // fast_float refuses a leading '+'
    auto r = fast_float::from_chars(b, e, v);
    return r.ec == std::errc() && r.ptr == e && std::isfinite(v);
  }
  double number(const Tok& t) {
    double v;
    if (!parse_number(t, v)) error(t, "bad number '" + shown(t) + "'");
    return v;
  }

  // The directive's quoted argument.
  std::string string_arg(const Tok& dir, const char* what) {
    const Tok* p = peek();
    if (!p || !p->t.quoted())
      error(dir, std::string(dir.t.text) + " needs " + what + " (a quoted string)" +
                     (p ? ", found '" + shown(*p) + "'" : ", found the end of the file"));
    Tok t;
    next(t);
    return unquote(*t.file, t.t);
  }
  double number_arg(const Tok& dir) {
    Tok t;
    if (!next(t)) error(dir, std::string(dir.t.text) + " needs more numbers, found the end of the file");
    if (t.t.quoted() || t.t.is("[") || t.t.is("]"))
      error(t, std::string(dir.t.text) + " needs a number, found '" + shown(t) + "'");
    return number(t);
  }
  // n numbers, bracketed or not.
  void numbers_arg(const Tok& dir, int n, double* out) {
    const Tok* p = peek();
    const bool bracket = p && p->t.is("[");
    Tok open;
    if (bracket) next(open);
    for (int i = 0; i < n; ++i) out[i] = number_arg(dir);
    if (bracket) {
      Tok close;
      if (!next(close)) error(open, "missing ']' (the file ends)");
      if (!close.t.is("]")) error(close, "missing ']' after " + std::to_string(n) + " numbers, found '" + shown(close) + "'");
    }
  }
  Vec3 vec3_arg(const Tok& dir) {
    double v[3];
    numbers_arg(dir, 3, v);
    return {float(v[0]), float(v[1]), float(v[2])};
  }

  // One value item of a parameter list.
  void add_value(Param& p, const TypeInfo& ti, const Tok& v) {
    if (v.t.quoted()) {
      std::string s = unquote(*v.file, v.t);
      if (ti.kind == TypeInfo::Bool) {
        if (s != "true" && s != "false") error(v, "parameter '" + p.name + "': bool value must be true or false, found \"" + s + "\"");
        p.bools.push_back(s == "true");
      } else if (ti.kind == TypeInfo::String || ti.kind == TypeInfo::NumberOrString) {
        p.strings.push_back(std::move(s));
      } else {
        error(v, "parameter '" + p.name + "' of type '" + p.type + "' takes numbers, found a string");
      }
      return;
    }
    if (ti.kind == TypeInfo::Bool) {
      if (!v.t.is("true") && !v.t.is("false"))
        error(v, "parameter '" + p.name + "': bool value must be true or false, found '" + shown(v) + "'");
      p.bools.push_back(v.t.is("true"));
      return;
    }
    if (ti.kind == TypeInfo::String)
      error(v, "parameter '" + p.name + "' of type '" + p.type + "' takes quoted strings, found '" + shown(v) + "'");
    const double x = number(v);
    if (p.type == "integer" && (x != std::floor(x) || x < double(INT_MIN) || x > double(INT_MAX)))
      error(v, "parameter '" + p.name + "' is an integer, found '" + shown(v) + "'");
    p.numbers.push_back(x);
  }

  ParamSet params() {
    ParamSet ps;
    for (;;) {
      const Tok* p = peek();
      if (!p || !p->t.quoted()) break;
      Tok decl;
      next(decl);
      const std::string d = unquote(*decl.file, decl.t);
      // "type name": two words.
      std::vector<std::string> words;
      size_t i = 0;
      while (i < d.size()) {
        while (i < d.size() && (d[i] == ' ' || d[i] == '\t')) ++i;
        size_t j = i;
        while (j < d.size() && d[j] != ' ' && d[j] != '\t') ++j;
        if (j > i) words.push_back(d.substr(i, j - i));
        i = j;
      }
      if (words.size() != 2) error(decl, "expected a parameter \"type name\", found \"" + d + "\"");
      Param par;
      par.type = words[0];
      par.name = words[1];
      par.loc = loc(decl);
      const TypeInfo* ti = nullptr;
      for (const TypeInfo& t : kTypes)
        if (par.type == t.name) ti = &t;
      if (!ti) error(decl, "unknown parameter type '" + par.type + "' (parameter '" + par.name + "')");
      if (ps.find(par.name)) error(decl, "parameter '" + par.name + "' given twice");
      Tok v;
      if (!next(v)) error(decl, "parameter '" + par.name + "' has no value (the file ends)");
      if (v.t.is("[")) {
        for (;;) {
          Tok w;
          if (!next(w)) error(v, "missing ']' (the file ends)");
          if (w.t.is("]")) break;
          if (w.t.is("[")) error(w, "'[' inside a list (missing ']' for the list opened at line " + std::to_string(v.t.line) + "?)");
          // A directive's name: the list was never closed.
          if (!w.t.quoted() && std::isalpha((unsigned char)w.t.text[0]) && !w.t.is("true") && !w.t.is("false"))
            error(w, "missing ']' for the list opened at line " + std::to_string(v.t.line) + " (found '" + shown(w) + "')");
          add_value(par, *ti, w);
        }
      } else if (v.t.is("]")) {
        error(v, "unexpected ']'");
      } else {
        add_value(par, *ti, v);
      }
      const size_t n = par.numbers.size() + par.strings.size() + par.bools.size();
      if (n == 0) error(decl, "parameter '" + par.name + "' has no values");
      if (ti->per_item > 1 && (par.numbers.size() % size_t(ti->per_item) != 0))
        error(decl, "parameter '" + par.name + "' of type '" + par.type + "' needs a multiple of " +
                        std::to_string(ti->per_item) + " values, found " + std::to_string(n));
      if (ti->kind == TypeInfo::NumberOrString && !par.numbers.empty() && !par.strings.empty())
        error(decl, "parameter '" + par.name + "' mixes numbers and strings");
      ps.params.push_back(std::move(par));
    }
    return ps;
  }

  // A directive of a quoted name (a type) and a parameter list.
  using Named = void (ParserTarget::*)(const SourceLoc&, const std::string&, ParamSet);
  void named(const Tok& t, Named f) {
    const bool is_name = t.t.is("MakeNamedMaterial") || t.t.is("MakeNamedMedium") || t.t.is("Attribute");
    std::string name = string_arg(t, is_name ? "a name" : "a type");
    ParamSet ps = params();
    (target_.*f)(loc(t), name, std::move(ps));
  }

  void include(const Tok& dir) {
    const std::string name = string_arg(dir, "a file name");
    fs::path path = fs::path(name);
    if (path.is_relative()) path = search_dir_ / path;
    std::error_code ec;
    const std::string canon = fs::weakly_canonical(path, ec).string();
    for (size_t i = 0; i < stack_.size(); ++i)
      if (!ec && stack_[i].canonical == canon) {
        std::string chain;
        for (size_t k = i; k < stack_.size(); ++k) chain += fs::path(stack_[k].tz->file()).filename().string() + " -> ";
        error(dir, "include cycle: " + chain + path.filename().string());
      }
    if (!fs::is_regular_file(path, ec))
      error(dir, "cannot include '" + path.string() + "': " + (fs::exists(path, ec) ? "not a regular file" : "no such file"));
    if (stack_.size() >= 256) error(dir, "includes nested more than 256 deep");
    std::unique_ptr<Tokenizer> tz;
    try {
      tz = std::make_unique<Tokenizer>(Tokenizer::from_file(path.string()));
    } catch (const InputError& e) {
      error(dir, e.what());
    }
    // The lookahead (if any) belongs to the includer: none is pending here,
    // since string_arg consumed the file name and nothing was peeked after it.
    push(std::move(tz));
  }

  void directive(const Tok& t) {
    if (t.t.quoted() || t.t.is("[") || t.t.is("]"))
      error(t, "expected a directive, found '" + shown(t) + "'");
    // Directives of a quoted name and a parameter list.
    static const std::pair<const char*, Named> kNamed[] = {
        {"Accelerator", &ParserTarget::accelerator},
        {"AreaLightSource", &ParserTarget::area_light_source},
        {"Attribute", &ParserTarget::attribute},
        {"Camera", &ParserTarget::camera},
        {"Film", &ParserTarget::film},
        {"Integrator", &ParserTarget::integrator},
        {"LightSource", &ParserTarget::light_source},
        {"MakeNamedMaterial", &ParserTarget::make_named_material},
        {"MakeNamedMedium", &ParserTarget::make_named_medium},
        {"Material", &ParserTarget::material},
        {"PixelFilter", &ParserTarget::pixel_filter},
        {"Sampler", &ParserTarget::sampler},
        {"Shape", &ParserTarget::shape},
    };
    const std::string_view d = t.t.text;
    for (const auto& [name, f] : kNamed)
      if (d == name) return named(t, f);
    const SourceLoc at = loc(t);
    ParserTarget& g = target_;
    if (d == "AttributeBegin") g.attribute_begin(at);
    else if (d == "AttributeEnd") g.attribute_end(at);
    else if (d == "ActiveTransform") {
      Tok w;
      if (!next(w) || (!w.t.is("All") && !w.t.is("StartTime") && !w.t.is("EndTime")))
        error(t, "ActiveTransform needs All, StartTime or EndTime");
      g.active_transform(at, std::string(w.t.text));
    } else if (d == "ConcatTransform" || d == "Transform") {
      double m[16];
      numbers_arg(t, 16, m);
      if (d == "Transform") g.transform(at, m);
      else g.concat_transform(at, m);
    } else if (d == "CoordinateSystem") g.coordinate_system(at, string_arg(t, "a name"));
    else if (d == "CoordSysTransform") g.coord_sys_transform(at, string_arg(t, "a name"));
    else if (d == "ColorSpace") g.color_space(at, string_arg(t, "a name"));
    else if (d == "Include" || d == "Import") include(t);
    else if (d == "Identity") g.identity(at);
    else if (d == "LookAt") {
      double v[9];
      for (double& x : v) x = number_arg(t);
      g.look_at(at, {float(v[0]), float(v[1]), float(v[2])}, {float(v[3]), float(v[4]), float(v[5])},
                {float(v[6]), float(v[7]), float(v[8])});
    } else if (d == "MediumInterface") {
      std::string inside = string_arg(t, "a medium name");
      std::string outside = inside;
      if (const Tok* p = peek(); p && p->t.quoted()) outside = string_arg(t, "a medium name");
      g.medium_interface(at, inside, outside);
    } else if (d == "NamedMaterial") g.named_material(at, string_arg(t, "a name"));
    else if (d == "ObjectBegin") g.object_begin(at, string_arg(t, "a name"));
    else if (d == "ObjectEnd") g.object_end(at);
    else if (d == "ObjectInstance") g.object_instance(at, string_arg(t, "a name"));
    else if (d == "Option") {
      ParamSet ps = params();
      if (ps.params.size() != 1) error(t, "Option needs one \"type name\" value");
      g.option(at, ps.params[0]);
    } else if (d == "ReverseOrientation") g.reverse_orientation(at);
    else if (d == "Rotate") {
      double v[4];
      for (double& x : v) x = number_arg(t);
      g.rotate(at, v[0], {float(v[1]), float(v[2]), float(v[3])});
    } else if (d == "Scale") g.scale(at, vec3_arg(t));
    else if (d == "TransformBegin") g.transform_begin(at);
    else if (d == "TransformEnd") g.transform_end(at);
    else if (d == "TransformTimes") {
      const double a = number_arg(t), b = number_arg(t);
      g.transform_times(at, a, b);
    } else if (d == "Texture") {
      std::string name = string_arg(t, "a name");
      std::string type = string_arg(t, "a type (\"float\" or \"spectrum\")");
      std::string cls = string_arg(t, "a class");
      g.texture(at, name, type, cls, params());
    } else if (d == "Translate") g.translate(at, vec3_arg(t));
    else if (d == "WorldBegin") g.world_begin(at);
    else error(t, "unknown directive '" + shown(t) + "'");
  }

  ParserTarget& target_;
  fs::path search_dir_;
  std::vector<std::unique_ptr<Tokenizer>> all_;  // every file read, alive while tokens point into them
  std::vector<Open> stack_;
  Tok peek_;
  bool has_peek_ = false;
};

}  // namespace

void parse_file(const std::string& path, ParserTarget& target) {
  auto tz = std::make_unique<Tokenizer>(Tokenizer::from_file(path));
  Parser p(target, path);
  p.push(std::move(tz));
  p.run();
}

void parse_string(const std::string& name, std::string text, ParserTarget& target) {
  Parser p(target, name);
  p.push(std::make_unique<Tokenizer>(name, std::move(text)));
  p.run();
}

}  // namespace luz::pbrt
