// The XML plumbing of the Mitsuba reader: the file, <default> and $params,
// property lookup (Props), names of Mitsuba 0.5/0.6, numbers, transforms and
// errors (see parser.h).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include "luz/io/mitsuba/parser.h"

namespace luz {

namespace mitsuba {

namespace {

// The whole file, or an InputError that says why not (no std::filesystem or
// stream exception escapes).
std::string read_text_file(const std::string& path) {
  std::error_code ec;
  fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) throw InputError(path, 0, "cannot open file: no such file");
  if (fs::is_directory(st)) throw InputError(path, 0, "cannot open file: is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, std::string("cannot open file: ") + std::strerror(errno));
  std::stringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw InputError(path, 0, "read error");
  return ss.str();
}

}  // namespace

Scene MitsubaParser::parse() {
  text_ = read_text_file(path_);
  pugi::xml_parse_result res = doc_.load_buffer(text_.data(), text_.size(), pugi::parse_default);
  if (!res) throw InputError(path_, line_at(size_t(res.offset)), std::string("malformed XML: ") + res.description());
  pugi::xml_node root = doc_.child("scene");
  if (!root) error(doc_.document_element(), "root element must be <scene>");
  legacy_names_ = scene_version_legacy(root);
  for (pugi::xml_node n = doc_.first_child(); n; n = n.next_sibling())
    if (n.type() == pugi::node_element && (std::string(n.name()) != "scene" || n != root))
      error(n, "unexpected top-level element <" + std::string(n.name()) + ">");

  // Parameters: <default> values, overridden by the command line's -D.
  params_ = defines_;
  std::set<std::string> declared_defaults;
  for (pugi::xml_node n : root.children("default")) {
    std::string name = attr(n, "name");
    if (name.empty() || !std::all_of(name.begin(), name.end(), [](unsigned char c) { return std::isalnum(c) || c == '_'; }))
      error(n, "<default> name '" + name + "' must be letters, digits and '_'");
    if (!declared_defaults.insert(name).second) error(n, "<default name=\"" + name + "\"> given twice");
    for (pugi::xml_attribute a : n.attributes())
      if (std::string(a.name()) != "name" && std::string(a.name()) != "value")
        error(n, "unknown attribute '" + std::string(a.name()) + "' of <default>");
    std::string value = attr(n, "value");
    if (!params_.count(name)) params_[name] = value;
  }
  for (const auto& [name, value] : defines_) {
    bool declared = false;
    for (pugi::xml_node n : root.children("default"))
      if (n.attribute("name").value() == name) declared = true;
    if (!declared) throw InputError(path_, 0, "-D " + name + ": the scene declares no <default name=\"" + name + "\">");
  }

  include_stack_.push_back(fs::absolute(path_).lexically_normal().string());
  read_ahead(root);
  parse_top_level(root);
  if (!have_sensor_) throw InputError(path_, 0, "the scene has no <sensor>");
  return builder_.finish();
}

// Whether a <scene> names parameters in Mitsuba 0.5/0.6's camelCase: its
// version is below 2, or it is 2.x (a version bumped by hand, as the shared
// material-testball's 2.0.0) and a parameter name holds a capital, which no
// Mitsuba 2 name does: then the names are upgraded with a warning. A
// version 3 scene's names are taken as written.
bool MitsubaParser::scene_version_legacy(pugi::xml_node root) {
  pugi::xml_attribute v = root.attribute("version");
  if (!v) return false;
  int major = 0;
  const char* b = v.value();
  auto r = std::from_chars(b, b + std::strlen(b), major);
  if (r.ec != std::errc() || (*r.ptr != '.' && *r.ptr != '\0'))
    error(root, "version '" + std::string(b) + "' is not a version number (as 3.0.0)");
  if (major < 2) return true;
  if (major > 2) return false;
  const pugi::xml_node n = root.find_node([](pugi::xml_node c) {
    const std::string name = c.attribute("name").value();
    return kPropertyTags.count(c.name()) &&
           std::any_of(name.begin(), name.end(), [](unsigned char ch) { return std::isupper(ch); });
  });
  if (n) {
    builder_.warn(loc(n), "parameter '" + std::string(n.attribute("name").value()) +
                              "' is a Mitsuba 0.5/0.6 camelCase name in a version " + b +
                              " scene: the file's names are read as Mitsuba 0.6's");
    return true;
  }
  return false;
}

// The elements of a <scene>, of the scene file or of an included one.
void MitsubaParser::parse_top_level(pugi::xml_node root) {
  for (pugi::xml_node n : root.children()) {
    if (n.type() != pugi::node_element) continue;
    std::string tag = n.name();
    if (tag == "default") {
      if (include_stack_.size() > 1) error(n, "<default> in an included file is not supported (declare it in the scene file)");
      continue;  // read by parse()
    }
    if (tag == "integrator") {
      if (have_integrator_) error(n, "only one <integrator> is supported");
      parse_integrator(n);
      have_integrator_ = true;
    } else if (tag == "sensor") {
      if (have_sensor_) error(n, "only one <sensor> is supported");
      parse_sensor(n);
      have_sensor_ = true;
    } else if (tag == "bsdf") {
      parse_bsdf(n);
    } else if (tag == "texture") {
      const std::string id = n.attribute("id").value();
      if (id.empty()) error(n, "a top-level <texture> needs an id");
      if (textures_.count(id) || bsdfs_.count(id) || shapegroups_.count(id)) error(n, "duplicate id '" + id + "'");
      textures_[id] = uint32_t(parse_texture(n, true));
    } else if (tag == "shape") parse_shape(n);
    else if (tag == "emitter") parse_emitter(n);
    else if (tag == "include") parse_include(n);
    else error(n, "unsupported element <" + tag + ">");
  }
}

// Mitsuba's <include filename="..."/>: a file (relative to the including
// one) whose <scene> holds more top-level elements, read in its own
// version's names; a file that includes itself, directly or not, is refused.
void MitsubaParser::parse_include(pugi::xml_node n) {
  for (pugi::xml_attribute a : n.attributes())
    if (std::string(a.name()) != "filename") error(n, "unknown attribute '" + std::string(a.name()) + "' of <include>");
  if (n.first_child()) error(n, "<include> takes no children");
  const fs::path full = resolve_file(n, attr(n, "filename"), "included file");
  const std::string key = fs::absolute(full).lexically_normal().string();
  for (const std::string& f : include_stack_)
    if (f == key) error(n, "'" + full.string() + "' includes itself (a cycle of includes)");
  if (include_stack_.size() > 64) error(n, "includes nested more than 64 deep");

  // Messages name the included file and its lines while it is read.
  struct Context {
    MitsubaParser& p;
    std::string path, text;
    bool legacy;
    explicit Context(MitsubaParser& parser) : p(parser), path(p.path_), text(p.text_), legacy(p.legacy_names_) {}
    ~Context() {
      p.path_ = std::move(path);
      p.text_ = std::move(text);
      p.legacy_names_ = legacy;
      p.include_stack_.pop_back();
    }
  } context(*this);
  include_stack_.push_back(key);
  path_ = full.string();
  text_ = read_text_file(path_);
  included_.push_back(std::make_unique<pugi::xml_document>());
  pugi::xml_document& doc = *included_.back();
  pugi::xml_parse_result res = doc.load_buffer(text_.data(), text_.size(), pugi::parse_default);
  if (!res) throw InputError(path_, line_at(size_t(res.offset)), std::string("malformed XML: ") + res.description());
  pugi::xml_node root = doc.document_element();
  if (std::string(root.name()) != "scene") error(root, "the root element of an included file must be <scene>");
  for (pugi::xml_node c = doc.first_child(); c; c = c.next_sibling())
    if (c.type() == pugi::node_element && c != root)
      error(c, "unexpected top-level element <" + std::string(c.name()) + ">");
  legacy_names_ = scene_version_legacy(root);
  parse_top_level(root);
}

int MitsubaParser::line_at(size_t offset) const {
  offset = std::min(offset, text_.size());
  return 1 + int(std::count(text_.begin(), text_.begin() + std::ptrdiff_t(offset), '\n'));
}

// Mitsuba 3's upgrade of a 0.5/0.6 name: an underscore between a lower-case
// letter or digit and the capital after it, then all lower case (toWorld ->
// to_world, sampleCount -> sample_count, intIOR -> int_ior).
std::string MitsubaParser::camel_case_name(const std::string& name) {
  std::string out;
  for (size_t i = 0; i < name.size(); ++i) {
    unsigned char c = (unsigned char)name[i], prev = i > 0 ? (unsigned char)name[i - 1] : 0;
    if (std::isupper(c) && (std::islower(prev) || std::isdigit(prev))) out += '_';
    out += char(std::tolower(c));
  }
  return out;
}

std::string MitsubaParser::param_name(pugi::xml_node n) const {
  std::string name = attr(n, "name");
  return legacy_names_ ? camel_case_name(name) : name;
}

std::string MitsubaParser::attr(pugi::xml_node n, const char* name, bool required) const {
  pugi::xml_attribute a = n.attribute(name);
  if (!a) {
    if (required) error(n, "<" + std::string(n.name()) + "> lacks the attribute '" + name + "'");
    return "";
  }
  std::string v = a.value(), out;
  for (size_t i = 0; i < v.size();) {
    if (v[i] != '$') {
      out += v[i++];
      continue;
    }
    size_t j = i + 1;
    while (j < v.size() && (std::isalnum((unsigned char)v[j]) || v[j] == '_')) ++j;
    std::string key = v.substr(i + 1, j - i - 1);
    auto it = params_.find(key);
    if (key.empty() || it == params_.end()) error(n, "undefined parameter '$" + key + "'");
    out += it->second;
    i = j;
  }
  return out;
}

double MitsubaParser::number(pugi::xml_node n, const std::string& s) const {
  const char* b = s.data();
  const char* e = b + s.size();
  while (b < e && std::isspace((unsigned char)*b)) ++b;
  while (e > b && std::isspace((unsigned char)e[-1])) --e;
  if (b < e && *b == '+') ++b;
  double v = 0;
  auto r = std::from_chars(b, e, v);
  if (r.ec == std::errc::result_out_of_range && r.ptr == e && b != e)
    error(n, "'" + s + "' is not a finite number (out of range)");
  if (r.ec != std::errc() || r.ptr != e || b == e) error(n, "'" + s + "' is not a number");
  if (!std::isfinite(v)) error(n, "'" + s + "' is not a finite number");
  // Everything ends up in 32-bit floats: a larger magnitude would become inf.
  if (std::fabs(v) > double(std::numeric_limits<float>::max()))
    error(n, "'" + s + "' is out of the range of a 32-bit float");
  return v;
}

std::vector<double> MitsubaParser::numbers(pugi::xml_node n, const std::string& s) const {
  std::vector<double> out;
  std::string tok;
  for (size_t i = 0; i <= s.size(); ++i) {
    if (i == s.size() || s[i] == ',' || std::isspace((unsigned char)s[i])) {
      if (!tok.empty()) out.push_back(number(n, tok));
      tok.clear();
    } else {
      tok += s[i];
    }
  }
  return out;
}

Vec3 MitsubaParser::vec3_attr(pugi::xml_node n, const char* name) const {
  std::vector<double> v = numbers(n, attr(n, name));
  if (v.size() != 3) error(n, std::string("'") + name + "' needs 3 numbers");
  return {float(v[0]), float(v[1]), float(v[2])};
}

Color MitsubaParser::srgb_color(pugi::xml_node n, const std::string& v) const {
  if (!legacy_names_) error(n, "<srgb> is a Mitsuba 0.5 tag; use <rgb> (linear values)");
  double c[3];
  if (!v.empty() && v[0] == '#') {
    unsigned rgb = 0;
    if (v.size() != 7 || std::from_chars(v.data() + 1, v.data() + 7, rgb, 16).ptr != v.data() + 7)
      error(n, "'" + v + "' is not a colour of the form #rrggbb");
    for (int k = 0; k < 3; ++k) c[k] = ((rgb >> (16 - 8 * k)) & 255u) / 255.0;
  } else {
    std::vector<double> x = numbers(n, v);
    if (x.size() != 1 && x.size() != 3) error(n, "<srgb> needs #rrggbb, 1 or 3 numbers");
    for (int k = 0; k < 3; ++k) c[k] = x[x.size() == 1 ? 0 : size_t(k)];
  }
  Color out;
  for (int k = 0; k < 3; ++k) {
    if (!(c[k] >= 0.0 && c[k] <= 1.0)) error(n, "<srgb> values must lie in [0, 1]");
    out[k] = float(srgb_to_linear(c[k]));
  }
  return out;
}

MitsubaParser::Props::Props(const MitsubaParser* parser, pugi::xml_node node) : p(parser), owner(node) {
  for (pugi::xml_node c : node.children()) {
    if (c.type() != pugi::node_element) continue;
    if (!kPropertyTags.count(c.name()) && !p->is_texture_ref(c)) continue;
    std::string name = p->param_name(c);
    if (by_name.count(name)) p->error(c, "parameter '" + name + "' given twice");
    by_name[name] = c;
  }
}

pugi::xml_node MitsubaParser::Props::get(const std::string& name, std::initializer_list<const char*> types) {
  auto it = by_name.find(name);
  if (it == by_name.end()) return {};
  used.insert(name);
  for (const char* t : types)
    if (std::string(it->second.name()) == t) return it->second;
  std::string expect;
  for (const char* t : types) expect += std::string(expect.empty() ? "" : " or ") + "<" + t + ">";
  p->error(it->second, "parameter '" + name + "' has the wrong type <" + it->second.name() + ">, expected " +
                           expect);
}

double MitsubaParser::Props::get_float(const std::string& name, double def) {
  pugi::xml_node n = get(name, {"float", "integer"});
  return n ? p->number(n, p->attr(n, "value")) : def;
}

long MitsubaParser::Props::get_int(const std::string& name, long def, long lo, long hi) {
  pugi::xml_node n = get(name, {"integer"});
  if (!n) return def;
  double v = p->number(n, p->attr(n, "value"));
  if (v != std::floor(v) || v < double(lo) || v > double(hi))
    p->error(n, "'" + name + "' must be an integer from " + std::to_string(lo) + " to " + std::to_string(hi));
  return long(v);
}

bool MitsubaParser::Props::get_bool(const std::string& name, bool def) {
  pugi::xml_node n = get(name, {"boolean"});
  if (!n) return def;
  std::string v = p->attr(n, "value");
  if (v == "true") return true;
  if (v == "false") return false;
  p->error(n, "'" + v + "' is not a boolean (true or false)");
}

std::string MitsubaParser::Props::get_string(const std::string& name, const std::string& def) {
  pugi::xml_node n = get(name, {"string"});
  return n ? p->attr(n, "value") : def;
}

Color MitsubaParser::Props::get_color(const std::string& name, Color def) {
  pugi::xml_node n = get(name, {"rgb", "srgb", "spectrum", "float"});
  if (!n) return def;
  std::string v = p->attr(n, "value");
  if (std::string(n.name()) == "srgb") return p->srgb_color(n, v);
  if (std::string(n.name()) == "spectrum" && v.find(':') != std::string::npos)
    p->error(n, "sampled spectra (wavelength:value) are not supported; give <rgb> or one value");
  std::vector<double> c = p->numbers(n, v);
  if (c.size() == 1) return {float(c[0]), float(c[0]), float(c[0])};
  if (c.size() == 3 && std::string(n.name()) != "float") return {float(c[0]), float(c[1]), float(c[2])};
  p->error(n, "'" + name + "' needs 1 or 3 numbers");
}

Vec3 MitsubaParser::Props::get_point(const std::string& name, Vec3 def) {
  pugi::xml_node n = get(name, {"point", "vector"});
  if (!n) return def;
  if (n.attribute("value")) return p->vec3_attr(n, "value");
  return {float(p->number(n, p->attr(n, "x"))), float(p->number(n, p->attr(n, "y"))),
          float(p->number(n, p->attr(n, "z")))};
}

Matrix4 MitsubaParser::Props::get_transform(const std::string& name) {
  pugi::xml_node n = get(name, {"transform"});
  return n ? p->parse_transform(n) : Matrix4{};
}

void MitsubaParser::Props::check_all_used() const {
  for (const auto& [name, node] : by_name)
    if (!used.count(name))
      p->error(node, "unknown parameter '" + p->attr(node, "name") + "' for <" + owner.name() + " type=\"" +
                         p->attr(owner, "type", false) + "\">");
}

void MitsubaParser::check_children(pugi::xml_node n, std::initializer_list<const char*> allowed) const {
  for (pugi::xml_node c : n.children()) {
    if (c.type() != pugi::node_element || kPropertyTags.count(c.name()) || is_texture_ref(c)) continue;
    bool ok = false;
    for (const char* a : allowed) ok = ok || std::string(c.name()) == a;
    if (!ok) error(c, "<" + std::string(c.name()) + "> is not allowed inside <" + n.name() + ">");
  }
}

Matrix4 MitsubaParser::parse_transform(pugi::xml_node t) const {
  Matrix4 m;
  for (pugi::xml_node op : t.children()) {
    if (op.type() != pugi::node_element) continue;
    std::string k = op.name();
    if (legacy_names_ && k == "lookAt") k = "lookat";  // Mitsuba 0.5's spelling
    Matrix4 step;
    if (k == "matrix") {
      std::vector<double> v = numbers(op, attr(op, "value"));
      if (v.size() != 16 && v.size() != 9) error(op, "<matrix> needs 16 (or 9) numbers");
      int dim = v.size() == 16 ? 4 : 3;
      for (int i = 0; i < dim; ++i)
        for (int j = 0; j < dim; ++j) step.m[i][j] = v[size_t(i * dim + j)];
      if (dim == 4 && (step.m[3][0] != 0 || step.m[3][1] != 0 || step.m[3][2] != 0 || step.m[3][3] != 1))
        error(op, "projective <matrix> (last row not 0 0 0 1) is not supported");
    } else if (k == "translate" || k == "scale") {
      Vec3 v = k == "scale" ? Vec3{1, 1, 1} : Vec3{};
      if (op.attribute("value")) {
        std::vector<double> c = numbers(op, attr(op, "value"));
        if (c.size() == 1 && k == "scale") v = {float(c[0]), float(c[0]), float(c[0])};
        else if (c.size() == 3) v = {float(c[0]), float(c[1]), float(c[2])};
        else error(op, "<" + k + "> value needs 3 numbers");
      }
      for (int i = 0; i < 3; ++i) {
        const char* axis[] = {"x", "y", "z"};
        if (op.attribute(axis[i])) v[i] = float(number(op, attr(op, axis[i])));
      }
      step = k == "scale" ? Matrix4::scale(v) : Matrix4::translate(v);
    } else if (k == "rotate") {
      Vec3 axis{};
      if (op.attribute("value")) axis = vec3_attr(op, "value");
      const char* names[] = {"x", "y", "z"};
      for (int i = 0; i < 3; ++i)
        if (op.attribute(names[i])) axis[i] = float(number(op, attr(op, names[i])));
      if (length(axis) == 0.f) error(op, "<rotate> needs a non-zero axis");
      step = Matrix4::rotate(axis, number(op, attr(op, "angle")));
    } else if (k == "lookat") {
      Vec3 o = vec3_attr(op, "origin"), tg = vec3_attr(op, "target");
      Vec3 up = op.attribute("up") ? vec3_attr(op, "up") : Vec3{0, 1, 0};
      Vec3 dir = tg - o;
      if (length(dir) == 0.f) error(op, "<lookat> origin and target coincide");
      // A zero (or, in 32-bit floats, vanishing) up, or a direction that
      // overflows, would make the camera's axes NaN.
      if (!(length(up) > 0.f) || !is_finite(up)) error(op, "<lookat> up must be a non-zero vector");
      if (!is_finite(dir) || !std::isfinite(length(dir))) error(op, "<lookat> origin and target are too far apart");
      if (length(cross(normalize(up), normalize(dir))) < 1e-6f) error(op, "<lookat> up is parallel to the view direction");
      step = Matrix4::look_at(o, tg, up);
    } else {
      error(op, "unsupported transform operation <" + k + ">");
    }
    m = step * m;
  }
  if (std::fabs(m.det3()) < 1e-30) error(t, "transform is singular");
  return m;
}

}  // namespace mitsuba

Scene load_mitsuba(const std::string& path, const Defines& defines, const std::vector<std::string>& search_paths) {
  return mitsuba::MitsubaParser(path, defines, search_paths).parse();
}

}  // namespace luz
