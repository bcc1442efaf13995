// Mitsuba 3 XML scenes. Supported: <default>/$name, ref/id, integrator
// path|bsdf|light, sensor perspective, samplers, hdrfilm (and ldrfilm) with
// box/tent/gaussian rfilter, shapes obj/rectangle/cube/sphere, emitters
// area, constant, envmap, point, spot and directional, bsdfs diffuse,
// phong, blinnphong (Luz's own), conductor,
// roughconductor, dielectric, roughdielectric, thindielectric, plastic,
// roughplastic, ward (ward, ward-duer, balanced), blendbsdf, twosided (one or
// two nested bsdfs), mask (opacity: alpha-tested geometry), textures (bitmap: 8-bit and float images;
// checkerboard) on every colour and float parameter of every bsdf and on the
// blend weight (nested, or top-level with an id and <ref name=...>), and
// normalmap and bumpmap around a whole material (see parse_bsdf_element).
// Anything else is an error naming file and line: a renderer that
// silently ignores what it does not know renders the wrong image.
//
// Scenes of Mitsuba 0.5/0.6 (version < 2.0) name parameters in camelCase:
// they are renamed as Mitsuba 3's own upgrade does (camel_case_name below).
#include <pugixml.hpp>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <cstring>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include "luz/io/error.h"
#include "luz/io/mesh_obj.h"
#include "luz/io/load.h"
#include "luz/io/image.h"
#include "luz/math/transform.h"
#include "luz/scene/scene_builder.h"

namespace luz {

namespace {

namespace fs = std::filesystem;

// Embree's limit on a ray's origin and direction components (FLT_LARGE, 1.844e18).
float max_abs(Vec3 v) { return std::max({std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)}); }
// The rows of the inverse of m's linear part, (b × c, c × a, a × b) / det for
// its columns a, b, c (world -> local directions); false if it is degenerate.
bool inverse_rows(const Matrix4& m, Vec3& x, Vec3& y, Vec3& z) {
  const Vec3 a = m.vector({1, 0, 0}), b = m.vector({0, 1, 0}), c = m.vector({0, 0, 1});
  const float det = dot(a, cross(b, c));
  if (!(std::fabs(det) > 0.f) || !std::isfinite(det)) return false;
  x = cross(b, c) / det;
  y = cross(c, a) / det;
  z = cross(a, b) / det;
  return is_finite(x) && is_finite(y) && is_finite(z);
}

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

class MitsubaParser {
 public:
  MitsubaParser(const std::string& path, const Defines& defines) : path_(path), defines_(defines) {}

  Scene parse() {
    text_ = read_text_file(path_);
    pugi::xml_parse_result res = doc_.load_buffer(text_.data(), text_.size(), pugi::parse_default);
    if (!res) throw InputError(path_, line_at(size_t(res.offset)), std::string("malformed XML: ") + res.description());
    pugi::xml_node root = doc_.child("scene");
    if (!root) error(doc_.document_element(), "root element must be <scene>");
    if (pugi::xml_attribute v = root.attribute("version")) {
      int major = 0;
      const char* b = v.value();
      auto r = std::from_chars(b, b + std::strlen(b), major);
      if (r.ec != std::errc() || (*r.ptr != '.' && *r.ptr != '\0'))
        error(root, "version '" + std::string(b) + "' is not a version number (as 3.0.0)");
      legacy_names_ = major < 2;
    }
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

    bool have_sensor = false, have_integrator = false;
    for (pugi::xml_node n : root.children()) {
      if (n.type() != pugi::node_element) continue;
      std::string tag = n.name();
      if (tag == "default") continue;
      if (tag == "integrator") {
        if (have_integrator) error(n, "only one <integrator> is supported");
        parse_integrator(n);
        have_integrator = true;
      } else if (tag == "sensor") {
        if (have_sensor) error(n, "only one <sensor> is supported");
        parse_sensor(n);
        have_sensor = true;
      } else if (tag == "bsdf") {
        parse_bsdf(n);
      } else if (tag == "texture") {
        const std::string id = n.attribute("id").value();
        if (id.empty()) error(n, "a top-level <texture> needs an id");
        if (textures_.count(id) || bsdfs_.count(id)) error(n, "duplicate id '" + id + "'");
        textures_[id] = uint32_t(parse_texture(n, true));
      } else if (tag == "shape") parse_shape(n);
      else if (tag == "emitter") parse_emitter(n);
      else error(n, "unsupported element <" + tag + ">");
    }
    if (!have_sensor) throw InputError(path_, 0, "the scene has no <sensor>");
    return builder_.finish();
  }

 private:
  // ---- errors and positions ----
  int line_at(size_t offset) const {
    offset = std::min(offset, text_.size());
    return 1 + int(std::count(text_.begin(), text_.begin() + std::ptrdiff_t(offset), '\n'));
  }
  int line(pugi::xml_node n) const { return line_at(size_t(n.offset_debug())); }
  [[noreturn]] void error(pugi::xml_node n, const std::string& msg) const { throw InputError(path_, line(n), msg); }
  SourceLoc loc(pugi::xml_node n) const { return {path_, line(n)}; }

  // Mitsuba 3's upgrade of a 0.5/0.6 name: an underscore between a lower-case
  // letter or digit and the capital after it, then all lower case (toWorld ->
  // to_world, sampleCount -> sample_count, intIOR -> int_ior).
  static std::string camel_case_name(const std::string& name) {
    std::string out;
    for (size_t i = 0; i < name.size(); ++i) {
      unsigned char c = (unsigned char)name[i], prev = i > 0 ? (unsigned char)name[i - 1] : 0;
      if (std::isupper(c) && (std::islower(prev) || std::isdigit(prev))) out += '_';
      out += char(std::tolower(c));
    }
    return out;
  }
  // A parameter's name as Luz knows it (Mitsuba 3's).
  std::string param_name(pugi::xml_node n) const {
    std::string name = attr(n, "name");
    return legacy_names_ ? camel_case_name(name) : name;
  }

  // Attribute with $parameter substitution.
  std::string attr(pugi::xml_node n, const char* name, bool required = true) const {
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

  // ---- numbers ----
  double number(pugi::xml_node n, const std::string& s) const {
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
  std::vector<double> numbers(pugi::xml_node n, const std::string& s) const {
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
  Vec3 vec3_attr(pugi::xml_node n, const char* name) const {
    std::vector<double> v = numbers(n, attr(n, name));
    if (v.size() != 3) error(n, std::string("'") + name + "' needs 3 numbers");
    return {float(v[0]), float(v[1]), float(v[2])};
  }

  // Mitsuba 0.5's <srgb>: "#rrggbb" or 1 or 3 numbers in [0, 1], sRGB-encoded,
  // decoded to linear RGB (Mitsuba 3 has no such tag).
  Color srgb_color(pugi::xml_node n, const std::string& v) const {
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

  // ---- properties of one plugin element ----
  // Elements that are named parameters of their parent (a nested <texture>
  // is one too: Props hands it out by name like a value).
  static inline const std::set<std::string> kPropertyTags = {
      "integer", "float", "boolean", "string", "rgb", "srgb", "spectrum", "point", "vector", "transform", "texture"};
  struct Props {
    const MitsubaParser* p;
    pugi::xml_node owner;
    std::map<std::string, pugi::xml_node> by_name;
    std::set<std::string> used;

    Props(const MitsubaParser* parser, pugi::xml_node node) : p(parser), owner(node) {
      for (pugi::xml_node c : node.children()) {
        if (c.type() != pugi::node_element) continue;
        if (!kPropertyTags.count(c.name()) && !p->is_texture_ref(c)) continue;
        std::string name = p->param_name(c);
        if (by_name.count(name)) p->error(c, "parameter '" + name + "' given twice");
        by_name[name] = c;
      }
    }
    pugi::xml_node get(const std::string& name, std::initializer_list<const char*> types) {
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
    double get_float(const std::string& name, double def) {
      pugi::xml_node n = get(name, {"float", "integer"});
      return n ? p->number(n, p->attr(n, "value")) : def;
    }
    long get_int(const std::string& name, long def) {
      pugi::xml_node n = get(name, {"integer"});
      if (!n) return def;
      double v = p->number(n, p->attr(n, "value"));
      if (v != std::floor(v) || std::fabs(v) > 2e9) p->error(n, "'" + name + "' must be an integer");
      return long(v);
    }
    bool get_bool(const std::string& name, bool def) {
      pugi::xml_node n = get(name, {"boolean"});
      if (!n) return def;
      std::string v = p->attr(n, "value");
      if (v == "true") return true;
      if (v == "false") return false;
      p->error(n, "'" + v + "' is not a boolean (true or false)");
    }
    std::string get_string(const std::string& name, const std::string& def) {
      pugi::xml_node n = get(name, {"string"});
      return n ? p->attr(n, "value") : def;
    }
    Color get_color(const std::string& name, Color def) {
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
    Vec3 get_point(const std::string& name, Vec3 def) {
      pugi::xml_node n = get(name, {"point", "vector"});
      if (!n) return def;
      if (n.attribute("value")) return p->vec3_attr(n, "value");
      return {float(p->number(n, p->attr(n, "x"))), float(p->number(n, p->attr(n, "y"))),
              float(p->number(n, p->attr(n, "z")))};
    }
    Matrix4 get_transform(const std::string& name) {
      pugi::xml_node n = get(name, {"transform"});
      return n ? p->parse_transform(n) : Matrix4{};
    }
    bool has(const std::string& name) const { return by_name.count(name) > 0; }
    // Any parameter nobody asked for is an error.
    void check_all_used() const {
      for (const auto& [name, node] : by_name)
        if (!used.count(name))
          p->error(node, "unknown parameter '" + p->attr(node, "name") + "' for <" + owner.name() + " type=\"" +
                             p->attr(owner, "type", false) + "\">");
    }
  };

  // Nested plugin children (everything that is not a property).
  void check_children(pugi::xml_node n, std::initializer_list<const char*> allowed) const {
    for (pugi::xml_node c : n.children()) {
      if (c.type() != pugi::node_element || kPropertyTags.count(c.name()) || is_texture_ref(c)) continue;
      bool ok = false;
      for (const char* a : allowed) ok = ok || std::string(c.name()) == a;
      if (!ok) error(c, "<" + std::string(c.name()) + "> is not allowed inside <" + n.name() + ">");
    }
  }

  Matrix4 parse_transform(pugi::xml_node t) const {
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

  // ---- plugins ----
  void parse_integrator(pugi::xml_node n) {
    std::string type = attr(n, "type");
    IntegratorParams& ip = builder_.settings().integrator;
    if (type == "path") ip.type = IntegratorType::Path;
    else if (type == "bsdf") ip.type = IntegratorType::Bsdf;
    else if (type == "light") ip.type = IntegratorType::Light;
    else error(n, "unknown integrator '" + type + "' (supported: path, bsdf, light)");
    check_children(n, {});
    Props p(this, n);
    ip.max_depth = int(p.get_int("max_depth", -1));
    ip.rr_depth = int(p.get_int("rr_depth", 5));
    if (ip.max_depth < -1 || ip.max_depth == 0) error(n, "max_depth must be -1 (unbounded) or ≥ 1");
    if (ip.rr_depth < 1) error(n, "rr_depth must be ≥ 1");
    if (p.get_bool("hide_emitters", false)) error(n, "hide_emitters is not supported");
    // Mitsuba 0.5's strictNormals drops light whose geometric and shading
    // sides disagree; Luz's path tracer always does (path.h: the geometric
    // side test beside the shading frame's), so either value means that.
    p.get_bool("strict_normals", false);
    p.check_all_used();
  }

  void parse_sensor(pugi::xml_node n) {
    std::string type = attr(n, "type");
    Camera cam;
    if (type == "perspective") cam.type = CameraType::Perspective;
    else if (type == "thinlens") cam.type = CameraType::ThinLens;
    else if (type == "orthographic") cam.type = CameraType::Orthographic;
    else error(n, "unknown sensor '" + type + "' (supported: perspective, thinlens, orthographic)");
    const bool projective = cam.type != CameraType::Orthographic;
    check_children(n, {"sampler", "film"});
    Props p(this, n);
    double fov = 30.0, ppx = 0.0, ppy = 0.0;
    std::string axis = "x";
    if (projective) {
      fov = p.get_float("fov", 30.0);
      axis = p.get_string("fov_axis", "x");
      ppx = p.get_float("principal_point_offset_x", 0.0);
      ppy = p.get_float("principal_point_offset_y", 0.0);
      // Far beyond any real lens shift; keeps the rays' directions finite.
      if (std::fabs(ppx) > 1e6 || std::fabs(ppy) > 1e6) error(n, "principal_point_offset_x/y must lie in [-1e6, 1e6]");
    }
    Matrix4 to_world = p.get_transform("to_world");
    double near_clip = p.get_float("near_clip", 1e-2), far_clip = p.get_float("far_clip", 1e4);
    if (!(near_clip > 0 && far_clip > near_clip)) error(n, "need 0 < near_clip < far_clip");
    if (!(fov > 0 && fov < 180)) error(n, "fov must be in (0, 180) degrees");
    // Mitsuba's projective cameras all take focus_distance (default far_clip);
    // only the thin lens uses it.
    double focus = p.get_float("focus_distance", far_clip);
    if (!(focus > 0)) error(n, "focus_distance must be > 0");
    if (cam.type == CameraType::ThinLens) {
      // Required, as in Mitsuba.
      if (!p.has("aperture_radius")) error(n, "a thinlens sensor needs an aperture_radius");
      double radius = p.get_float("aperture_radius", 0.0);
      if (!(radius >= 0)) error(n, "aperture_radius must be ≥ 0");
      cam.lens.aperture_radius = float(radius);
      cam.lens.focus_distance = float(focus);
    }
    p.check_all_used();

    int width = 768, height = 576;
    // Mitsuba's defaults when the sensor names no sampler or film: an
    // independent sampler with 4 samples, a 768×576 hdrfilm, a gaussian rfilter.
    builder_.settings().sampler = SamplerType::Independent;
    builder_.settings().spp = 4;
    builder_.settings().filter = FilterKind::Gaussian;
    if (std::distance(n.children("sampler").begin(), n.children("sampler").end()) > 1)
      error(n, "a sensor takes one <sampler>");
    if (std::distance(n.children("film").begin(), n.children("film").end()) > 1) error(n, "a sensor takes one <film>");
    for (pugi::xml_node c : n.children("sampler")) parse_sampler(c);
    for (pugi::xml_node c : n.children("film")) parse_film(c, width, height);
    cam.width = width;
    cam.height = height;
    double aspect = double(width) / height, t = std::tan(fov * M_PI / 360.0), tx, ty;
    if (!projective) tx = 1, ty = 1 / aspect;  // Mitsuba's orthographic film: [-1, 1] × [-1/aspect, 1/aspect]
    else if (axis == "x") tx = t, ty = t / aspect;
    else if (axis == "y") ty = t, tx = t * aspect;
    else if (axis == "diagonal") {
      double d = t / std::sqrt(1 + 1 / (aspect * aspect));
      tx = d, ty = d / aspect;
    } else if (axis == "smaller") (aspect > 1 ? (ty = t, tx = t * aspect) : (tx = t, ty = t / aspect));
    else if (axis == "larger") (aspect > 1 ? (tx = t, ty = t / aspect) : (ty = t, tx = t * aspect));
    else error(n, "fov_axis must be x, y, diagonal, smaller or larger");
    cam.tan_half_x = float(tx);
    cam.tan_half_y = float(ty);
    cam.edge_x = float(1 - 2 * ppx);
    cam.edge_y = float(1 - 2 * ppy);
    cam.z_axis = normalize(to_world.vector({0, 0, 1}));
    if (projective) {
      cam.x_axis = normalize(to_world.vector({1, 0, 0}));
      cam.y_axis = normalize(to_world.vector({0, 1, 0}));
      cam.origin = to_world.point({0, 0, 0});
    } else {
      // to_world's x and y scale the view: kept (orthographic.h).
      cam.x_axis = to_world.vector({1, 0, 0});
      cam.y_axis = to_world.vector({0, 1, 0});
      cam.origin = to_world.point({0, 0, float(near_clip)});
    }
    builder_.set_camera(loc(n), cam);  // the checks every format shares
  }

  void parse_sampler(pugi::xml_node n) {
    std::string type = attr(n, "type");
    RenderSettings& s = builder_.settings();
    if (type == "independent") s.sampler = SamplerType::Independent;
    else if (type == "stratified") s.sampler = SamplerType::Stratified;
    else if (type == "sobol" || type == "ldsampler") s.sampler = SamplerType::Sobol;
    else error(n, "unknown sampler '" + type + "' (supported: independent, stratified, sobol)");
    check_children(n, {});
    Props p(this, n);
    long spp = p.get_int("sample_count", 4);
    // The command line's --spp bound (2^24), so that a scene cannot ask for
    // what the flag may not.
    if (spp < 1 || spp > (1 << 24)) error(n, "sample_count must be between 1 and 16777216 (2^24)");
    s.spp = uint32_t(spp);
    long seed = p.get_int("seed", 0);
    s.seed = uint64_t(seed);
    p.get_bool("jitter", true);
    p.check_all_used();
  }

  void parse_film(pugi::xml_node n, int& width, int& height) {
    std::string type = attr(n, "type");
    // ldrfilm differs from hdrfilm only in how the file is written (tone
    // mapping, gamma, 8 bits), and Luz picks the output format from -o's
    // extension: its formatting parameters are accepted and have no effect.
    if (type != "hdrfilm" && type != "ldrfilm") error(n, "unknown film '" + type + "' (supported: hdrfilm, ldrfilm)");
    check_children(n, {"rfilter"});
    Props p(this, n);
    long w = p.get_int("width", 768), h = p.get_int("height", 576);
    if (w < 1 || h < 1 || w > 65536 || h > 65536) error(n, "film size must be between 1 and 65536");
    width = int(w);
    height = int(h);
    p.get_string("file_format", "openexr");
    std::string pf = p.get_string("pixel_format", "rgb");
    if (pf != "rgb" && pf != "rgba") error(n, "pixel_format '" + pf + "' is not supported (rgb)");
    if (type == "hdrfilm") p.get_string("component_format", "float16");
    if (type == "ldrfilm") p.get_float("gamma", -1.0);  // the PNG encoding's gamma (-1: sRGB)
    p.get_bool("banner", false);
    p.get_bool("high_quality_edges", false);
    p.check_all_used();
    if (std::distance(n.children("rfilter").begin(), n.children("rfilter").end()) > 1)
      error(n, "a film takes one <rfilter>");
    for (pugi::xml_node r : n.children("rfilter")) {
      std::string ft = attr(r, "type");
      check_children(r, {});
      Props rp(this, r);
      if (ft == "box") builder_.settings().filter = FilterKind::Box;
      else if (ft == "tent") builder_.settings().filter = FilterKind::Tent;
      else if (ft == "gaussian") {
        builder_.settings().filter = FilterKind::Gaussian;
        double sd = rp.get_float("stddev", 0.5);
        if (sd != 0.5) error(r, "only the default gaussian stddev 0.5 is supported");
      } else {
        error(r, "unknown rfilter '" + ft + "' (supported: box, tent, gaussian)");
      }
      rp.check_all_used();
    }
  }

  Color checked_reflectance(pugi::xml_node n, Props& p, const char* name, Color def) {
    Color c = p.get_color(name, def);
    for (int k = 0; k < 3; ++k)
      if (c[k] < 0.f || c[k] > 1.f) error(n, std::string("'") + name + "' must lie in [0, 1]");
    return c;
  }

  // ---- bsdf parameters shared by several plugins ----
  MicrofacetType distribution(pugi::xml_node n, Props& p) {
    std::string d = p.get_string("distribution", "beckmann");
    if (d == "beckmann") return MicrofacetType::Beckmann;
    if (d == "ggx") return MicrofacetType::GGX;
    error(n, "unknown distribution '" + d + "' (supported: beckmann, ggx)");
  }
  // Mitsuba 3: `alpha` (isotropic), or `alpha_u` and `alpha_v`; default 0.1.
  // Textures may drive them (bound to AlphaU / AlphaV in *tb; their zero
  // texels act as the microfacet models' least roughness, 1e-4) unless tb is
  // null: then a texture is an error.
  void roughness(pugi::xml_node n, Props& p, float& au, float& av, std::vector<TextureBinding>* tb) {
    p.get_bool("sample_visible", true);  // a sampling strategy only: the image's expectation is the same
    bool iso = p.has("alpha"), aniso = p.has("alpha_u") || p.has("alpha_v");
    if (iso && aniso) error(n, "give either 'alpha' or 'alpha_u' and 'alpha_v', not both");
    if (aniso && !(p.has("alpha_u") && p.has("alpha_v"))) error(n, "'alpha_u' and 'alpha_v' must be given together");
    for (const char* name : {"alpha", "alpha_u", "alpha_v"}) {
      auto it = p.by_name.find(name);
      if (!tb && it != p.by_name.end() && (std::string(it->second.name()) == "texture" || std::string(it->second.name()) == "ref"))
        error(it->second, std::string("'") + name + "' cannot take a texture here (a constant roughness, as in Mitsuba 3)");
    }
    std::vector<TextureBinding> none;
    std::vector<TextureBinding>& b = tb ? *tb : none;
    const size_t before = b.size();
    float a = float_param(p, "alpha", 0.1f, {BsdfParam::AlphaU, BsdfParam::AlphaV}, b);
    au = iso ? a : float_param(p, "alpha_u", 0.1f, {BsdfParam::AlphaU}, b);
    av = iso ? a : float_param(p, "alpha_v", 0.1f, {BsdfParam::AlphaV}, b);
    if (b.size() == before && (!(au > 0.f) || !(av > 0.f)))
      error(n, "roughness (alpha, alpha_u, alpha_v) must be positive");
  }
  // An index of refraction: a number or one of Mitsuba's named presets.
  float ior(pugi::xml_node n, Props& p, const char* name, const char* def) {
    pugi::xml_node c = p.get(name, {"float", "integer", "string"});
    float v = 0.f;
    if (!c) {
      find_ior_preset(def, v);
      return v;
    }
    std::string text = attr(c, "value");
    if (std::string(c.name()) == "string") {
      if (!find_ior_preset(text.c_str(), v)) error(c, "unknown index of refraction preset '" + text + "'");
    } else {
      v = float(number(c, text));
    }
    // Real dielectrics lie within about [1, 4]; far outside, the models'
    // Fresnel terms overflow (plastic's internal reflectance reaches 1 at a
    // ratio near 1000: every sample NaN).
    if (!(v >= 0.1f && v <= 10.f)) error(n, std::string("'") + name + "' must lie in [0.1, 10] (an index of refraction)");
    return v;
  }
  // Conductor: `material` preset, or `eta` and `k` (Mitsuba 3: default
  // material "none", the perfect mirror; eta defaults to 0 and k to 1 when
  // only one is given).
  void conductor_ior(pugi::xml_node n, Props& p, Color& eta, Color& k, std::vector<TextureBinding>& tb) {
    bool explicit_ior = p.has("eta") || p.has("k");
    if (explicit_ior && p.has("material")) error(n, "give either 'material' or 'eta' and 'k', not both");
    if (explicit_ior) {
      eta = color_param(n, p, "eta", {0.f, 0.f, 0.f}, BsdfParam::Eta, false, tb);
      k = color_param(n, p, "k", {1.f, 1.f, 1.f}, BsdfParam::K, false, tb);
      for (int c = 0; c < 3; ++c)
        if (eta[c] < 0.f || k[c] < 0.f) error(n, "conductor 'eta' and 'k' must not be negative");
      return;
    }
    std::string m = p.get_string("material", "none");
    if (!find_conductor_preset(m.c_str(), eta, k)) {
      std::string names;
      for (const ConductorPreset& c : kConductorPresets) names += std::string(names.empty() ? "" : ", ") + c.name;
      error(n, "unknown conductor material '" + m + "' (supported: " + names + ")");
    }
  }
  // A bsdf as parsed (MaterialDesc): the BSDF with its constant parameters
  // and the textures that drive the others (a textured parameter holds the
  // texture's mean).
  using ParsedBsdf = MaterialDesc;
  uint32_t add_material(pugi::xml_node n, const ParsedBsdf& b) { return builder_.add_material(loc(n), b); }

  // One bsdf element (or a <ref> to one) nested in another.
  ParsedBsdf nested_bsdf(pugi::xml_node c) {
    if (std::string(c.name()) != "ref") return parse_bsdf_value(c);
    return builder_.material(resolve_ref(c));
  }
  // The bsdfs nested in n (<ref>s to textures are parameters, not bsdfs).
  std::vector<pugi::xml_node> nested_bsdf_nodes(pugi::xml_node n) {
    std::vector<pugi::xml_node> inner;
    for (pugi::xml_node c : n.children())
      if (c.type() == pugi::node_element &&
          (std::string(c.name()) == "bsdf" || (std::string(c.name()) == "ref" && !is_texture_ref(c))))
        inner.push_back(c);
    return inner;
  }
  // Moves bindings of one part to another (a nested bsdf becoming a blend's
  // second or a two-sided back).
  static void move_part(std::vector<TextureBinding>& b, BsdfPart from, BsdfPart to) {
    for (TextureBinding& t : b)
      if (t.part == from) t.part = to;
  }

  ParsedBsdf parse_bsdf_element(pugi::xml_node n) {
    // Nested bsdfs (bumpmap, twosided, blendbsdf) recurse: bound the depth so
    // that a deep nesting is an error rather than a stack overflow.
    struct Depth {
      int& d;
      explicit Depth(int& depth) : d(++depth) {}
      ~Depth() { --d; }
    } depth(bsdf_depth_);
    if (bsdf_depth_ > kMaxBsdfNesting) error(n, "bsdfs nested more than " + std::to_string(kMaxBsdfNesting) + " deep");
    std::string type = attr(n, "type");
    if (type == "normalmap" || type == "bumpmap") {
      // Mitsuba 3's adapters: a texture perturbs the shading frame, one nested
      // bsdf is evaluated in the perturbed frame (SceneView::perturbed_frame).
      // normalmap: the texture `normalmap`, raw (its texels are vectors);
      // bumpmap: one texture of any name (the height: its luminance) and
      // `scale`. Luz holds one map per material, around the whole of it: the
      // map may wrap any bsdf, twosided and blendbsdf included, but a map
      // inside a twosided, a blendbsdf or another map is refused below.
      const bool bump = type == "bumpmap";
      check_children(n, {"bsdf", "ref"});
      Props p(this, n);
      std::string map = "normalmap";
      if (bump) {
        std::vector<std::string> names;
        for (const auto& [name, c] : p.by_name)
          if (std::string(c.name()) == "texture" || std::string(c.name()) == "ref") names.push_back(name);
        if (names.size() != 1) error(n, "bumpmap needs exactly one nested texture (the height map)");
        map = names[0];
      }
      const int32_t t = texture_param(p, map.c_str());
      if (t < 0) error(n, type + " needs a <texture name=\"" + map + "\">");
      const float scale = bump ? float(p.get_float("scale", 1.0)) : 1.f;
      p.check_all_used();
      if (!std::isfinite(scale)) error(n, "bumpmap 'scale' must be finite");
      const Texture& tex = builder_.scene().textures[size_t(t)];
      if (!bump && tex.type == TextureType::Bitmap && !tex.bitmap.is_float && tex.bitmap.srgb)
        error(n, "the normalmap bitmap must be raw (<boolean name=\"raw\" value=\"true\"/>): its texels are "
                 "vectors, not sRGB colours");
      if (bump && tex.type != TextureType::Bitmap)
        error(n, "bumpmap needs a bitmap height map (a checkerboard has no gradient)");
      std::vector<pugi::xml_node> inner = nested_bsdf_nodes(n);
      if (inner.size() != 1) error(n, type + " needs exactly one nested bsdf");
      ParsedBsdf b = nested_bsdf(inner[0]);
      if (b.has_map()) error(inner[0], "a normalmap or bumpmap inside another is not supported");
      (bump ? b.bump_map : b.normal_map) = t;
      b.bump_scale = scale;
      return b;
    }
    if (type == "mask") {
      // Mitsuba 3's mask: `opacity` (a number or a texture's luminance, in
      // [0, 1]) over one nested bsdf, traced as alpha-tested geometry
      // (material/opacity.h). A mask wraps any bsdf (twosided, blendbsdf);
      // inside a blendbsdf, a two-sided twosided or another mask it is
      // refused (an opacity per part is not an alpha test).
      check_children(n, {"bsdf", "ref"});
      Props p(this, n);
      int32_t t = -1;
      const float a = unit_param(n, p, "mask", "opacity", 0.5f, t);
      p.check_all_used();
      std::vector<pugi::xml_node> inner = nested_bsdf_nodes(n);
      if (inner.size() != 1) error(n, "mask needs exactly one nested bsdf");
      ParsedBsdf out = nested_bsdf(inner[0]);
      if (out.masked()) error(inner[0], "a mask inside a mask is not supported");
      out.opacity = a;
      out.opacity_texture = t;
      return out;
    }
    if (type == "twosided") {
      // Mitsuba 3: one nested bsdf for both sides, or two: the first for the
      // front, the second for the back.
      check_children(n, {"bsdf", "ref"});
      Props p(this, n);
      p.check_all_used();
      std::vector<pugi::xml_node> inner = nested_bsdf_nodes(n);
      if (inner.size() != 1 && inner.size() != 2) error(n, "twosided needs one or two nested bsdfs");
      ParsedBsdf sides[2];
      for (size_t i = 0; i < inner.size(); ++i) {
        if (std::string(inner[i].name()) == "bsdf" && attr(inner[i], "type") == "twosided")
          error(inner[i], "twosided cannot wrap another twosided");
        sides[i] = nested_bsdf(inner[i]);
        if (sides[i].bsdf.has_back) error(inner[i], "twosided cannot wrap another twosided");
        // One map per material, on both sides: Mitsuba's twosided would
        // mirror a map inside it on the back, Luz's map outside does not.
        if (sides[i].has_map())
          error(inner[i], "a normalmap or bumpmap inside a twosided is not supported (put the twosided inside the map)");
        // Mitsuba 3's twosided refuses transmissive materials ("Only materials
        // without a transmission component can be nested!"): dielectrics are
        // two-sided by nature.
        if (sides[i].bsdf.has_transmission())
          error(inner[i], "twosided cannot wrap a material that transmits light (a dielectric)");
        if (inner.size() == 2 && sides[i].masked())
          error(inner[i], "a mask as one side of a twosided is not supported (wrap the twosided in the mask)");
      }
      if (inner.size() == 1) {
        sides[0].bsdf.two_sided = true;
        return sides[0];
      }
      if (sides[1].bsdf.blend)
        error(inner[1], "a blendbsdf as the back side of a twosided is not supported (only as the front)");
      ParsedBsdf out{Bsdf::make_two_sided(sides[0].bsdf, sides[1].bsdf), sides[0].bindings};
      move_part(sides[1].bindings, BsdfPart::Front, BsdfPart::Back);
      out.bindings.insert(out.bindings.end(), sides[1].bindings.begin(), sides[1].bindings.end());
      return out;
    }
    if (type == "blendbsdf") {
      check_children(n, {"bsdf", "ref"});
      Props p(this, n);
      int32_t weight_texture = -1;
      const float w = unit_param(n, p, "blendbsdf", "weight", 0.5f, weight_texture);
      p.check_all_used();
      std::vector<pugi::xml_node> inner = nested_bsdf_nodes(n);
      if (inner.size() != 2) error(n, "blendbsdf needs exactly two nested bsdfs");
      ParsedBsdf a = nested_bsdf(inner[0]), b = nested_bsdf(inner[1]);
      if (a.masked() || b.masked()) error(n, "a mask inside a blendbsdf is not supported (wrap the blend in the mask)");
      if (a.bsdf.blend || b.bsdf.blend) error(n, "a blendbsdf inside a blendbsdf is not supported");
      if (a.has_map() || b.has_map())
        error(n, "a normalmap or bumpmap inside a blendbsdf is not supported (put the blendbsdf inside the map)");
      if (a.bsdf.has_back || b.bsdf.has_back)
        error(n, "a twosided with two different bsdfs inside a blendbsdf is not supported");
      if (a.bsdf.two_sided != b.bsdf.two_sided)
        error(n, "the two bsdfs of a blendbsdf must both be twosided or both not (wrap the blend in twosided)");
      ParsedBsdf out{Bsdf::make_blend(a.bsdf, b.bsdf, w), a.bindings};
      move_part(b.bindings, BsdfPart::Front, BsdfPart::Second);
      out.bindings.insert(out.bindings.end(), b.bindings.begin(), b.bindings.end());
      if (weight_texture >= 0) out.bindings.push_back({weight_texture, BsdfPart::BlendWeight});
      return out;
    }
    check_children(n, {});
    Props p(this, n);
    ParsedBsdf out;
    std::vector<TextureBinding>& tb = out.bindings;
    Bsdf& b = out.bsdf;
    auto reflectance = [&](const char* name, Color def, BsdfParam param) {
      return color_param(n, p, name, def, param, true, tb);
    };
    // Phong-like sums: k_d + k_s ≤ 1 wherever the textures reach (their maxima).
    auto check_sum = [&](Color kd, Color ks) {
      const Color dmax = texture_max(tb, BsdfParam::DiffuseReflectance, kd),
                  smax = texture_max(tb, BsdfParam::SpecularReflectance, ks);
      for (int k = 0; k < 3; ++k)
        if (dmax[k] + smax[k] > 1.f)
          error(n, "diffuse_reflectance + specular_reflectance > 1: the material would create energy");
    };
    if (type == "diffuse") {
      b = Bsdf::make_diffuse(reflectance("reflectance", {0.5f, 0.5f, 0.5f}, BsdfParam::Reflectance), false);
    } else if (type == "phong" || type == "blinnphong") {  // the same parameters (Mitsuba 0.6's)
      Color kd = reflectance("diffuse_reflectance", {0.5f, 0.5f, 0.5f}, BsdfParam::DiffuseReflectance);
      Color ks = reflectance("specular_reflectance", {0.2f, 0.2f, 0.2f}, BsdfParam::SpecularReflectance);
      float e = float_param(p, "exponent", 30.f, {BsdfParam::Exponent}, tb);
      if (!(e >= 0.f)) error(n, "exponent must be ≥ 0");
      check_sum(kd, ks);
      b = type == "phong" ? Bsdf::make_phong(kd, ks, e, false) : Bsdf::make_blinn_phong(kd, ks, e, false);
    } else if (type == "conductor" || type == "roughconductor") {
      Color eta, k;
      conductor_ior(n, p, eta, k, tb);
      // Mitsuba 0.5's extEta: the exterior medium's index; eta and k are relative to it.
      float ext_eta = legacy_names_ ? ior(n, p, "ext_eta", "vacuum") : 1.f;  // not a Mitsuba 3 parameter
      if (ext_eta != 1.f && !tb.empty()) error(n, "textured 'eta' or 'k' with 'ext_eta' is not supported");
      eta = eta / ext_eta;
      k = k / ext_eta;
      Color spec = reflectance("specular_reflectance", {1.f, 1.f, 1.f}, BsdfParam::SpecularReflectance);
      if (type == "conductor") {
        b = Bsdf::make_smooth_conductor(eta, k, spec, false);
      } else {
        MicrofacetType d = distribution(n, p);
        float au, av;
        roughness(n, p, au, av, &tb);
        b = Bsdf::make_rough_conductor(d, au, av, eta, k, spec, false);
      }
    } else if (type == "dielectric" || type == "roughdielectric" || type == "thindielectric") {
      float int_ior = ior(n, p, "int_ior", "bk7"), ext_ior = ior(n, p, "ext_ior", "air");
      Color r = reflectance("specular_reflectance", {1.f, 1.f, 1.f}, BsdfParam::SpecularReflectance);
      Color t = reflectance("specular_transmittance", {1.f, 1.f, 1.f}, BsdfParam::SpecularTransmittance);
      if (type == "dielectric") {
        b = Bsdf::make_smooth_dielectric(int_ior, ext_ior, r, t);
      } else if (type == "thindielectric") {
        b = Bsdf::make_thin_dielectric(int_ior, ext_ior, r, t);
      } else {
        MicrofacetType d = distribution(n, p);
        float au, av;
        roughness(n, p, au, av, &tb);
        if (int_ior == ext_ior) error(n, "roughdielectric needs int_ior != ext_ior (nothing would refract)");
        b = Bsdf::make_rough_dielectric(d, au, av, int_ior, ext_ior, r, t);
      }
    } else if (type == "plastic") {
      Color kd = reflectance("diffuse_reflectance", {0.5f, 0.5f, 0.5f}, BsdfParam::DiffuseReflectance);
      Color ks = reflectance("specular_reflectance", {1.f, 1.f, 1.f}, BsdfParam::SpecularReflectance);
      float int_ior = ior(n, p, "int_ior", "polypropylene"), ext_ior = ior(n, p, "ext_ior", "air");
      bool nonlinear = p.get_bool("nonlinear", false);
      b = Bsdf::make_smooth_plastic(kd, ks, int_ior, ext_ior, false, nonlinear);
    } else if (type == "roughplastic") {
      Color kd = reflectance("diffuse_reflectance", {0.5f, 0.5f, 0.5f}, BsdfParam::DiffuseReflectance);
      Color ks = reflectance("specular_reflectance", {1.f, 1.f, 1.f}, BsdfParam::SpecularReflectance);
      float int_ior = ior(n, p, "int_ior", "polypropylene"), ext_ior = ior(n, p, "ext_ior", "air");
      bool nonlinear = p.get_bool("nonlinear", false);
      MicrofacetType d = distribution(n, p);
      float au, av;
      // As Mitsuba 3: a constant roughness (the coat's tables depend on it),
      // isotropic, and two indices that differ.
      roughness(n, p, au, av, nullptr);
      if (au != av) error(n, "roughplastic supports isotropic roughness only (alpha_u = alpha_v)");
      if (int_ior == ext_ior) error(n, "roughplastic needs int_ior != ext_ior");
      b = Bsdf::make_rough_plastic(d, au, kd, ks, int_ior, ext_ior, nonlinear, false);
    } else if (type == "ward") {
      std::string v = p.get_string("variant", "balanced");
      WardVariant variant = WardVariant::Balanced;
      if (v == "ward") variant = WardVariant::Ward;
      else if (v == "ward-duer") variant = WardVariant::WardDuer;
      else if (v != "balanced") error(n, "unknown ward variant '" + v + "' (supported: ward, ward-duer, balanced)");
      float au = float_param(p, "alpha_u", 0.1f, {BsdfParam::AlphaU}, tb);
      float av = float_param(p, "alpha_v", 0.1f, {BsdfParam::AlphaV}, tb);
      if (!(au > 0.f) || !(av > 0.f)) error(n, "roughness (alpha_u, alpha_v) must be positive");
      Color kd = reflectance("diffuse_reflectance", {0.5f, 0.5f, 0.5f}, BsdfParam::DiffuseReflectance);
      Color ks = reflectance("specular_reflectance", {0.2f, 0.2f, 0.2f}, BsdfParam::SpecularReflectance);
      check_sum(kd, ks);
      b = Bsdf::make_ward(variant, kd, ks, au, av, false);
    } else {
      error(n, "unknown bsdf '" + type +
                   "' (supported: diffuse, phong, blinnphong, conductor, roughconductor, dielectric, "
                   "roughdielectric, thindielectric, plastic, roughplastic, ward, blendbsdf, twosided, mask, "
                   "normalmap, bumpmap)");
    }
    p.check_all_used();
    return out;
  }

  // A bsdf element as a value; one with an id becomes a material that <ref>s
  // name, nested ones too (as in Mitsuba, where the staircase's bumpmap
  // wraps the bsdf its shapes refer to).
  ParsedBsdf parse_bsdf_value(pugi::xml_node n) {
    ParsedBsdf b = parse_bsdf_element(n);
    std::string id = n.attribute("id").value();
    if (!id.empty()) {
      if (bsdfs_.count(id)) error(n, "duplicate id '" + id + "'");
      bsdfs_[id] = add_material(n, b);
    }
    return b;
  }
  uint32_t parse_bsdf(pugi::xml_node n) {
    ParsedBsdf b = parse_bsdf_value(n);
    std::string id = n.attribute("id").value();
    return id.empty() ? add_material(n, b) : bsdfs_[id];
  }

  // ---- textures ----
  // A file named relative to the scene file; it must be a regular file.
  fs::path scene_file(pugi::xml_node n, const std::string& file, const char* what) const {
    const fs::path full = fs::path(path_).parent_path() / file;
    std::error_code ec;
    if (!fs::is_regular_file(full, ec))
      error(n, std::string("cannot open ") + what + " '" + full.string() +
                   "': " + (fs::exists(full, ec) ? "not a regular file" : "no such file"));
    return full;
  }
  // A texture's to_uv (Mitsuba 3: the upper-left 3×3 of the transform, an
  // affine map of uv) or Mitsuba 0.5's uscale, vscale, uoffset, voffset.
  UvTransform uv_transform(pugi::xml_node t, Props& p) {
    UvTransform m;
    if (p.has("to_uv")) {
      const Matrix4 a = p.get_transform("to_uv");
      if (a.m[2][0] != 0 || a.m[2][1] != 0 || a.m[2][2] != 1)
        error(t, "to_uv must be an affine map of (u, v): its third row must be 0 0 1");
      m = {float(a.m[0][0]), float(a.m[0][1]), float(a.m[0][2]), float(a.m[1][0]), float(a.m[1][1]), float(a.m[1][2])};
    }
    if (legacy_names_) {
      const float us = float(p.get_float("uscale", 1.0)), vs = float(p.get_float("vscale", 1.0));
      m.a *= us, m.b *= us, m.c = m.c * us + float(p.get_float("uoffset", 0.0));
      m.d *= vs, m.e *= vs, m.f = m.f * vs + float(p.get_float("voffset", 0.0));
    }
    for (float v : {m.a, m.b, m.c, m.d, m.e, m.f})
      if (!std::isfinite(v)) error(t, "to_uv is not finite");
    return m;
  }
  // A <texture>: `bitmap` (filename relative to the scene file; filter_type,
  // wrap_mode, raw (Mitsuba 3) or gamma (Mitsuba 0.5), to_uv) or
  // `checkerboard` (color0, color1, to_uv). Returns its index in
  // the scene's textures; with load = false the texture is only checked (the file
  // must exist) and -1 returned.
  int32_t parse_texture(pugi::xml_node t, bool load) {
    std::string type = attr(t, "type");
    if (type != "bitmap" && type != "checkerboard")
      error(t, "unknown texture '" + type + "' (supported: bitmap, checkerboard)");
    check_children(t, {});
    Props p(this, t);
    const UvTransform to_uv = uv_transform(t, p);
    if (type == "checkerboard") {
      CheckerboardTexture c;
      for (const char* name : {"color0", "color1"}) {
        auto it = p.by_name.find(name);
        if (it != p.by_name.end() && (std::string(it->second.name()) == "texture" || std::string(it->second.name()) == "ref"))
          error(it->second, std::string("a texture as the checkerboard's ") + name + " is not supported");
      }
      c.color0 = p.get_color("color0", c.color0);
      c.color1 = p.get_color("color1", c.color1);
      p.check_all_used();
      for (Color v : {c.color0, c.color1})
        if (!is_finite(v) || !(v.x >= 0.f && v.y >= 0.f && v.z >= 0.f))
          error(t, "checkerboard colours must be finite and not negative");
      if (!load) return -1;
      return builder_.add_checkerboard(loc(t), c.color0, c.color1, to_uv);
    }
    std::string file = p.get_string("filename", "");
    if (file.empty()) error(t, "bitmap texture needs a 'filename'");
    BitmapTexture bm;
    // Luz has no MIP maps: trilinear (Mitsuba 0.5's choice for the staircase)
    // is looked up bilinearly at the finest level. The two differ only where
    // a texel is smaller than a pixel's footprint, and there the many samples
    // per pixel average the texels that trilinear filtering would pre-average.
    std::string filter = p.get_string("filter_type", "bilinear");
    if (filter == "nearest") bm.filter = TextureFilter::Nearest;
    else if (filter != "bilinear" && filter != "trilinear" && filter != "ewa")  // ewa: Mitsuba 0.5's default, as trilinear
      error(t, "unknown filter_type '" + filter + "' (supported: bilinear, trilinear, ewa, nearest)");
    std::string wrap = p.get_string("wrap_mode", "repeat");
    if (wrap == "mirror") bm.wrap = WrapMode::Mirror;
    else if (wrap == "clamp") bm.wrap = WrapMode::Clamp;
    else if (wrap != "repeat") error(t, "unknown wrap_mode '" + wrap + "' (supported: repeat, mirror, clamp)");
    bm.srgb = !p.get_bool("raw", false);
    double gamma = legacy_names_ ? p.get_float("gamma", -1.0) : -1.0;  // Mitsuba 3 has `raw` instead
    if (gamma == 1.0) bm.srgb = false;
    else if (gamma != -1.0) error(t, "bitmap gamma must be -1 (sRGB) or 1 (linear)");
    p.check_all_used();
    const fs::path full = scene_file(t, file, "bitmap");
    if (!load) return -1;
    return builder_.add_image_texture(loc(t), {full.string(), bm.srgb, bm.filter, bm.wrap, to_uv});
  }
  static std::string lower_extension(const fs::path& f) {
    std::string e = f.extension().string();
    for (char& c : e) c = char(std::tolower((unsigned char)c));
    return e;
  }
  // A <ref> naming a top-level texture (a parameter), not a bsdf.
  bool is_texture_ref(pugi::xml_node c) const {
    return std::string(c.name()) == "ref" && c.attribute("name") && textures_.count(c.attribute("id").value()) > 0;
  }
  // Parameter `name` given as a texture (nested, or a <ref> to a top-level
  // one): its index, or -1 when the parameter is absent or a constant.
  int32_t texture_param(Props& p, const char* name, bool load = true) {
    auto it = p.by_name.find(name);
    if (it == p.by_name.end()) return -1;
    const std::string tag = it->second.name();
    if (tag == "ref") {
      p.get(name, {"ref"});
      return int32_t(textures_.at(it->second.attribute("id").value()));
    }
    if (tag != "texture") return -1;
    return parse_texture(p.get(name, {"texture"}), load);
  }
  // A colour parameter of a bsdf: a constant (a reflectance checked to lie
  // in [0, 1]), or a texture, bound to `param` of the front part, whose mean
  // is returned (what the models' lobe sampling weights use, as Mitsuba's
  // mean()); a reflectance's texels must not exceed 1.
  Color color_param(pugi::xml_node n, Props& p, const char* name, Color def, BsdfParam param, bool is_reflectance,
                    std::vector<TextureBinding>& tb) {
    const int32_t t = texture_param(p, name);
    if (t < 0) {
      if (is_reflectance) return checked_reflectance(n, p, name, def);
      return p.get_color(name, def);
    }
    const TextureStats& info = builder_.texture_stats(t);
    if (is_reflectance && max_component(info.max) > 1.f)
      error(n, std::string("'") + name + "' texture has texels above 1 (a reflectance lies in [0, 1])");
    tb.push_back({t, BsdfPart::Front, param});
    return info.mean;
  }
  // A float parameter: a number, or a texture (its luminance, Mitsuba's
  // eval_1) bound to each of `params` of the front part; returns the
  // number, or the texture's mean luminance.
  float float_param(Props& p, const char* name, float def, std::initializer_list<BsdfParam> params,
                    std::vector<TextureBinding>& tb) {
    const int32_t t = texture_param(p, name);
    if (t < 0) return float(p.get_float(name, def));
    for (BsdfParam q : params) tb.push_back({t, BsdfPart::Front, q});
    return luminance(builder_.texture_stats(t).mean);
  }
  // A float in [0, 1] (a mask's opacity, a blend's weight): a number, or a
  // texture (`texture` set; its mean luminance returned) whose texels do not
  // exceed 1.
  float unit_param(pugi::xml_node n, Props& p, const char* plugin, const char* name, float def, int32_t& texture) {
    texture = texture_param(p, name);
    const std::string what = std::string(plugin) + " '" + name + "'";
    if (texture >= 0) {
      if (max_component(builder_.texture_stats(texture).max) > 1.f)
        error(n, what + " texture has texels above 1 (it lies in [0, 1])");
      return luminance(builder_.texture_stats(texture).mean);
    }
    const float v = float(p.get_float(name, def));
    if (!(v >= 0.f && v <= 1.f)) error(n, what + " must lie in [0, 1]");
    return v;
  }
  // A colour parameter's greatest value: its texture's maximum when bound, else v.
  Color texture_max(const std::vector<TextureBinding>& tb, BsdfParam param, Color v) const {
    for (const TextureBinding& t : tb)
      if (t.part == BsdfPart::Front && t.param == param) return builder_.texture_stats(t.texture).max;
    return v;
  }

  uint32_t resolve_ref(pugi::xml_node r) {
    std::string id = attr(r, "id");
    auto it = bsdfs_.find(id);
    if (it == bsdfs_.end()) error(r, "no bsdf with id '" + id + "' defined before this point");
    return it->second;
  }

  // Top-level emitters: `constant` (an environment), and the delta lights
  // `point`, `spot` and `directional`.
  void parse_emitter(pugi::xml_node n) {
    std::string type = attr(n, "type");
    check_children(n, {});
    Props p(this, n);
    auto non_negative = [&](Color c, const char* what) {
      for (int k = 0; k < 3; ++k)
        if (!(c[k] >= 0.f) || !std::isfinite(c[k])) error(n, std::string(what) + " must be finite and not negative");
      return c;
    };
    // A light's placement: `position` (point) or `direction` (directional),
    // or to_world; not both.
    auto placement = [&](const char* alternative) {
      if (p.has(alternative) && p.has("to_world"))
        error(n, std::string("give either '") + alternative + "' or 'to_world', not both");
      return p.get_transform("to_world");
    };
    auto finite_place = [&](Vec3 v, const char* what) {
      if (!is_finite(v) || max_abs(v) > kMaxCoordinate)
        error(n, std::string("the light's ") + what + " is not finite or lies beyond 1e18");
      return v;
    };
    if (type == "constant") {
      Color L = non_negative(p.get_color("radiance", {1, 1, 1}), "radiance");
      p.check_all_used();
      ConstantLight c;
      c.radiance = L;
      builder_.add_light(loc(n), c);
    } else if (type == "point") {
      PointLight l;
      l.intensity = non_negative(p.get_color("intensity", {1, 1, 1}), "intensity");
      Matrix4 to_world = placement("position");
      l.position = finite_place(p.has("position") ? p.get_point("position", {}) : to_world.point({0, 0, 0}), "position");
      p.check_all_used();
      builder_.add_light(loc(n), l);
    } else if (type == "spot") {
      SpotLight l;
      l.intensity = non_negative(p.get_color("intensity", {1, 1, 1}), "intensity");
      const double cutoff = p.get_float("cutoff_angle", 20.0);
      const double beam = p.get_float("beam_width", cutoff * 3.0 / 4.0);
      l.texture = texture_param(p, "texture");  // projected over the cutoff cone
      Matrix4 to_world = p.get_transform("to_world");
      p.check_all_used();
      if (!(cutoff > 0.0 && cutoff <= 90.0)) error(n, "cutoff_angle must be in (0, 90] degrees");
      if (!(beam > 0.0 && beam <= cutoff)) error(n, "beam_width must be in (0, cutoff_angle] degrees");
      l.position = finite_place(to_world.point({0, 0, 0}), "position");
      if (!inverse_rows(to_world, l.inv_x, l.inv_y, l.inv_z)) error(n, "the spot light's to_world is degenerate");
      l.cutoff = float(cutoff * M_PI / 180.0);
      l.beam = float(beam * M_PI / 180.0);
      l.cos_cutoff = float(std::cos(cutoff * M_PI / 180.0));
      l.cos_beam = float(std::cos(beam * M_PI / 180.0));
      l.inv_transition = beam < cutoff ? float(1.0 / ((cutoff - beam) * M_PI / 180.0)) : 0.f;
      l.tan_cutoff = float(std::tan(cutoff * M_PI / 180.0));
      builder_.add_light(loc(n), l);
    } else if (type == "directional") {
      DirectionalLight l;
      l.irradiance = non_negative(p.get_color("irradiance", {1, 1, 1}), "irradiance");
      Matrix4 to_world = placement("direction");
      Vec3 d = p.has("direction") ? p.get_point("direction", {}) : to_world.vector({0, 0, 1});
      p.check_all_used();
      const float len = length(d);
      if (!(len > 0.f) || !std::isfinite(len)) error(n, "the directional light's direction is zero or not finite");
      l.direction = d / len;
      builder_.add_light(loc(n), l);
    } else if (type == "envmap") {
      parse_envmap(n, p);
    } else {
      error(n, "unknown top-level emitter '" + type + "' (supported: constant, envmap, point, spot, directional)");
    }
  }

  // An equirectangular environment map: filename (relative to the scene
  // file; OpenEXR, Radiance HDR, PFM, or 8-bit sRGB), scale, to_world.
  void parse_envmap(pugi::xml_node n, Props& p) {
    const std::string file = p.get_string("filename", "");
    if (file.empty()) error(n, "envmap needs a 'filename'");
    const double scale = p.get_float("scale", 1.0);
    Matrix4 to_world = p.get_transform("to_world");
    p.check_all_used();
    if (!(scale >= 0.0) || !std::isfinite(scale)) error(n, "scale must be finite and not negative");
    const fs::path full = scene_file(n, file, "envmap");
    Image img;
    try {
      img = read_image_linear(full.string());
    } catch (const InputError& e) {
      error(n, e.what());
    }
    EnvmapLight l;
    l.scale = float(scale);
    l.to_world_x = to_world.vector({1, 0, 0});
    l.to_world_y = to_world.vector({0, 1, 0});
    l.to_world_z = to_world.vector({0, 0, 1});
    if (!inverse_rows(to_world, l.to_local_x, l.to_local_y, l.to_local_z))
      error(n, "the envmap's to_world is degenerate");
    builder_.add_envmap(loc(n), l, img, file);
  }

  void parse_shape(pugi::xml_node n) {
    std::string type = attr(n, "type");
    if (type != "sphere" && type != "rectangle" && type != "cube" && type != "obj")
      error(n, "unknown shape '" + type + "' (supported: obj, rectangle, cube, sphere)");
    check_children(n, {"bsdf", "ref", "emitter"});
    Props p(this, n);
    Matrix4 to_world = p.get_transform("to_world");
    bool flip = p.get_bool("flip_normals", false);

    // Material: nested <bsdf>, a <ref>, or Mitsuba's default (diffuse 0.5).
    int material = -1;
    for (pugi::xml_node c : n.children()) {
      if (c.type() != pugi::node_element) continue;
      std::string tag = c.name();
      if (tag != "bsdf" && tag != "ref") continue;
      if (material >= 0) error(c, "a shape takes one bsdf");
      material = int(tag == "ref" ? resolve_ref(c) : parse_bsdf(c));
    }
    if (material < 0) material = int(builder_.default_material());

    // An area emitter: a constant radiance or a texture (its mean kept as
    // the radiance that power and light selection use).
    AreaEmission area;
    const AreaEmission* emission = nullptr;
    for (pugi::xml_node c : n.children("emitter")) {
      if (emission) error(c, "a shape takes one emitter");
      std::string et = attr(c, "type");
      if (et != "area") error(c, "unknown shape emitter '" + et + "' (supported: area)");
      check_children(c, {});
      Props ep(this, c);
      area.texture = texture_param(ep, "radiance");
      area.radiance = area.texture >= 0 ? builder_.texture_stats(area.texture).mean : ep.get_color("radiance", {1, 1, 1});
      ep.check_all_used();
      emission = &area;
    }

    // Textures, masks, normal and bump maps need texture coordinates: rectangles
    // and OBJ meshes with vt have them. Only a textured shape keeps them (see read_obj).
    const Material& mat = builder_.scene().materials[size_t(material)];
    const bool textured_bsdf = mat.num_bindings > 0 || mat.opacity_texture >= 0 || mat.normal_map >= 0 || mat.bump_map >= 0;
    const bool textured = textured_bsdf || area.texture >= 0;
    auto refuse_texture = [&](const char* why) {
      if (textured) error(n, std::string(textured_bsdf ? "a textured bsdf on " : "a textured emitter on ") + why);
    };
    std::vector<Vec3> pos, nrm;
    std::vector<Vec2> uv;
    std::vector<uint32_t> idx;
    if (type == "sphere") {
      refuse_texture("a sphere is not supported (no texture coordinates)");
      Vec3 center = p.get_point("center", {});
      double radius = p.get_float("radius", 1.0);
      if (!(radius > 0)) error(n, "radius must be positive");
      p.check_all_used();
      Vec3 c = to_world.point(center);
      float sx = length(to_world.vector({1, 0, 0})), sy = length(to_world.vector({0, 1, 0})),
            sz = length(to_world.vector({0, 0, 1}));
      if (std::fabs(sx - sy) > 1e-4f * sx || std::fabs(sx - sz) > 1e-4f * sx)
        error(n, "a sphere's to_world must scale uniformly");
      builder_.add_sphere(loc(n), c, float(radius) * sx, uint32_t(material), emission, flip);
      return;
    }
    if (type == "rectangle") {
      p.check_all_used();
      pos = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
      nrm.assign(4, {0, 0, 1});
      if (textured) uv = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};  // Mitsuba's rectangle
      idx = {0, 1, 2, 2, 3, 0};
    } else if (type == "cube") {
      p.check_all_used();
      refuse_texture("a cube is not supported (no texture coordinates)");
      // Each face: 4 corners counter-clockwise seen from outside.
      for (int axis = 0; axis < 3; ++axis)
        for (int sgn = -1; sgn <= 1; sgn += 2) {
          Vec3 nn{};
          nn[axis] = float(sgn);
          int a = (axis + 1) % 3, b = (axis + 2) % 3;
          uint32_t base = uint32_t(pos.size());
          const float corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
          for (const auto& cr : corners) {
            Vec3 v{};
            v[axis] = float(sgn);
            v[a] = cr[0] * float(sgn);
            v[b] = cr[1];
            pos.push_back(v);
            nrm.push_back(nn);
          }
          idx.insert(idx.end(), {base, base + 1, base + 2, base + 2, base + 3, base});
        }
    } else if (type == "obj") {
      std::string file = p.get_string("filename", "");
      if (file.empty()) error(n, "obj shape needs a 'filename'");
      bool face_normals = p.get_bool("face_normals", false);
      // Mitsuba flips OBJ's v by default (read_obj does); flip_tex_coords false keeps vt as written.
      const bool flip_uv = p.get_bool("flip_tex_coords", true);
      p.check_all_used();
      const fs::path full = scene_file(n, file, "OBJ file");
      ObjMesh mesh = read_obj(full.string(), false, textured);
      pos = std::move(mesh.positions);
      if (!face_normals) nrm = std::move(mesh.normals);
      if (textured && mesh.texcoords.empty()) refuse_texture(("an OBJ mesh without texture coordinates ('" + file + "')").c_str());
      uv = std::move(mesh.texcoords);
      if (!flip_uv)
        for (Vec2& t : uv) t.y = 1.f - t.y;
      idx = std::move(mesh.indices);
    } else {
      error(n, "unknown shape '" + type + "' (supported: obj, rectangle, cube, sphere)");
    }

    // Bake the transform. Analytic rectangle and cube keep the normal given by
    // the normal transform; the winding is set to agree with it.
    bool analytic = type != "obj";
    for (Vec3& v : pos) v = to_world.point(v);
    for (Vec3& v : nrm) v = to_world.normal(v);
    for (size_t k = 0; k + 2 < idx.size(); k += 3) {
      Vec3 g = cross(pos[idx[k + 1]] - pos[idx[k]], pos[idx[k + 2]] - pos[idx[k]]);
      if (length(g) == 0.f) continue;
      bool swap = analytic && dot(g, nrm[idx[k]]) < 0.f;
      if (swap != flip) std::swap(idx[k + 1], idx[k + 2]);
    }
    if (flip)
      for (Vec3& v : nrm) v = -v;
    if (analytic) nrm.clear();  // flat faces: the geometric normal is exact
    builder_.add_mesh(loc(n), {std::move(pos), std::move(nrm), std::move(uv), std::move(idx)}, uint32_t(material), emission);
  }

  std::string path_;
  Defines defines_;
  Defines params_;
  std::string text_;
  pugi::xml_document doc_;
  std::map<std::string, uint32_t> bsdfs_;
  std::map<std::string, uint32_t> textures_;  // top-level <texture id>, by id
  SceneBuilder builder_{path_};
  bool legacy_names_ = false;  // a Mitsuba 0.5/0.6 scene: camelCase parameter names
  int bsdf_depth_ = 0;
  static constexpr int kMaxBsdfNesting = 32;
};

}  // namespace

Scene load_mitsuba(const std::string& path, const Defines& defines) { return MitsubaParser(path, defines).parse(); }

}  // namespace luz
