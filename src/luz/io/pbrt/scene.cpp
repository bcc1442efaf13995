// pbrt-v4 scenes, third stage: the directives translated onto the
// SceneBuilder. Each pbrt-v4 entity maps onto the nearest Luz one; where the
// two differ the difference is written beside the mapping, and what Luz
// cannot render is refused (InputError "file:line: ...") or skipped with a
// one-line warning that names it, never silently.
//
// Conventions bridged here:
// - pbrt's camera space has +x to the right of the image (a left-handed
//   frame); Luz's (Mitsuba's) has +x to the left: the camera's x axis is
//   negated. pbrt's `Transform`/`ConcatTransform` list the matrix by columns.
// - pbrt's texture v points up the image (its image lookup flips v); Luz's
//   points down: mesh uvs are stored as (u, 1 - v).
// - pbrt's materials scatter on both sides: Luz's reflective models are made
//   two-sided. Area lights are one-sided in both; pbrt's emitting side is
//   that of the shading normals when a mesh has them, else the winding's
//   (flipped by ReverseOrientation and by a mirroring transform): the
//   winding is set so that Luz's geometric normal is that side.
// - Spectra: RGB values are used as they are (pbrt-v4 renders an "rgb L" of
//   (1,1,1) as white (1,1,1) in its sRGB film); named metal spectra take the
//   RGB of Luz's conductor presets, named glasses their index at 587.6 nm.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <tbb/parallel_invoke.h>

#include "luz/bsdf/fresnel.h"
#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "luz/io/mesh_ply.h"
#include "luz/io/pbrt/parser.h"
#include "luz/io/pbrt/tokenizer.h"
#include "luz/io/read_ahead.h"
#include "luz/io/spectrum.h"
#include "luz/math/transform.h"
#include "luz/scene/scene_builder.h"
#include "luz/texture/texture.h"

namespace fs = std::filesystem;

namespace luz {
namespace pbrt {
namespace {

// ---- small matrix helpers ----

// pbrt-v4 reads the 16 numbers of Transform / ConcatTransform as the
// transpose of the row-major matrix: the file lists columns.
Matrix4 from_columns(const double v[16]) {
  Matrix4 r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r.m[i][j] = v[4 * j + i];
  return r;
}

// General 4×4 inverse (Gauss-Jordan with partial pivoting); false when singular.
bool invert(const Matrix4& a, Matrix4& out) {
  double m[4][8];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      m[i][j] = a.m[i][j];
      m[i][j + 4] = i == j ? 1 : 0;
    }
  for (int c = 0; c < 4; ++c) {
    int p = c;
    for (int r = c + 1; r < 4; ++r)
      if (std::fabs(m[r][c]) > std::fabs(m[p][c])) p = r;
    if (!(std::fabs(m[p][c]) > 1e-300)) return false;
    for (int j = 0; j < 8; ++j) std::swap(m[c][j], m[p][j]);
    const double inv = 1 / m[c][c];
    for (int j = 0; j < 8; ++j) m[c][j] *= inv;
    for (int r = 0; r < 4; ++r)
      if (r != c) {
        const double f = m[r][c];
        for (int j = 0; j < 8; ++j) m[r][j] -= f * m[c][j];
      }
  }
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) out.m[i][j] = m[i][j + 4];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      if (!std::isfinite(out.m[i][j])) return false;
  return true;
}

// pbrt's LookAt (transform.cpp): the world-to-camera matrix whose inverse has
// columns (right, up, dir, eye), right = normalize(up) × dir: Mitsuba's
// look_at (which calls that vector "left": the frames differ in handedness).
bool pbrt_look_at(Vec3 eye, Vec3 target, Vec3 up, Matrix4& out) {
  const Vec3 d = target - eye;
  if (!(length(d) > 0.f) || !(length(up) > 0.f)) return false;
  if (!(length(cross(normalize(up), normalize(d))) > 1e-6f)) return false;
  return invert(Matrix4::look_at(eye, target, up), out);
}

// Rows of the inverse of m's linear part.
bool inverse_rows(const Matrix4& m, Vec3& x, Vec3& y, Vec3& z) {
  Matrix4 inv;
  if (!invert(m, inv)) return false;
  x = {float(inv.m[0][0]), float(inv.m[0][1]), float(inv.m[0][2])};
  y = {float(inv.m[1][0]), float(inv.m[1][1]), float(inv.m[1][2])};
  z = {float(inv.m[2][0]), float(inv.m[2][1]), float(inv.m[2][2])};
  return is_finite(x) && is_finite(y) && is_finite(z);
}

// pbrt-v4's EqualAreaSphereToSquare (Clarberg 2008, util/math.cpp): a unit
// direction to [0,1]² of the equal-area octahedral map, atan exact here.
Vec2 equal_area_sphere_to_square(Vec3 d) {
  const float x = std::fabs(d.x), y = std::fabs(d.y), z = std::fabs(d.z);
  const float r = std::sqrt(std::max(0.f, 1.f - z));
  const float a = std::max(x, y);
  const float b = a == 0.f ? 0.f : std::min(x, y) / a;
  float phi = std::atan(b) * float(2.0 / M_PI);
  if (x < y) phi = 1.f - phi;
  float v = phi * r, u = r - v;
  if (d.z < 0.f) {
    std::swap(u, v);
    u = 1.f - u;
    v = 1.f - v;
  }
  u = std::copysign(u, d.x);
  v = std::copysign(v, d.y);
  return {0.5f * (u + 1.f), 0.5f * (v + 1.f)};
}

bool same(Color a, Color b) { return a.x == b.x && a.y == b.y && a.z == b.z; }


// Named spectra of pbrt-v4 (spectrum.cpp) that Luz maps: metals onto the
// conductor presets' RGB, glasses onto their index at the d line (587.6 nm,
// Schott catalogue), dispersion dropped.
struct NamedGlass {
  const char* name;
  float eta;
};
constexpr NamedGlass kGlasses[] = {{"glass-BK7", 1.5168f},  {"glass-BAF10", 1.6700f}, {"glass-FK51A", 1.4866f},
                                   {"glass-LASF9", 1.8503f}, {"glass-F5", 1.6034f},   {"glass-F10", 1.6200f},
                                   {"glass-F11", 1.6209f}};
bool named_metal(const std::string& s, Color& out) {
  // "metal-Cu-eta", "metal-Cu-k"
  if (s.rfind("metal-", 0) != 0) return false;
  const size_t dash = s.rfind('-');
  if (dash <= 6) return false;
  const std::string metal = s.substr(6, dash - 6), part = s.substr(dash + 1);
  if (part != "eta" && part != "k") return false;
  Color eta, k;
  if (metal == "none" || !find_conductor_preset(metal.c_str(), eta, k)) return false;
  out = part == "eta" ? eta : k;
  return true;
}

// A texture as pbrt names it: a constant, or a Luz texture.
struct TexValue {
  int32_t index = -1;  // Luz texture, or -1: the constant `value`
  Color value{};
};

// A parameter that is a colour (spectrum or float) or a texture.
struct ColorParam {
  Color value{};
  int32_t texture = -1;
  bool given = false;
};

struct GraphicsState {
  Matrix4 ctm;
  bool reverse_orientation = false;
  int32_t material = -1;  // -1: pbrt-v4's default, diffuse 0.5
  bool interface = false;  // the current material is "interface"
  std::string material_name;
  bool area_light = false;
  Color area_L{};
  bool area_two_sided = false;
  double area_power = -1;  // pbrt-v4's `power` per shape, when positive
  SourceLoc area_loc;
  std::map<std::string, ParamSet> attributes;  // "shape", "light", "material", "texture"
  bool transform_start = true, transform_end = true;  // ActiveTransform
};

struct NamedMaterial {
  uint32_t index = 0;
  MaterialDesc desc;
  bool interface = false;
};

class PbrtScene final : public ParserTarget {
 public:
  explicit PbrtScene(const std::string& path) : path_(path), builder_(path) {
    search_dir_ = fs::path(path).parent_path();
    // pbrt-v4's defaults where the file gives no Integrator or PixelFilter:
    // volpath with maxdepth 5 (Luz's depth counts segments: 6), a gaussian.
    builder_.settings().integrator.max_depth = 6;
    builder_.settings().filter = FilterKind::Gaussian;
  }

  Scene finish() { return builder_.finish(); }

  // ---- transforms ----
  void apply(const SourceLoc& at, const Matrix4& m, bool concat) {
    if (!gs_.transform_start) {
      warn_once(at, "motion", "motion blur is not supported: transforms at the end time are ignored");
      return;
    }
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        if (!std::isfinite(m.m[i][j])) error(at, "the transform is not finite");
    gs_.ctm = concat ? gs_.ctm * m : m;
  }
  void identity(const SourceLoc& at) override { apply(at, Matrix4(), false); }
  void translate(const SourceLoc& at, Vec3 d) override { apply(at, Matrix4::translate(d), true); }
  void scale(const SourceLoc& at, Vec3 s) override { apply(at, Matrix4::scale(s), true); }
  void rotate(const SourceLoc& at, double degrees, Vec3 axis) override {
    if (!(length(axis) > 0.f)) error(at, "Rotate needs a non-zero axis");
    apply(at, Matrix4::rotate(axis, degrees), true);
  }
  void look_at(const SourceLoc& at, Vec3 eye, Vec3 target, Vec3 up) override {
    Matrix4 m;
    if (!pbrt_look_at(eye, target, up, m))
      error(at, "LookAt: the eye and target coincide, or up is zero or parallel to the view direction");
    apply(at, m, true);
  }
  void concat_transform(const SourceLoc& at, const double v[16]) override { apply(at, from_columns(v), true); }
  void transform(const SourceLoc& at, const double v[16]) override { apply(at, from_columns(v), false); }
  void coordinate_system(const SourceLoc&, const std::string& name) override { named_coords_[name] = gs_.ctm; }
  void coord_sys_transform(const SourceLoc& at, const std::string& name) override {
    auto it = named_coords_.find(name);
    if (it == named_coords_.end()) error(at, "no coordinate system named '" + name + "'");
    gs_.ctm = it->second;
  }
  void active_transform(const SourceLoc&, const std::string& which) override {
    gs_.transform_start = which != "EndTime";
    gs_.transform_end = which != "StartTime";
  }
  void transform_times(const SourceLoc& at, double, double) override {
    warn_once(at, "motion", "motion blur is not supported: TransformTimes is ignored");
  }
  void reverse_orientation(const SourceLoc&) override { gs_.reverse_orientation = !gs_.reverse_orientation; }

  // ---- options ----
  void option(const SourceLoc& at, const Param& p) override {
    builder_.warn(at, "Option \"" + p.type + " " + p.name + "\" is not supported: ignored");
  }
  void color_space(const SourceLoc& at, const std::string& name) override {
    if (name != "srgb") error(at, "ColorSpace '" + name + "' is not supported (Luz renders in linear sRGB)");
  }
  void camera(const SourceLoc& at, const std::string& name, ParamSet params) override {
    before_world(at, "Camera");
    if (camera_given_) error(at, "a second Camera");
    camera_given_ = true;
    camera_loc_ = at;
    camera_type_ = name;
    camera_params_ = std::move(params);
    camera_from_world_ = gs_.ctm;
    Matrix4 world_from_camera;
    if (!invert(gs_.ctm, world_from_camera)) error(at, "the camera's transform is singular");
    named_coords_["camera"] = world_from_camera;
  }
  void film(const SourceLoc& at, const std::string& name, ParamSet params) override {
    before_world(at, "Film");
    if (name != "rgb" && name != "gbuffer" && name != "spectral")
      error(at, "unknown film '" + name + "' (supported: rgb, gbuffer, spectral)");
    if (name != "rgb") builder_.warn(at, "film '" + name + "' is rendered as an RGB film (its other channels are not written)");
    film_loc_ = at;
    film_params_ = std::move(params);
  }
  void sampler(const SourceLoc& at, const std::string& name, ParamSet ps) override {
    before_world(at, "Sampler");
    RenderSettings& s = builder_.settings();
    int spp = ps.get_int("pixelsamples", 16);
    if (name == "independent") {
      s.sampler = SamplerType::Independent;
    } else if (name == "stratified") {
      // pbrt's stratified sampler: xsamples × ysamples strata (default 4 × 4).
      s.sampler = SamplerType::Stratified;
      spp = ps.get_int("xsamples", 4) * ps.get_int("ysamples", 4);
      ps.get_bool("jitter", true);
    } else if (name == "sobol" || name == "zsobol" || name == "paddedsobol" || name == "halton" || name == "pmj02bn") {
      // Low-discrepancy samplers: Luz's Sobol sampler, the nearest.
      s.sampler = SamplerType::Sobol;
      ps.get_string("randomization", "");
    } else {
      error(at, "unknown sampler '" + name + "' (supported: independent, stratified, sobol, zsobol, paddedsobol, "
                "halton, pmj02bn)");
    }
    if (spp < 1 || spp > (1 << 24)) error(at, "pixelsamples must be between 1 and 16777216 (2^24)");
    s.spp = uint32_t(spp);
    s.seed = uint64_t(std::max(0, ps.get_int("seed", 0)));
    done(ps);
  }
  void pixel_filter(const SourceLoc& at, const std::string& name, ParamSet ps) override {
    before_world(at, "PixelFilter");
    // Luz's filters have fixed footprints: box 1 pixel wide (pbrt's radius
    // 0.5), tent of radius 1, gaussian of standard deviation 0.5.
    FilterKind k;
    double radius;
    if (name == "box") k = FilterKind::Box, radius = 0.5;
    else if (name == "triangle") k = FilterKind::Tent, radius = 2.0;
    else if (name == "gaussian") k = FilterKind::Gaussian, radius = 1.5;
    else if (name == "mitchell" || name == "sinc") {
      builder_.warn(at, "pixel filter '" + name + "' is rendered with Luz's gaussian filter (stddev 0.5), the nearest");
      k = FilterKind::Gaussian, radius = name == "mitchell" ? 2.0 : 4.0;
      ps.get_float("B", 1.0 / 3), ps.get_float("C", 1.0 / 3), ps.get_float("tau", 3.0);
    } else {
      error(at, "unknown pixel filter '" + name + "' (supported: box, triangle, gaussian, mitchell, sinc)");
    }
    const double rx = ps.get_float("xradius", radius), ry = ps.get_float("yradius", radius);
    const double luz_radius = k == FilterKind::Box ? 0.5 : k == FilterKind::Tent ? 1.0 : radius;
    if (k == FilterKind::Gaussian && ps.get_float("sigma", 0.5) != 0.5)
      builder_.warn(at, "gaussian sigma other than 0.5 is rendered with Luz's 0.5");
    if (rx != luz_radius || ry != luz_radius)
      builder_.warn(at, "pixel filter radius " + num(rx) + " x " + num(ry) + " is rendered with Luz's " +
                            (k == FilterKind::Box ? "box (radius 0.5)" : k == FilterKind::Tent ? "tent (radius 1)" : "gaussian"));
    builder_.settings().filter = k;
    done(ps);
  }
  void integrator(const SourceLoc& at, const std::string& name, ParamSet ps) override {
    before_world(at, "Integrator");
    IntegratorParams& ip = builder_.settings().integrator;
    ip.type = IntegratorType::Path;
    // pbrt's maxdepth counts scattering events (0: emitted light only); Luz
    // counts path segments as Mitsuba (1: emitted light only): N + 1.
    const int depth = ps.get_int("maxdepth", 5);
    if (depth < 0) error(at, "maxdepth must be ≥ 0");
    ip.max_depth = depth + 1;
    if (name != "path" && name != "volpath") {
      builder_.warn(at, "integrator '" + name + "' is not supported: rendered with the path tracer (same expected "
                        "image for unbiased integrators)");
      for (const char* p : {"lightsampler", "regularize", "samplelights", "samplebsdf", "visualizestrategies",
                            "visualizeweights", "mutationsperpixel", "largestepprobability", "sigma", "chains",
                            "bootstrapsamples", "iterations", "photonsperiteration", "radius", "maxdistance", "cossample"})
        if (const Param* q = ps.find(p)) q->used = true;
    }
    const std::string ls = ps.get_string("lightsampler", "bvh");
    if (ls == "bvh") builder_.settings().light_sampler = LightSamplerType::Bvh;
    else if (ls == "power" || ls == "uniform") builder_.settings().light_sampler = LightSamplerType::Power;
    else error(at, "unknown lightsampler '" + ls + "' (supported: bvh, power, uniform)");
    if (ps.get_bool("regularize", false)) builder_.warn(at, "regularize is not supported: ignored");
    done(ps);
  }
  void accelerator(const SourceLoc&, const std::string&, ParamSet ps) override {
    for (const Param& p : ps.params) p.used = true;  // a performance hint: Luz uses Embree
  }
  void make_named_medium(const SourceLoc& at, const std::string& name, ParamSet ps) override {
    for (const Param& p : ps.params) p.used = true;
    media_.insert(name);
    builder_.warn(at, "participating media are not supported: medium '" + name + "' is ignored");
  }
  void medium_interface(const SourceLoc& at, const std::string& inside, const std::string& outside) override {
    if (!inside.empty() || !outside.empty())
      builder_.warn(at, "participating media are not supported: MediumInterface \"" + inside + "\" \"" + outside +
                            "\" is ignored (shapes render as if in vacuum)");
  }

  void world_begin(const SourceLoc& at) override {
    before_world(at, "WorldBegin");
    in_world_ = true;
    make_camera();
    gs_.ctm = Matrix4();
    named_coords_["world"] = gs_.ctm;
  }

  // ---- attributes ----
  void attribute_begin(const SourceLoc& at) override { stack_.push_back({gs_, at, false}); }
  void attribute_end(const SourceLoc& at) override {
    if (stack_.empty() || stack_.back().transform_only) error(at, "AttributeEnd without a matching AttributeBegin");
    gs_ = stack_.back().state;
    stack_.pop_back();
  }
  void transform_begin(const SourceLoc& at) override {
    warn_once(at, "transformbegin", "TransformBegin/TransformEnd are deprecated in pbrt-v4 (read as before)");
    stack_.push_back({gs_, at, true});
  }
  void transform_end(const SourceLoc& at) override {
    if (stack_.empty() || !stack_.back().transform_only) error(at, "TransformEnd without a matching TransformBegin");
    gs_.ctm = stack_.back().state.ctm;
    stack_.pop_back();
  }
  void attribute(const SourceLoc& at, const std::string& target, ParamSet ps) override {
    if (target != "shape" && target != "light" && target != "material" && target != "medium" && target != "texture")
      error(at, "unknown Attribute target '" + target + "' (shape, light, material, medium, texture)");
    ParamSet& set = gs_.attributes[target];
    for (Param& p : ps.params) {
      auto it = std::find_if(set.params.begin(), set.params.end(), [&](const Param& q) { return q.name == p.name; });
      if (it != set.params.end()) *it = p;
      else set.params.push_back(p);
    }
  }
  // A directive's parameters with the Attribute defaults of `target` it does
  // not give; those may go unused (pbrt-v4's mayBeUnused): a shape default
  // need not apply to every shape.
  ParamSet with_attributes(ParamSet ps, const char* target) const {
    auto it = gs_.attributes.find(target);
    if (it == gs_.attributes.end()) return ps;
    for (const Param& p : it->second.params)
      if (!ps.find(p.name)) {
        ps.params.push_back(p);
        ps.params.back().used = true;
      }
    return ps;
  }

  // ---- textures ----
  void texture(const SourceLoc& at, const std::string& name, const std::string& type, const std::string& cls,
               ParamSet raw) override {
    in_world(at, "Texture");
    if (type != "float" && type != "spectrum")
      error(at, "texture type must be \"float\" or \"spectrum\", found \"" + type + "\"");
    ParamSet ps = with_attributes(std::move(raw), "texture");
    const bool is_float = type == "float";
    TexValue t;
    std::string mapping = ps.get_string("mapping", "uv");
    if (mapping != "uv") error(at, "texture mapping '" + mapping + "' is not supported (only uv)");
    const double su = ps.get_float("uscale", 1), sv = ps.get_float("vscale", 1), du = ps.get_float("udelta", 0),
                 dv = ps.get_float("vdelta", 0);
    if (cls == "imagemap") {
      const std::string file = ps.get_string("filename", "");
      if (file.empty()) error(at, "imagemap needs a 'filename'");
      ImageTextureDesc d;
      const std::string filter = ps.get_string("filter", "bilinear");
      // Luz has no MIP maps: trilinear and EWA are looked up bilinearly at
      // the finest level (many samples per pixel average what they pre-filter).
      if (filter == "point") d.filter = TextureFilter::Nearest;
      else if (filter != "bilinear" && filter != "trilinear" && filter != "ewa")
        error(at, "unknown imagemap filter '" + filter + "' (supported: point, bilinear, trilinear, ewa)");
      const std::string wrap = ps.get_string("wrap", "repeat");
      if (wrap == "clamp") d.wrap = WrapMode::Clamp;
      else if (wrap != "repeat") error(at, "imagemap wrap '" + wrap + "' is not supported (repeat, clamp)");
      ps.get_float("maxanisotropy", 8);
      const double scale = ps.get_float("scale", 1);
      if (!(scale >= 0) || !std::isfinite(scale)) error(at, "imagemap 'scale' must be finite and ≥ 0");
      const bool invert_values = ps.get_bool("invert", false);
      const std::string enc = ps.get_string("encoding", "sRGB");
      if (enc == "linear") d.srgb = false;
      else if (enc != "sRGB") error(at, "imagemap encoding '" + enc + "' is not supported (sRGB, linear)");
      d.path = find_file(at, file, "texture");
      // Luz looks the image up at (s, t) from its top-left; pbrt at (s, 1 - t)
      // with (s, t) = (su u + du, sv v + dv), and Luz's v is 1 - pbrt's.
      d.to_uv = {float(su), 0.f, float(du), 0.f, float(sv), float(1 - sv - dv)};
      int32_t image = builder_.add_image_texture(at, d);
      if (is_float) {
        // pbrt-v4's float image textures read the first channel (Luz's
        // float parameters read a texture's luminance: red alone is that).
        Texture red = builder_.scene().textures[size_t(image)];
        red.bitmap.channel = TextureChannel::R;
        image = builder_.add_texture(at, red);
      }
      t.index = builder_.add_scaled_texture(at, image, Color{float(scale), float(scale), float(scale)});
      if (invert_values) {
        // pbrt-v4: max(0, 1 - v), v the scaled value; 1 - v where no v exceeds 1.
        if (max_component(builder_.texture_stats(t.index).max) > 1.f)
          error(at, "imagemap 'invert' of values above 1 is not supported (pbrt clamps 1 - v at 0; Luz inverts "
                    "values in [0, 1] only)");
        Texture inverted = builder_.scene().textures[size_t(t.index)];
        inverted.scale = inverted.scale * -1.f;
        inverted.offset = {1.f, 1.f, 1.f};
        t.index = builder_.add_texture(at, inverted);
      }
      t.value = builder_.texture_stats(t.index).mean;
    } else if (cls == "checkerboard") {
      if (ps.get_int("dimension", 2) != 2) error(at, "only 2D checkerboards are supported");
      const ColorParam a = color(ps, "tex1", {1, 1, 1}, is_float), b = color(ps, "tex2", {0, 0, 0}, is_float);
      // pbrt: tex1 where floor(s) + floor(t) is even, squares of 1 in (s, t);
      // Luz's (Mitsuba's): color0 where the halves of a unit period differ.
      // Halving (s, t) makes them agree, with color0 = tex2; v flipped as above.
      // A checkerboard of textures: their mix by a checkerboard of 0 and 1.
      const UvTransform m{float(su / 2), 0.f, float(du / 2), 0.f, float(-sv / 2), float((sv + dv) / 2)};
      if (a.texture < 0 && b.texture < 0) {
        t.index = builder_.add_checkerboard(at, b.value, a.value, m);
      } else {
        const int32_t w = builder_.add_checkerboard(at, {0, 0, 0}, {1, 1, 1}, m);
        t.index = builder_.add_mix_texture(at, {b.texture, b.value}, {a.texture, a.value}, {w, {}});
      }
      t.value = builder_.texture_stats(t.index).mean;
    } else if (cls == "constant") {
      t.value = color(ps, "value", {1, 1, 1}, is_float).value;
    } else if (cls == "scale") {
      const ColorParam a = color(ps, "tex", {1, 1, 1}, is_float), s = color(ps, "scale", {1, 1, 1}, true);
      if (a.texture < 0 && s.texture < 0) {
        t.value = a.value * s.value;
      } else if (a.texture >= 0 && s.texture >= 0) {
        t.index = builder_.add_product_texture(at, {a.texture, a.value}, {s.texture, s.value});
        t.value = builder_.texture_stats(t.index).mean;
      } else {
        // A texture times a constant: a view of its texels with that factor.
        const Color k = a.texture >= 0 ? s.value : a.value;
        if (!(k.x >= 0 && k.y >= 0 && k.z >= 0)) error(at, "a scale texture's constant factor must be ≥ 0");
        t.index = builder_.add_scaled_texture(at, a.texture >= 0 ? a.texture : s.texture, k);
        t.value = builder_.texture_stats(t.index).mean;
      }
    } else if (cls == "mix") {
      const ColorParam a = color(ps, "tex1", {0, 0, 0}, is_float), b = color(ps, "tex2", {1, 1, 1}, is_float);
      const ColorParam w = color(ps, "amount", {0.5f, 0.5f, 0.5f}, true);
      const float x = w.value.x;
      if (w.texture < 0 && (x == 0.f || x == 1.f)) {
        const ColorParam& pick = x == 0.f ? a : b;
        t.index = pick.texture;
        t.value = pick.value;
      } else if (w.texture < 0 && a.texture < 0 && b.texture < 0) {
        t.value = a.value * (1 - x) + b.value * x;
      } else {
        t.index = builder_.add_mix_texture(at, {a.texture, a.value}, {b.texture, b.value}, {w.texture, w.value});
        t.value = builder_.texture_stats(t.index).mean;
      }
    } else {
      error(at, "texture '" + cls + "' is not supported (imagemap, checkerboard, constant, scale, mix)");
    }
    done(ps);
    (is_float ? float_tex_ : spectrum_tex_)[name] = t;
  }

  // ---- materials ----
  void material(const SourceLoc& at, const std::string& type, ParamSet ps) override {
    in_world(at, "Material");
    NamedMaterial m = make_material(at, type, with_attributes(std::move(ps), "material"));
    gs_.material = int32_t(m.index);
    gs_.interface = m.interface;
    gs_.material_name = type;
  }
  void make_named_material(const SourceLoc& at, const std::string& name, ParamSet raw) override {
    in_world(at, "MakeNamedMaterial");
    ParamSet ps = with_attributes(std::move(raw), "material");
    const std::string type = ps.get_string("type", "");
    if (type.empty()) error(at, "MakeNamedMaterial '" + name + "' needs a \"string type\"");
    if (named_.count(name)) error(at, "material '" + name + "' is defined twice");
    named_[name] = make_material(at, type, std::move(ps));
  }
  void named_material(const SourceLoc& at, const std::string& name) override {
    in_world(at, "NamedMaterial");
    auto it = named_.find(name);
    if (it == named_.end()) error(at, "no material named '" + name + "'");
    gs_.material = int32_t(it->second.index);
    gs_.interface = it->second.interface;
    gs_.material_name = name;
  }

  // ---- lights ----
  void light_source(const SourceLoc& at, const std::string& name, ParamSet raw) override {
    in_world(at, "LightSource");
    ParamSet ps = with_attributes(std::move(raw), "light");
    const float sc = float(ps.get_float("scale", 1));
    if (!(sc >= 0.f) || !std::isfinite(sc)) error(at, "scale must be finite and not negative");
    // `scale`, times pbrt-v4's photometric target where given (`power` or
    // `illuminance`, ignored when not positive) over k_e, what the light
    // gives at scale 1 per unit of its (luminance-1) spectrum; as in
    // pbrt-v4, the RGB's own magnitude still multiplies.
    auto scale_for = [&](const char* target, double k_e) {
      const double v = ps.get_float(target, -1);
      if (!std::isfinite(v)) error(at, std::string("'") + target + "' must be finite");
      const double f = v > 0 ? sc * v / k_e : sc;
      if (!std::isfinite(float(f))) error(at, "the light's scale overflows");
      return float(f);
    };
    const Matrix4& m = gs_.ctm;
    if (name == "point") {
      PointLight l;
      l.intensity = light_color(at, ps, "I") * scale_for("power", 4 * M_PI);
      l.position = m.point(ps.get_point3("from", {0, 0, 0}));
      builder_.add_light(at, l);
    } else if (name == "spot") {
      SpotLight l;
      const Vec3 from = ps.get_point3("from", {0, 0, 0}), to = ps.get_point3("to", {0, 0, 1});
      const double cone = ps.get_float("coneangle", 30), delta = ps.get_float("conedeltaangle", 5);
      if (!(cone > 0 && cone <= 180)) error(at, "coneangle must be in (0, 180] degrees");
      if (!(delta >= 0 && delta <= cone)) error(at, "conedeltaangle must be in [0, coneangle]");
      // pbrt-v4's falloff: a smoothstep in cos θ from cos(coneangle) to
      // cos(coneangle - conedeltaangle); `power` over the power of intensity 1.
      l.set_cone(cone * M_PI / 180, (cone - delta) * M_PI / 180, SpotFalloff::SmoothstepCos);
      l.intensity = {1.f, 1.f, 1.f};
      l.intensity = light_color(at, ps, "I") * scale_for("power", l.phi(0.f));
      if (!(length(to - from) > 0.f)) error(at, "the spotlight's from and to coincide");
      const Vec3 dir = normalize(to - from);
      const Frame f = Frame::from_normal(dir);
      Matrix4 local;
      for (int i = 0; i < 3; ++i) {
        local.m[i][0] = f.s[i];
        local.m[i][1] = f.t[i];
        local.m[i][2] = f.n[i];
        local.m[i][3] = from[i];
      }
      const Matrix4 to_world = m * local;
      l.position = to_world.point({0, 0, 0});
      if (!inverse_rows(to_world, l.inv_x, l.inv_y, l.inv_z)) error(at, "the spotlight's transform is singular");
      builder_.add_light(at, l);
    } else if (name == "distant") {
      DirectionalLight l;
      l.irradiance = light_color(at, ps, "L") * scale_for("illuminance", 1);
      const Vec3 from = ps.get_point3("from", {0, 0, 0}), to = ps.get_point3("to", {0, 0, 1});
      const Vec3 d = m.vector(to - from);  // the way the light travels
      if (!(length(d) > 0.f) || !is_finite(d)) error(at, "the distant light's direction is zero or not finite");
      l.direction = normalize(d);
      builder_.add_light(at, l);
    } else if (name == "infinite") {
      if (ps.has("portal")) error(at, "infinite light portals are not supported");
      const std::string file = ps.get_string("filename", "");
      if (file.empty()) {
        ConstantLight c;
        c.radiance = light_color(at, ps, "L") * scale_for("illuminance", M_PI);  // π L on an upward patch
        builder_.add_light(at, c);
      } else {
        if (ps.has("L")) error(at, "give either 'L' or 'filename', not both");
        const double target = ps.get_float("illuminance", -1);
        if (!std::isfinite(target)) error(at, "'illuminance' must be finite");
        envmap(at, file, sc, target);
      }
    } else {
      error(at, "light '" + name + "' is not supported (point, spot, distant, infinite)");
    }
    done(ps);
  }

  // An infinite light from an image. pbrt-v4 reads square images in its
  // equal-area octahedral mapping (z up in light space); a square image is
  // resampled here to the equirectangular map Luz's envmap reads. A 2:1
  // image (what pbrt-v3 read) is taken as pbrt-v3's latitude-longitude map
  // (φ = atan2(y, x) across, θ from +z down), with a warning. A positive
  // `illuminance` scales a square map as pbrt-v4 does (below).
  void envmap(const SourceLoc& at, const std::string& file, float sc, double illuminance) {
    const std::string path = find_file(at, file, "environment map");
    Image img;
    try {
      img = read_image_linear(path);
    } catch (const InputError& e) {
      error(at, e.what());
    }
    if (img.width == img.height) {
      if (illuminance > 0) {
        const double k_e = pbrt_image_illuminance(img);
        if (!(k_e > 0)) error(at, "'illuminance' cannot scale environment map '" + file + "': it is black over its upper hemisphere");
        sc = float(sc * illuminance / k_e);
        if (!std::isfinite(sc)) error(at, "the light's scale overflows");
      }
      img = equal_area_to_equirect(img);
    } else if (illuminance > 0) {
      error(at, "'illuminance' needs pbrt-v4's square equal-area map; '" + file + "' is not square");
    } else if (img.width == 2 * img.height) {
      builder_.warn(at, "environment map '" + fs::path(path).filename().string() +
                            "' is not square (pbrt-v4's equal-area map): read as pbrt-v3's latitude-longitude map");
    } else {
      error(at, "environment map '" + file + "' must be square (pbrt-v4's equal-area octahedral map) or 2:1 "
                "(latitude-longitude), found " + std::to_string(img.width) + "x" + std::to_string(img.height));
    }
    // Luz's envmap (Mitsuba's) reads u = atan2(x, -z) / 2π, θ from +y; pbrt's
    // light space: u = atan2(y, x) / 2π, θ from +z. Luz local m = P p with
    // P's rows (0,1,0), (0,0,1), (-1,0,0).
    Matrix4 P;
    P.m[0][0] = 0, P.m[0][1] = 1, P.m[0][2] = 0;
    P.m[1][0] = 0, P.m[1][1] = 0, P.m[1][2] = 1;
    P.m[2][0] = -1, P.m[2][1] = 0, P.m[2][2] = 0;
    Matrix4 Pt;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) Pt.m[i][j] = P.m[j][i];
    Matrix4 to_world = gs_.ctm * Pt;
    for (int i = 0; i < 3; ++i) to_world.m[i][3] = 0;
    EnvmapLight l;
    l.scale = sc;
    l.to_world_x = to_world.vector({1, 0, 0});
    l.to_world_y = to_world.vector({0, 1, 0});
    l.to_world_z = to_world.vector({0, 0, 1});
    if (!inverse_rows(to_world, l.to_local_x, l.to_local_y, l.to_local_z))
      error(at, "the infinite light's transform is singular");
    builder_.add_envmap(at, l, img, file);
  }
  // pbrt-v4's illuminance of an equal-area map at scale 1 (ImageInfiniteLight's
  // Create): Σ Y(texel) cos θ over the texels whose centre is in the upper
  // hemisphere (+z in light space), times 2π / N². A texel spans 4π / N² sr,
  // so this is half the true illuminance, and pbrt-v4 renders such a light
  // at twice the `illuminance` asked for; Luz renders what pbrt-v4 does.
  // The centre's z in the octahedral map: 1 - r² for r = |2u - 1| + |2v - 1|
  // below 1.
  static double pbrt_image_illuminance(const Image& sq) {
    const int n = sq.width;
    double sum = 0;
    for (int y = 0; y < n; ++y) {
      const double v = std::fabs(2 * (y + 0.5) / n - 1);
      for (int x = 0; x < n; ++x) {
        const double r = std::fabs(2 * (x + 0.5) / n - 1) + v;
        if (r >= 1) continue;
        const float* t = &sq.rgb[(size_t(y) * n + x) * 3];
        sum += double(luminance({t[0], t[1], t[2]})) * (1 - r * r);
      }
    }
    return sum * 2 * M_PI / (double(n) * n);
  }

  // Resamples an equal-area octahedral square (N × N) to a latitude-longitude
  // map (2N × N) in pbrt-v3's convention: column i at φ = 2π (i + ½) / W,
  // row j at θ = π j / (H − 1), the grid Luz's envmap looks up; bilinear in
  // the square.
  static Image equal_area_to_equirect(const Image& sq) {
    const int n = sq.width, W = 2 * n, H = std::max(n, 3);
    Image out;
    out.width = W;
    out.height = H;
    out.rgb.resize(size_t(W) * H * 3);
    auto texel = [&](int x, int y, int c) {
      x = std::clamp(x, 0, n - 1), y = std::clamp(y, 0, n - 1);
      return sq.rgb[(size_t(y) * n + x) * 3 + c];
    };
    for (int j = 0; j < H; ++j) {
      const double theta = M_PI * j / (H - 1);
      for (int i = 0; i < W; ++i) {
        const double phi = 2 * M_PI * (i + 0.5) / W;
        const Vec3 d{float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)),
                     float(std::cos(theta))};
        const Vec2 uv = equal_area_sphere_to_square(d);
        const float x = uv.x * n - 0.5f, y = uv.y * n - 0.5f;
        const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
        const float fx = x - x0, fy = y - y0;
        for (int c = 0; c < 3; ++c)
          out.rgb[(size_t(j) * W + i) * 3 + c] =
              (texel(x0, y0, c) * (1 - fx) + texel(x0 + 1, y0, c) * fx) * (1 - fy) +
              (texel(x0, y0 + 1, c) * (1 - fx) + texel(x0 + 1, y0 + 1, c) * fx) * fy;
      }
    }
    return out;
  }

  void area_light_source(const SourceLoc& at, const std::string& name, ParamSet raw) override {
    in_world(at, "AreaLightSource");
    ParamSet ps = with_attributes(std::move(raw), "light");
    if (name != "diffuse") error(at, "area light '" + name + "' is not supported (diffuse)");
    if (ps.has("filename")) error(at, "an image on an area light is not supported");
    gs_.area_two_sided = ps.get_bool("twosided", false);
    gs_.area_power = ps.get_float("power", -1);
    if (!std::isfinite(gs_.area_power)) error(at, "area light 'power' must be finite");
    const float sc = float(ps.get_float("scale", 1));
    gs_.area_L = light_color(at, ps, "L") * sc;
    gs_.area_light = true;
    gs_.area_loc = at;
    done(ps);
  }

  // ---- shapes ----
  void shape(const SourceLoc& at, const std::string& name, ParamSet raw) override {
    in_world(at, "Shape");
    ParamSet ps = with_attributes(std::move(raw), "shape");
    if (gs_.interface) {
      // pbrt's "interface" marks a boundary between media and has no surface.
      for (const Param& p : ps.params) p.used = true;
      builder_.warn(at, "shape '" + name + "' with the 'interface' material (a media boundary) is skipped");
      return;
    }
    if (ps.has("alpha")) {
      if (!ps.get_texture("alpha").empty() || ps.get_float("alpha", 1) != 1)
        error(at, "shape 'alpha' (cut-outs) is not supported");
    }
    ps.get_string("emissionfilename", "");
    if (object_ >= 0 && gs_.area_light) error(at, "area lights inside an object (ObjectBegin) are not supported");
    TriangleMesh mesh;
    bool has_normals = false;
    double disk_area = 0;
    // pbrt-v4 gives each of its shapes the power: each triangle, each quad of
    // a plymesh and each patch of a bilinearmesh; a disk or sphere whole.
    const bool per_shape = gs_.area_light && gs_.area_power > 0 && object_ < 0;
    PbrtShapes shapes;
    if (name == "trianglemesh") {
      mesh.positions = ps.get_point3s("P");
      std::vector<int> idx = ps.get_ints("indices");
      if (mesh.positions.empty()) error(at, "trianglemesh needs \"point3 P\"");
      if (idx.empty()) {
        if (mesh.positions.size() != 3) error(at, "trianglemesh needs \"integer indices\" (more than 3 vertices)");
        idx = {0, 1, 2};
      }
      mesh.indices = checked_indices(at, idx, mesh.positions.size(), 3);
      mesh.normals = ps.get_normals("N");
      mesh.uvs = ps.get_point2s("uv");
      if (ps.has("S")) {
        ps.get_floats("S");
        builder_.warn(at, "trianglemesh tangents 'S' are ignored");
      }
      ps.get_ints("faceIndices");
      check_counts(at, mesh);
    } else if (name == "plymesh") {
      const std::string file = ps.get_string("filename", "");
      if (file.empty()) error(at, "plymesh needs a 'filename'");
      if (!ps.get_texture("displacement").empty() || ps.has("displacement")) {
        if (const Param* p = ps.find("displacement")) p->used = true;
        ps.get_float("edgelength", 1);
        builder_.warn(at, "plymesh displacement is not supported: the mesh is rendered undisplaced");
      }
      const std::string path = find_file(at, file, "PLY file");
      std::optional<PlyMesh> ahead = plys_ahead_.take(path);
      PlyMesh ply = ahead ? std::move(*ahead) : read_ply(path);
      mesh.positions = std::move(ply.positions);
      mesh.normals = std::move(ply.normals);
      mesh.uvs = std::move(ply.uvs);
      mesh.indices = std::move(ply.indices);
      if (per_shape) mesh_shapes(at, mesh, ply.face_first_triangle, shapes);
    } else if (name == "bilinearmesh") {
      bilinear_mesh(at, ps, mesh, per_shape ? &shapes : nullptr);
    } else if (name == "disk") {
      disk_area = disk(at, ps, mesh);
    } else if (name == "sphere") {
      sphere(at, ps);
      return;
    } else {
      error(at, "shape '" + name + "' is not supported (trianglemesh, plymesh, bilinearmesh, disk, sphere)");
    }
    if (per_shape && name == "trianglemesh") mesh_shapes(at, mesh, {}, shapes);
    has_normals = !mesh.normals.empty();
    for (Vec2& uv : mesh.uvs) uv.y = 1.f - uv.y;
    const uint32_t mat = current_material();
    done(ps);
    // Inside an object, the CTM at the shape's definition places it in the
    // object's space, and each instance's CTM applies on top (pbrt-v4).
    orient(mesh, has_normals);
    if (object_ >= 0) {
      builder_.add_object_mesh(at, uint32_t(object_), std::move(mesh), mat);
      return;
    }
    AreaEmission e;
    e.radiance = gs_.area_L;
    e.two_sided = gs_.area_two_sided;
    if (per_shape && name == "disk") e.radiance = e.radiance * powered(disk_area);
    if (per_shape && name != "disk") {
      add_powered(at, mesh, mat, e, shapes);
      return;
    }
    builder_.add_mesh(at, std::move(mesh), mat, gs_.area_light ? &e : nullptr);
  }

  // The factor of an area light of pbrt-v4 `power` over a shape of `area`
  // (pbrt's Shape::Area: in world space for triangles, in the shape's own
  // space for disks and spheres): power / (π area, twice that two-sided); 1
  // without power.
  float powered(double area) const {
    if (!(gs_.area_power > 0)) return 1.f;
    if (!(area > 0)) return 0.f;  // a degenerate triangle emits nothing
    return float(gs_.area_power / ((gs_.area_two_sided ? 2 : 1) * M_PI * area));
  }

  // pbrt-v4's shapes of a mesh Luz holds as triangles: shape k is triangles
  // first[k] to first[k + 1] (the last to the end), of world-space area[k].
  struct PbrtShapes {
    std::vector<uint32_t> first;
    std::vector<double> area;
  };

  // pbrt-v4's BilinearPatch::Area for corners in the world: a 3×3 Riemann
  // sum of the sub-patches' diagonal areas (exact for a planar patch; pbrt
  // takes a rectangle's side lengths, the same up to rounding).
  static double patch_area(const Vec3 c[4]) {
    auto at = [&](int i, int j) {
      const double u = i / 3.0, v = j / 3.0;
      double p[3];
      for (int a = 0; a < 3; ++a)
        p[a] = (1 - u) * ((1 - v) * c[0][a] + v * c[2][a]) + u * ((1 - v) * c[1][a] + v * c[3][a]);
      return std::array<double, 3>{p[0], p[1], p[2]};
    };
    double area = 0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const auto a = at(i, j), b = at(i + 1, j + 1), c1 = at(i + 1, j), d = at(i, j + 1);
        const double e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, f[3] = {c1[0] - d[0], c1[1] - d[1], c1[2] - d[2]};
        area += half_cross(e, f);
      }
    return area;
  }

  // Half the length of e × f, in double.
  static double half_cross(const double e[3], const double f[3]) {
    const double x = e[1] * f[2] - e[2] * f[1], y = e[2] * f[0] - e[0] * f[2], z = e[0] * f[1] - e[1] * f[0];
    return 0.5 * std::sqrt(x * x + y * y + z * z);
  }

  static double triangle_area(Vec3 a, Vec3 b, Vec3 c) {
    const double e[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z},
                 f[3] = {double(c.x) - a.x, double(c.y) - a.y, double(c.z) - a.z};
    return half_cross(e, f);
  }

  // A trianglemesh's or plymesh's pbrt shapes, before `orient` moves the
  // positions into the world: each triangle, or with `face_first` (the PLY
  // reader's) each face, a quad (v0, v1, v2, v3) as pbrt-v4's bilinear patch
  // p00 = v0, p10 = v1, p01 = v3, p11 = v2. pbrt skips larger faces, so a
  // power cannot be shared over one.
  void mesh_shapes(const SourceLoc& at, const TriangleMesh& mesh, const std::vector<uint32_t>& face_first,
                   PbrtShapes& shapes) const {
    const size_t triangles = mesh.indices.size() / 3, faces = face_first.empty() ? triangles : face_first.size();
    auto first = [&](size_t f) { return face_first.empty() ? f : size_t(face_first[f]); };
    auto corner = [&](size_t i) { return gs_.ctm.point(mesh.positions[mesh.indices[i]]); };
    for (size_t f = 0; f < faces; ++f) {
      const size_t t = first(f), n = (f + 1 < faces ? first(f + 1) : triangles) - t;
      shapes.first.push_back(uint32_t(t));
      if (n == 1) {
        shapes.area.push_back(triangle_area(corner(3 * t), corner(3 * t + 1), corner(3 * t + 2)));
      } else if (n == 2) {
        const Vec3 c[4] = {corner(3 * t), corner(3 * t + 1), corner(3 * t + 5), corner(3 * t + 2)};
        shapes.area.push_back(patch_area(c));
      } else {
        error(at, "area light 'power' on a plymesh with a face of " + std::to_string(n + 2) +
                      " vertices (pbrt-v4 reads triangles and quads only): give L and 'scale'");
      }
    }
  }

  // An area light of pbrt-v4 `power` on each of the mesh's pbrt shapes: the
  // shapes of equal radiance share one mesh, in the order they first occur.
  void add_powered(const SourceLoc& at, const TriangleMesh& mesh, uint32_t mat, const AreaEmission& e,
                   const PbrtShapes& shapes) {
    std::vector<TriangleMesh> parts;
    std::vector<float> factor;
    std::map<float, size_t> part_of;
    const size_t triangles = mesh.indices.size() / 3;
    for (size_t k = 0; k < shapes.first.size(); ++k) {
      const float f = powered(shapes.area[k]);
      auto [it, added] = part_of.emplace(f, parts.size());
      if (added) {
        parts.emplace_back();
        factor.push_back(f);
      }
      TriangleMesh& part = parts[it->second];
      const size_t end = k + 1 < shapes.first.size() ? shapes.first[k + 1] : triangles;
      for (size_t t = shapes.first[k]; t < end; ++t)
        for (int j = 0; j < 3; ++j) {
          const uint32_t v = mesh.indices[3 * t + size_t(j)];
          part.indices.push_back(uint32_t(part.positions.size()));
          part.positions.push_back(mesh.positions[v]);
          if (!mesh.normals.empty()) part.normals.push_back(mesh.normals[v]);
          if (!mesh.uvs.empty()) part.uvs.push_back(mesh.uvs[v]);
        }
    }
    for (size_t p = 0; p < parts.size(); ++p) {
      AreaEmission ep = e;
      ep.radiance = e.radiance * factor[p];
      builder_.add_mesh(at, std::move(parts[p]), mat, &ep);
    }
  }

  // Transforms the mesh and sets its winding so that the geometric normal is
  // pbrt's: toward the shading normals where the mesh has them, else the
  // winding's, flipped by ReverseOrientation and by a mirroring transform.
  void orient(TriangleMesh& mesh, bool has_normals) const {
    const Matrix4& m = gs_.ctm;
    for (Vec3& p : mesh.positions) p = m.point(p);
    for (Vec3& n : mesh.normals) {
      n = m.normal(n);
      if (gs_.reverse_orientation) n = -n;
    }
    const bool flip = gs_.reverse_orientation != (m.det3() < 0);
    auto& ix = mesh.indices;
    for (size_t k = 0; k + 2 < ix.size(); k += 3) {
      bool swap = flip;
      if (has_normals) {
        const Vec3 g = cross(mesh.positions[ix[k + 1]] - mesh.positions[ix[k]], mesh.positions[ix[k + 2]] - mesh.positions[ix[k]]);
        const Vec3 ns = mesh.normals[ix[k]] + mesh.normals[ix[k + 1]] + mesh.normals[ix[k + 2]];
        swap = dot(g, ns) < 0.f;
      }
      if (swap) std::swap(ix[k + 1], ix[k + 2]);
    }
  }

  void sphere(const SourceLoc& at, const ParamSet& ps) {
    const double r = ps.get_float("radius", 1);
    const double zmin = ps.get_float("zmin", -r), zmax = ps.get_float("zmax", r), phimax = ps.get_float("phimax", 360);
    if (zmin > -r || zmax < r || phimax < 360) error(at, "partial spheres (zmin, zmax, phimax) are not supported");
    if (!(r > 0)) error(at, "sphere radius must be positive");
    if (object_ >= 0) error(at, "spheres inside an object (ObjectBegin) are not supported");
    const Matrix4& m = gs_.ctm;
    const float sx = length(m.vector({1, 0, 0})), sy = length(m.vector({0, 1, 0})), sz = length(m.vector({0, 0, 1}));
    if (std::fabs(sx - sy) > 1e-4f * sx || std::fabs(sx - sz) > 1e-4f * sx)
      error(at, "a sphere's transform must scale uniformly");
    const uint32_t mat = current_material();
    done(ps);
    AreaEmission e;
    e.radiance = gs_.area_L * powered(4 * M_PI * r * r);
    // A closed sphere seen from outside shows only its outer side.
    if (gs_.area_light && gs_.area_two_sided)
      builder_.warn(at, "a two-sided sphere light emits outward only (Luz's sphere lights are one-sided)");
    // pbrt-v4's full sphere: uv = (φ / 2π, 1 - θ / π) in the CTM's axes,
    // v flipped as for every pbrt shape (sphere_uv).
    builder_.add_sphere(at, m.point({0, 0, 0}), float(r) * sx, mat, gs_.area_light ? &e : nullptr,
                        gs_.reverse_orientation != (m.det3() < 0), m);
  }

  // pbrt's disk (z = height, normal +z) as a fan of kDiskSegments triangles
  // per ring: its area is short of the disk's by (2π/n)²/6 ≈ 1e-4 relative.
  static constexpr int kDiskSegments = 256;
  // Returns pbrt's area of the disk (in its own space).
  double disk(const SourceLoc& at, const ParamSet& ps, TriangleMesh& mesh) {
    const float h = float(ps.get_float("height", 0)), r = float(ps.get_float("radius", 1)),
                ri = float(ps.get_float("innerradius", 0)), phimax = float(ps.get_float("phimax", 360));
    if (!(r > 0.f) || !(ri >= 0.f && ri < r)) error(at, "disk needs radius > innerradius ≥ 0");
    if (!(phimax > 0.f && phimax <= 360.f)) error(at, "disk phimax must be in (0, 360]");
    const float pm = phimax * float(M_PI / 180);
    const int n = std::max(3, int(std::ceil(kDiskSegments * phimax / 360.f)));
    // pbrt's disk uv: u = φ / φmax, v = (r − ρ) / (r − ri).
    for (int i = 0; i <= n; ++i) {
      const float phi = pm * float(i) / float(n);
      const float c = std::cos(phi), s = std::sin(phi);
      mesh.positions.push_back({r * c, r * s, h});
      mesh.uvs.push_back({float(i) / float(n), 0.f});
      mesh.positions.push_back({ri * c, ri * s, h});
      mesh.uvs.push_back({float(i) / float(n), 1.f});
    }
    for (int i = 0; i < n; ++i) {
      const uint32_t o0 = uint32_t(2 * i), i0 = o0 + 1, o1 = o0 + 2, i1 = o0 + 3;
      mesh.indices.insert(mesh.indices.end(), {o0, o1, i1});  // counter-clockwise seen from +z
      if (ri > 0.f) mesh.indices.insert(mesh.indices.end(), {o0, i1, i0});
    }
    return 0.5 * double(pm) * (double(r) * r - double(ri) * ri);
  }

  // pbrt's bilinear patches (vertices p00, p10, p01, p11): a planar patch
  // is exactly two triangles; a curved one is tessellated in a 16 × 16 grid
  // of its bilinear surface, with a warning.
  // Each patch's triangles follow one another; with `shapes`, each patch is
  // recorded as a pbrt shape (its area in the world).
  void bilinear_mesh(const SourceLoc& at, const ParamSet& ps, TriangleMesh& mesh, PbrtShapes* shapes) {
    const std::vector<Vec3> P = ps.get_point3s("P");
    std::vector<int> idx = ps.get_ints("indices");
    if (P.empty()) error(at, "bilinearmesh needs \"point3 P\"");
    if (idx.empty()) {
      if (P.size() != 4) error(at, "bilinearmesh needs \"integer indices\" (more than 4 vertices)");
      idx = {0, 1, 2, 3};
    }
    const std::vector<uint32_t> ix = checked_indices(at, idx, P.size(), 4);
    const std::vector<Vec3> N = ps.get_normals("N");
    const std::vector<Vec2> UV = ps.get_point2s("uv");
    if (!N.empty() && N.size() != P.size()) error(at, "bilinearmesh: \"normal N\" needs one normal per vertex");
    if (!UV.empty() && UV.size() != P.size()) error(at, "bilinearmesh: \"point2 uv\" needs one per vertex");
    bool curved = false;
    for (size_t k = 0; k < ix.size(); k += 4) {
      const Vec3 p00 = P[ix[k]], p10 = P[ix[k + 1]], p01 = P[ix[k + 2]], p11 = P[ix[k + 3]];
      const Vec3 nrm = cross(p10 - p00, p01 - p00);
      const float size = std::max({length(p10 - p00), length(p01 - p00), length(p11 - p00)});
      const bool planar = length(nrm) > 0.f && std::fabs(dot(normalize(nrm), p11 - p00)) <= 1e-5f * size;
      const int g = planar ? 1 : 16;
      curved = curved || !planar;
      if (shapes) {
        const Vec3 c[4] = {gs_.ctm.point(p00), gs_.ctm.point(p10), gs_.ctm.point(p01), gs_.ctm.point(p11)};
        shapes->first.push_back(uint32_t(mesh.indices.size() / 3));
        shapes->area.push_back(patch_area(c));
      }
      const uint32_t base = uint32_t(mesh.positions.size());
      for (int j = 0; j <= g; ++j)
        for (int i = 0; i <= g; ++i) {
          const float u = float(i) / float(g), v = float(j) / float(g);
          const float w00 = (1 - u) * (1 - v), w10 = u * (1 - v), w01 = (1 - u) * v, w11 = u * v;
          mesh.positions.push_back(p00 * w00 + p10 * w10 + p01 * w01 + p11 * w11);
          if (!N.empty()) mesh.normals.push_back(N[ix[k]] * w00 + N[ix[k + 1]] * w10 + N[ix[k + 2]] * w01 + N[ix[k + 3]] * w11);
          const Vec2 t00 = UV.empty() ? Vec2{0, 0} : UV[ix[k]], t10 = UV.empty() ? Vec2{1, 0} : UV[ix[k + 1]],
                     t01 = UV.empty() ? Vec2{0, 1} : UV[ix[k + 2]], t11 = UV.empty() ? Vec2{1, 1} : UV[ix[k + 3]];
          mesh.uvs.push_back({t00.x * w00 + t10.x * w10 + t01.x * w01 + t11.x * w11,
                              t00.y * w00 + t10.y * w10 + t01.y * w01 + t11.y * w11});
        }
      for (int j = 0; j < g; ++j)
        for (int i = 0; i < g; ++i) {
          const uint32_t a = base + uint32_t(j * (g + 1) + i), b = a + 1, c = a + uint32_t(g + 1), d = c + 1;
          // (u, v) → p: the normal dp/du × dp/dv, as pbrt's patch.
          mesh.indices.insert(mesh.indices.end(), {a, b, d, a, d, c});
        }
    }
    if (curved) builder_.warn(at, "curved bilinear patches are tessellated into 16x16 quads (planar ones into 2 triangles)");
  }

  // ---- instancing ----
  void object_begin(const SourceLoc& at, const std::string& name) override {
    in_world(at, "ObjectBegin");
    if (object_ >= 0) error(at, "ObjectBegin inside another object");
    if (objects_.count(name)) error(at, "object '" + name + "' is defined twice");
    attribute_begin(at);
    object_ = int32_t(builder_.begin_object(at, name));
    objects_[name] = uint32_t(object_);
  }
  void object_end(const SourceLoc& at) override {
    if (object_ < 0) error(at, "ObjectEnd without ObjectBegin");
    object_ = -1;
    attribute_end(at);
  }
  void object_instance(const SourceLoc& at, const std::string& name) override {
    in_world(at, "ObjectInstance");
    if (object_ >= 0) error(at, "ObjectInstance inside an object definition");
    auto it = objects_.find(name);
    if (it == objects_.end()) error(at, "no object named '" + name + "'");
    builder_.add_instance(at, it->second, gs_.ctm);
  }

  void end_of_files() override {
    if (!stack_.empty()) {
      const SourceLoc& at = stack_.back().at;
      error(at, std::string(stack_.back().transform_only ? "TransformBegin" : "AttributeBegin") + " without a matching End");
    }
    if (object_ >= 0) error({}, "ObjectBegin without ObjectEnd");
    if (!in_world_) make_camera();
  }

 private:
  struct Saved {
    GraphicsState state;
    SourceLoc at;
    bool transform_only;
  };

  [[noreturn]] void error(const SourceLoc& at, const std::string& problem) const { builder_.error(at, problem); }
  void warn_once(const SourceLoc& at, const std::string& key, const std::string& what) {
    if (warned_.insert(key).second) builder_.warn(at, what);
  }
  static std::string num(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    return b;
  }
  void before_world(const SourceLoc& at, const char* what) const {
    if (in_world_) error(at, std::string(what) + " must come before WorldBegin");
  }
  void in_world(const SourceLoc& at, const char* what) const {
    if (!in_world_) error(at, std::string(what) + " must come after WorldBegin");
  }
  // pbrt-v4 reports parameters that nothing used: a warning here.
  void done(const ParamSet& ps) {
    ps.report_unused([&](const Param& p) { builder_.warn(p.loc, "unused parameter \"" + p.type + " " + p.name + "\""); });
  }

  // A file named in the scene, relative to the scene file's directory (pbrt-v4's
  // search directory). A missing file falls back, with a warning, to one of
  // the same name with another image extension (the testball's envmap.pfm:
  // envmap.hdr), beside it or under the same relative path in a sibling of
  // the scene's directory (a scene shipped in several formats side by side,
  // sharing textures: the staircase's textures/X.tga as ../mitsuba/textures/X.jpg).
  std::string find_file(const SourceLoc& at, const std::string& name, const char* what) {
    bool other_format = false;
    const fs::path found = locate_file(name, other_format);
    std::error_code ec;
    if (other_format)
      builder_.warn(at, std::string(what) + " '" + name + "' not found: using '" +
                            fs::relative(found, search_dir_, ec).string() + "' (same name, another format)");
    if (!found.empty()) return found.string();
    const fs::path full = fs::path(name).is_absolute() ? fs::path(name) : search_dir_ / name;
    error(at, std::string("cannot open ") + what + " '" + full.string() + "': " +
                  (fs::exists(full, ec) ? "not a regular file" : "no such file"));
  }

  // The file find_file takes for `name` (empty: none), other_format set when
  // it is the stand-in of another image format.
  fs::path locate_file(const std::string& name, bool& other_format) const {
    const fs::path rel(name);
    const fs::path full = rel.is_absolute() ? rel : search_dir_ / rel;
    std::error_code ec;
    if (fs::is_regular_file(full, ec)) return full;
    if (!is_image_file(full.string())) return {};
    std::vector<fs::path> dirs{full.parent_path()};
    if (!rel.is_absolute() && fs::is_directory(search_dir_.parent_path(), ec)) {
      std::vector<fs::path> siblings;
      for (const fs::directory_entry& d : fs::directory_iterator(search_dir_.parent_path(), ec))
        if (d.is_directory(ec) && d.path() != search_dir_) siblings.push_back(d.path());
      std::sort(siblings.begin(), siblings.end());
      for (const fs::path& s : siblings) dirs.push_back((s / rel).parent_path());
    }
    for (const fs::path& dir : dirs)
      for (const char* e : kImageExts) {
        const fs::path alt = dir / full.filename().replace_extension(e);
        if (alt != full && fs::is_regular_file(alt, ec)) {
          other_format = true;
          return alt;
        }
      }
    return {};
  }

  static constexpr const char* kImageExts[] = {".exr", ".hdr", ".pfm", ".png", ".jpg", ".jpeg", ".tga", ".bmp"};
  static bool is_image_file(const std::string& path) {
    const std::string ext = lower_extension(path);
    return std::find_if(std::begin(kImageExts), std::end(kImageExts), [&](const char* e) { return ext == e; }) !=
           std::end(kImageExts);
  }

 public:
  // Reads the image maps and PLY meshes that the scene file names (not the
  // files it includes) in parallel, ahead of the translation, which takes
  // them as it meets them. A problem in the file itself is left for the
  // translation to report.
  void read_ahead() {
    std::vector<std::string> images, plys;
    try {
      Tokenizer tok = Tokenizer::from_file(path_);
      std::string directive;
      for (Token t; tok.next(t);) {
        if (!t.quoted()) {
          if (std::isupper((unsigned char)t.text.front())) directive = t.text;
          continue;
        }
        std::istringstream decl(unquote(path_, t));
        std::string type, name;
        decl >> type >> name;
        const bool image = directive == "Texture" ? name == "filename" : name == "normalmap";
        if (type != "string" || !(image || (directive == "Shape" && name == "filename"))) continue;
        Token v;
        if (!tok.next(v) || (v.is("[") && !tok.next(v))) break;
        if (!v.quoted()) continue;
        bool other_format = false;
        const fs::path found = locate_file(unquote(path_, v), other_format);
        if (found.empty()) continue;
        if (image) images.push_back(found.string());
        else if (lower_extension(found.string()) == ".ply") plys.push_back(found.string());
      }
    } catch (const InputError&) {
    }
    tbb::parallel_invoke([&] { builder_.read_images_ahead(images); },
                         [&] { plys_ahead_.run(largest_first(plys), [](const std::string& f) { return read_ply(f); }); });
  }

 private:
  static std::vector<uint32_t> checked_indices(const SourceLoc& at, const std::vector<int>& idx, size_t nv, int per) {
    if (idx.size() % size_t(per) != 0)
      throw InputError(at.file, at.line, "\"integer indices\" count " + std::to_string(idx.size()) + " is not a multiple of " + std::to_string(per));
    std::vector<uint32_t> out(idx.size());
    for (size_t k = 0; k < idx.size(); ++k) {
      if (idx[k] < 0 || size_t(idx[k]) >= nv)
        throw InputError(at.file, at.line, "index " + std::to_string(idx[k]) + " is out of range (" + std::to_string(nv) + " vertices)");
      out[k] = uint32_t(idx[k]);
    }
    // pbrt's patches: 4 per patch, kept as given; triangles as given.
    return out;
  }
  void check_counts(const SourceLoc& at, const TriangleMesh& m) const {
    if (!m.normals.empty() && m.normals.size() != m.positions.size())
      error(at, "\"normal N\" needs one normal per vertex (" + std::to_string(m.positions.size()) + ")");
    if (!m.uvs.empty() && m.uvs.size() != m.positions.size())
      error(at, "\"point2 uv\" needs one per vertex (" + std::to_string(m.positions.size()) + ")");
  }

  uint32_t current_material() {
    if (gs_.material >= 0) return uint32_t(gs_.material);
    if (default_material_ < 0) {
      MaterialDesc d;
      d.bsdf = Bsdf::make_diffuse({0.5f, 0.5f, 0.5f}, true);  // pbrt-v4's default material
      default_material_ = int32_t(builder_.add_material({}, d));
    }
    return uint32_t(default_material_);
  }

  // A light's emission `what` (rgb, a constant spectrum or blackbody; no texture), default 1.
  Color light_color(const SourceLoc& at, const ParamSet& ps, const char* what) {
    const ColorParam c = color(ps, what, {1, 1, 1}, false, false, true);
    for (int k = 0; k < 3; ++k)
      if (!(c.value[k] >= 0.f) || !std::isfinite(c.value[k]))
        throw InputError(at.file, at.line, std::string("'") + what + "' must be finite and not negative");
    return c.value;
  }

  // A colour parameter: rgb, a spectrum (a constant one, or a named metal
  // spectrum), a float (gray), blackbody (a light's: `light`), or a texture
  // of the matching kind (`is_float`: a float texture; otherwise a spectrum texture).
  ColorParam color(const ParamSet& ps, const std::string& name, Color def, bool is_float, bool texture_ok = true,
                   bool light = false) {
    ColorParam out;
    out.value = def;
    const Param* p = ps.find(name);
    if (!p) return out;
    out.given = true;
    p->used = true;
    if (p->type == "texture") {
      if (!texture_ok) ParamSet::error(*p, "a texture is not supported here");
      const std::string t = ps.get_texture(name);
      auto& table = is_float ? float_tex_ : spectrum_tex_;
      auto it = table.find(t);
      if (it == table.end()) ParamSet::error(*p, std::string("no ") + (is_float ? "float" : "spectrum") + " texture named '" + t + "'");
      out.texture = it->second.index;
      out.value = it->second.value;
      return out;
    }
    if (p->type == "rgb" || p->type == "color") {
      if (is_float) ParamSet::error(*p, "is of type '" + p->type + "', expected 'float'");
      if (p->numbers.size() != 3) ParamSet::error(*p, "expected 3 values");
      out.value = {float(p->numbers[0]), float(p->numbers[1]), float(p->numbers[2])};
    } else if (p->type == "float") {
      if (p->numbers.size() != 1) ParamSet::error(*p, "expected one value");
      const float v = float(p->numbers[0]);
      out.value = {v, v, v};
    } else if (p->type == "spectrum") {
      if (is_float) ParamSet::error(*p, "is of type 'spectrum', expected 'float'");
      if (!p->strings.empty()) {
        if (p->strings.size() != 1) ParamSet::error(*p, "expected one spectrum name");
        if (light && p->strings[0] == "stdillum-D65") {
          out.value = {1, 1, 1};  // luminance 1 (as every light below), sRGB's own white
        } else if (light || !named_metal(p->strings[0], out.value)) {
          ParamSet::error(*p, "spectrum '" + p->strings[0] + "' is not supported (" +
                                  (light ? "on lights stdillum-D65" : "named metals: metal-{Au,Ag,Cu,Al,Cr}-{eta,k}") + "; or rgb)");
        }
      } else if (light) {
        // pbrt-v4 divides every light's spectrum but RGB by its photometric
        // integral: any (λ, value) pairs emit luminance 1, in their colour.
        try {
          out.value = sampled_spectrum_rgb(p->numbers);
        } catch (const std::invalid_argument& e) {
          ParamSet::error(*p, e.what());
        }
        if (!(std::min({out.value.x, out.value.y, out.value.z}) >= 0.f)) {
          builder_.warn(p->loc, "spectrum '" + name + "' lies outside sRGB: its negative components are clamped to 0");
          out.value = vmax(out.value, Color{0, 0, 0});
        }
      } else {
        // (λ, value) pairs: only a constant spectrum has an exact RGB here.
        const auto& v = p->numbers;
        if (v.size() < 2 || v.size() % 2 != 0) ParamSet::error(*p, "a spectrum needs (wavelength, value) pairs");
        for (size_t i = 3; i < v.size(); i += 2)
          if (v[i] != v[1]) ParamSet::error(*p, "a sampled spectrum that is not constant is not supported (give rgb)");
        out.value = {float(v[1]), float(v[1]), float(v[1])};
      }
    } else if (p->type == "blackbody") {
      // pbrt-v4 normalises every light's spectrum to one nit (luminance 1):
      // a blackbody light is as bright as "rgb L [1 1 1]", in its colour.
      if (!light) ParamSet::error(*p, "a blackbody spectrum is supported on lights only");
      if (p->numbers.size() != 1) ParamSet::error(*p, "blackbody takes one temperature in kelvin");
      try {
        out.value = blackbody_rgb(p->numbers[0]);
      } catch (const std::invalid_argument& e) {
        ParamSet::error(*p, e.what());
      }
      if (!(out.value.z >= 0.f)) {
        builder_.warn(p->loc, "blackbody " + std::to_string(int(p->numbers[0])) +
                                  " K is redder than sRGB can show: its blue is clamped to 0");
        out.value.z = 0.f;
      }
    } else {
      ParamSet::error(*p, "is of type '" + p->type + "', expected 'rgb', 'spectrum' or 'texture'");
    }
    if (!is_finite(out.value)) ParamSet::error(*p, "is not finite");
    return out;
  }

  // A reflectance times `scale`: constants clamped to [0, 1] as pbrt-v4's
  // BxDFs clamp them; a texture (scaled) bound to `param`.
  Color reflectance(const SourceLoc& at, const ParamSet& ps, const char* name, Color def, BsdfParam param,
                    MaterialDesc& d, float scale = 1.f) {
    ColorParam c = color(ps, name, def, false);
    if (scale != 1.f) {
      c.value = c.value * scale;
      if (c.texture >= 0) c.texture = builder_.add_scaled_texture(at, c.texture, Color{scale, scale, scale});
    }
    if (c.texture >= 0) {
      // pbrt-v4's materials clamp a reflectance texture's value to [0, 1].
      const bool above = max_component(builder_.texture_stats(c.texture).max) > 1.f;
      if (above) builder_.warn(at, std::string("'") + name + "' texture has texels above 1: clamped to 1 where looked up");
      d.bindings.push_back({c.texture, BsdfPart::Front, param, above ? TextureMap::Clamp01 : TextureMap::Identity});
      return above ? vmin(c.value, Color{1, 1, 1}) : c.value;
    }
    Color v = c.value;
    for (int k = 0; k < 3; ++k) v[k] = std::clamp(v[k], 0.f, 1.f);
    if (!same(v, c.value)) builder_.warn(at, std::string("'") + name + "' clamped to [0, 1]");
    return v;
  }
  // pbrt's roughness: `roughness`, or uroughness / vroughness, remapped to
  // the GGX alpha by sqrt unless remaproughness is false (pbrt-v4's
  // TrowbridgeReitzDistribution::RoughnessToAlpha). Textures are refused.
  // pbrt's roughness, uroughness and vroughness (under `prefix`) as the
  // microfacet alphas: constants, or float textures bound to AlphaU / AlphaV
  // (`textured`: then the constants are their means), through pbrt-v4's
  // RoughnessToAlpha (sqrt, at each lookup) unless remaproughness is false.
  struct Roughness {
    float au = 0.f, av = 0.f;
    int32_t tu = -1, tv = -1;
    TextureMap map = TextureMap::Identity;
    bool textured() const { return tu >= 0 || tv >= 0; }
    void bind(MaterialDesc& d) const {
      if (tu >= 0) d.bindings.push_back({tu, BsdfPart::Front, BsdfParam::AlphaU, map});
      if (tv >= 0) d.bindings.push_back({tv, BsdfPart::Front, BsdfParam::AlphaV, map});
    }
  };
  Roughness roughness(const SourceLoc& at, const ParamSet& ps, const std::string& prefix) {
    const ColorParam r = color(ps, prefix + "roughness", {0, 0, 0}, true);
    ColorParam u = color(ps, prefix + "uroughness", {0, 0, 0}, true), v = color(ps, prefix + "vroughness", {0, 0, 0}, true);
    if (!u.given) u = r;
    if (!v.given) v = r;
    for (const ColorParam* c : {&u, &v})
      if (!(c->value.x >= 0.f) || !std::isfinite(c->value.x)) error(at, "roughness must be finite and not negative");
    Roughness out;
    const bool remap = ps.get_bool("remaproughness", true);
    out.map = remap ? TextureMap::Sqrt : TextureMap::Identity;
    out.tu = u.texture, out.tv = v.texture;
    out.au = remap ? std::sqrt(u.value.x) : u.value.x;
    out.av = remap ? std::sqrt(v.value.x) : v.value.x;
    return out;
  }
  // pbrt-v4's EffectivelySmooth: alpha below 1e-3 is a perfect specular.
  static bool smooth(float au, float av) { return std::max(au, av) < 1e-3f; }
  float eta_param(const SourceLoc& at, const ParamSet& ps, const std::string& name, float def) {
    const Param* p = ps.find(name);
    if (!p) return def;
    p->used = true;
    float eta = def;
    if (p->type == "float") {
      eta = float(ps.get_float(name, def));
    } else if (p->type == "spectrum" && p->strings.size() == 1) {
      bool found = false;
      for (const NamedGlass& g : kGlasses)
        if (p->strings[0] == g.name) eta = g.eta, found = true;
      if (!found) ParamSet::error(*p, "spectrum '" + p->strings[0] + "' is not supported (glass-BK7, glass-BAF10, ...; or a float)");
      warn_once(at, "dispersion", "a spectral eta is rendered without dispersion (its index at 587.6 nm)");
    } else if (p->type == "texture") {
      ParamSet::error(*p, "a textured eta is not supported");
    } else {
      ParamSet::error(*p, "is of type '" + p->type + "', expected 'float' or a named 'spectrum'");
    }
    if (!(eta >= 0.1f && eta <= 10.f)) ParamSet::error(*p, "must lie in [0.1, 10] (an index of refraction)");
    return eta;
  }
  // Conductor eta and k (default: pbrt's metal-Cu), or `reflectance` (pbrt-v4
  // then takes eta = 1 and k = 2 √r / √(1 − r), which gives that normal reflectance).
  void conductor_ior(const SourceLoc& at, const ParamSet& ps, const std::string& prefix, Color& eta, Color& k,
                     MaterialDesc& d) {
    const std::string ne = prefix + "eta", nk = prefix + "k", nr = prefix + "reflectance";
    if (ps.has(nr)) {
      if (ps.has(ne) || ps.has(nk)) error(at, "give either '" + nr + "' or '" + ne + "' and '" + nk + "'");
      const ColorParam r = color(ps, nr, {1, 1, 1}, false, false);
      eta = {1, 1, 1};
      for (int c = 0; c < 3; ++c) {
        const float rc = std::clamp(r.value[c], 0.f, 0.9999f);
        k[c] = 2 * std::sqrt(rc) / std::sqrt(1 - rc);
      }
      return;
    }
    Color cu_eta, cu_k;
    find_conductor_preset("Cu", cu_eta, cu_k);
    const ColorParam e = color(ps, ne, cu_eta, false), kk = color(ps, nk, cu_k, false);
    if (e.texture >= 0) d.bindings.push_back({e.texture, BsdfPart::Front, BsdfParam::Eta});
    if (kk.texture >= 0) d.bindings.push_back({kk.texture, BsdfPart::Front, BsdfParam::K});
    eta = e.value, k = kk.value;
    for (int c = 0; c < 3; ++c)
      if (eta[c] < 0.f || k[c] < 0.f) error(at, "conductor eta and k must not be negative");
  }

  NamedMaterial make_material(const SourceLoc& at, const std::string& type, ParamSet ps) {
    NamedMaterial out;
    MaterialDesc& d = out.desc;
    if (type == "interface") {
      out.interface = true;
      done(ps);
      out.index = current_material();
      return out;
    }
    // Shared by every material: a normal map, or else displacement, pbrt-v4's
    // bump mapping (BumpMap: the shading point moved along the shading
    // normal by the float texture's value), which is Luz's bump map of that
    // texture at scale 1 (SceneView::shading_frame): its gradient taken
    // exactly where pbrt takes a finite difference, and without pbrt's term
    // displacement · dn/du, zero on flat faces. A constant displacement has
    // no gradient: nothing to render.
    const std::string normalmap = ps.get_string("normalmap", "");
    const ColorParam displacement = color(ps, "displacement", {0, 0, 0}, true);
    if (!normalmap.empty()) {
      ImageTextureDesc nd;
      nd.path = find_file(at, normalmap, "normal map");
      nd.srgb = false;  // pbrt-v4 reads normal maps linearly
      nd.to_uv = {1, 0, 0, 0, 1, 0};
      d.normal_map = builder_.add_image_texture(at, nd);
      if (displacement.texture >= 0)
        builder_.warn(at, "displacement is ignored: the material has a normalmap, which pbrt-v4 uses instead");
    } else if (displacement.texture >= 0) {
      if (builder_.scene().textures[size_t(displacement.texture)].type == TextureType::Mix) {
        builder_.warn(at, "displacement by a mix or scale of textures is not rendered (Luz takes the gradient "
                          "of image textures only)");
      } else {
        d.bump_map = displacement.texture;
        d.bump_scale = 1.f;
      }
    }
    if (type == "diffuse") {
      d.bsdf = Bsdf::make_diffuse(reflectance(at, ps, "reflectance", {0.5f, 0.5f, 0.5f}, BsdfParam::Reflectance, d), true);
    } else if (type == "conductor" || type == "coatedconductor") {
      // coatedconductor: Luz has no layered conductor; the conductor below
      // the coat is rendered bare, without the coat's reflection, absorption
      // and the darkening of refraction through it.
      const std::string pre = type == "conductor" ? "" : "conductor.";
      Color eta, k;
      conductor_ior(at, ps, pre, eta, k, d);
      const Roughness rough = roughness(at, ps, pre);
      if (type == "coatedconductor") {
        for (const char* n : {"interface.roughness", "interface.uroughness", "interface.vroughness", "interface.eta",
                              "thickness", "albedo", "g", "maxdepth", "nsamples"})
          if (const Param* p = ps.find(n)) p->used = true;
        builder_.warn(at, "coatedconductor is rendered as its bare conductor (Luz has no coated conductor): the "
                          "coat's reflection and absorption are missing");
      }
      if (!rough.textured() && smooth(rough.au, rough.av)) {
        d.bsdf = Bsdf::make_smooth_conductor(eta, k, {1, 1, 1}, true);
      } else {
        d.bsdf = Bsdf::make_rough_conductor(MicrofacetType::GGX, rough.au, rough.av, eta, k, {1, 1, 1}, true);
        rough.bind(d);
      }
    } else if (type == "dielectric" || type == "thindielectric") {
      const float eta = eta_param(at, ps, "eta", 1.5f);
      if (type == "thindielectric") {
        d.bsdf = Bsdf::make_thin_dielectric(eta, 1.f);
      } else {
        const Roughness rough = roughness(at, ps, "");
        if (!rough.textured() && smooth(rough.au, rough.av)) {
          d.bsdf = Bsdf::make_smooth_dielectric(eta, 1.f);
        } else {
          if (eta == 1.f) error(at, "a rough dielectric with eta 1 is not supported (nothing would refract)");
          d.bsdf = Bsdf::make_rough_dielectric(MicrofacetType::GGX, rough.au, rough.av, eta, 1.f);
          rough.bind(d);
        }
      }
    } else if (type == "coateddiffuse") {
      // Nearest Luz model: rough plastic (Mitsuba's roughplastic, nonlinear:
      // internal reflections in the coat saturate the colour). pbrt-v4's
      // coateddiffuse simulates the layer stochastically (every bounce
      // between coat and base, the base seen through the rough interface);
      // roughplastic adds a GGX coat lobe to a diffuse base seen through a
      // smooth interface's Fresnel terms. They agree for smooth coats and
      // differ by a few percent at grazing angles for rough ones. The coat's
      // medium (albedo, g, thickness) is not rendered.
      const Color kd = reflectance(at, ps, "reflectance", {0.5f, 0.5f, 0.5f}, BsdfParam::DiffuseReflectance, d);
      const Roughness rough = roughness(at, ps, "");
      // Rough plastic tabulates its coat's internal reflection per alpha.
      if (rough.textured()) error(at, "a textured coateddiffuse roughness is not supported");
      const float au = rough.au, av = rough.av;
      const float eta = eta_param(at, ps, "eta", 1.5f);
      const ColorParam albedo = color(ps, "albedo", {0, 0, 0}, false, false);
      if (max_component(albedo.value) > 0.f) builder_.warn(at, "coateddiffuse 'albedo' (a medium in the coat) is ignored");
      ps.get_float("thickness", 0.01), ps.get_float("g", 0), ps.get_int("maxdepth", 10), ps.get_int("nsamples", 1);
      if (eta == 1.f) error(at, "coateddiffuse with eta 1 is not supported");
      if (au != av) builder_.warn(at, "anisotropic coateddiffuse roughness is rendered isotropic (the mean alpha)");
      const float a = 0.5f * (au + av);
      d.bsdf = smooth(au, av) ? Bsdf::make_smooth_plastic(kd, {1, 1, 1}, eta, 1.f, true, true)
                              : Bsdf::make_rough_plastic(MicrofacetType::GGX, a, kd, {1, 1, 1}, eta, 1.f, true, true);
    } else if (type == "diffusetransmission") {
      // pbrt-v4: R = clamp(scale reflectance, 0, 1), T = clamp(scale transmittance, 0, 1).
      const float scale = ps.get_float("scale", 1);
      if (!(scale >= 0.f) || !std::isfinite(scale)) error(at, "diffusetransmission 'scale' must be a finite number ≥ 0");
      const Color r = reflectance(at, ps, "reflectance", {0.25f, 0.25f, 0.25f}, BsdfParam::Reflectance, d, scale);
      const Color t = reflectance(at, ps, "transmittance", {0.25f, 0.25f, 0.25f}, BsdfParam::Transmittance, d, scale);
      d.bsdf = Bsdf::make_diffuse_transmission(r, t);
    } else if (type == "mix") {
      // pbrt-v4 picks one of the two per hit (stochastically by amount):
      // in expectation Luz's blend, (1 − amount) first + amount second.
      const std::vector<std::string> names = ps.get_strings("materials");
      if (names.size() != 2) error(at, "mix needs \"string materials\" with two names");
      const NamedMaterial* m[2];
      for (int i = 0; i < 2; ++i) {
        auto it = named_.find(names[size_t(i)]);
        if (it == named_.end()) error(at, "mix: no material named '" + names[size_t(i)] + "'");
        m[i] = &it->second;
        if (m[i]->interface) error(at, "mix with an 'interface' material is not supported");
        if (m[i]->desc.bsdf.blend) error(at, "a mix of mixes is not supported");
        if (m[i]->desc.has_map() || m[i]->desc.masked()) error(at, "a mix of normal-mapped materials is not supported");
      }
      if (m[0]->desc.bsdf.two_sided != m[1]->desc.bsdf.two_sided)
        error(at, "a mix of a transmissive and a reflective material is not supported");
      const ColorParam w = color(ps, "amount", {0.5f, 0.5f, 0.5f}, true);
      if (!(w.value.x >= 0.f && w.value.x <= 1.f)) error(at, "mix amount must lie in [0, 1]");
      if (w.texture >= 0 && max_component(builder_.texture_stats(w.texture).max) > 1.f)
        error(at, "mix amount texture has texels above 1");
      d.bsdf = Bsdf::make_blend(m[0]->desc.bsdf, m[1]->desc.bsdf, luminance(w.value));
      d.bindings = m[0]->desc.bindings;
      for (TextureBinding b : m[1]->desc.bindings) {
        b.part = BsdfPart::Second;
        d.bindings.push_back(b);
      }
      if (w.texture >= 0) d.bindings.push_back({w.texture, BsdfPart::BlendWeight, BsdfParam::Reflectance});
    } else {
      error(at, "material '" + type + "' is not supported (diffuse, conductor, dielectric, thindielectric, "
                "coateddiffuse, coatedconductor, diffusetransmission, mix, interface)");
    }
    done(ps);
    out.index = builder_.add_material(at, d);
    return out;
  }

  // The camera and film, once both are known (at WorldBegin).
  void make_camera() {
    if (camera_made_) return;
    camera_made_ = true;
    ParamSet& fp = film_params_;
    const int w = fp.get_int("xresolution", 1280), h = fp.get_int("yresolution", 720);
    if (w < 1 || h < 1 || w > 65536 || h > 65536) error(film_loc_, "film resolution must be between 1 and 65536");
    // The pixels rendered, [x0, x1) × [y0, y1), as pbrt-v4's film finds
    // them: pixelbounds, or a cropwindow in film fractions (ceil of each
    // times the resolution; the cropwindow wins when both are given).
    long bounds[4] = {0, w, 0, h};
    const bool has_crop = fp.has("cropwindow"), has_pixels = fp.has("pixelbounds");
    if (has_crop) {
      const std::vector<double> c = fp.get_floats("cropwindow");
      if (c.size() != 4 || !(0 <= c[0] && c[0] < c[1] && c[1] <= 1 && 0 <= c[2] && c[2] < c[3] && c[3] <= 1))
        error(film_loc_, "cropwindow needs 4 numbers x0 x1 y0 y1 with 0 ≤ x0 < x1 ≤ 1 and 0 ≤ y0 < y1 ≤ 1");
      for (int k = 0; k < 4; ++k) bounds[k] = long(std::ceil((k < 2 ? w : h) * c[size_t(k)]));
      if (has_pixels) {
        fp.get_ints("pixelbounds");
        builder_.warn(film_loc_, "both cropwindow and pixelbounds given: the cropwindow is used (as pbrt-v4 does)");
      }
    } else if (has_pixels) {
      const std::vector<int> b = fp.get_ints("pixelbounds");
      if (b.size() != 4) error(film_loc_, "pixelbounds needs 4 integers x0 x1 y0 y1");
      // Beyond the film: clamped to it with a warning, as pbrt-v4.
      const long c[4] = {std::clamp<long>(b[0], 0, w), std::clamp<long>(b[1], 0, w), std::clamp<long>(b[2], 0, h),
                         std::clamp<long>(b[3], 0, h)};
      if (!(c[0] < c[1] && c[2] < c[3]))
        error(film_loc_, "pixelbounds [" + std::to_string(b[0]) + ", " + std::to_string(b[1]) + ") × [" + std::to_string(b[2]) +
                             ", " + std::to_string(b[3]) + ") holds no pixel of the " + std::to_string(w) + "×" +
                             std::to_string(h) + " film");
      if (!std::equal(c, c + 4, b.begin()))
        builder_.warn(film_loc_, "pixelbounds extends beyond the " + std::to_string(w) + "×" + std::to_string(h) +
                                     " film: clamped to it");
      std::copy(c, c + 4, bounds);
    }
    fp.get_string("filename", "");  // Luz names its output on the command line (-o)
    fp.get_bool("savefp16", true);
    fp.get_float("diagonal", 35);
    const std::string sensor = fp.get_string("sensor", "cie1931");
    if (sensor != "cie1931") error(film_loc_, "film sensor '" + sensor + "' is not supported (cie1931)");
    if (fp.get_float("iso", 100) != 100 || fp.get_float("exposuretime", 1) != 1 || fp.get_float("whitebalance", 0) != 0)
      error(film_loc_, "film iso, exposuretime and whitebalance other than the defaults are not supported");
    if (std::isfinite(fp.get_float("maxcomponentvalue", INFINITY)))
      builder_.warn(film_loc_, "film maxcomponentvalue (clamping) is not supported: samples are not clamped");
    done(fp);

    Camera cam;
    cam.width = w;
    cam.height = h;
    const SourceLoc& at = camera_loc_;
    if (!camera_given_) {
      // pbrt-v4's default: perspective, fov 90, at the origin looking down +z.
      camera_type_ = "perspective";
    }
    ParamSet& ps = camera_params_;
    const double aspect = ps.get_float("frameaspectratio", double(w) / h);
    double sw[4] = {-aspect, aspect, -1, 1};
    if (aspect < 1) sw[0] = -1, sw[1] = 1, sw[2] = -1 / aspect, sw[3] = 1 / aspect;
    if (ps.has("screenwindow")) {
      const std::vector<double> v = ps.get_floats("screenwindow");
      if (v.size() != 4 || !(v[1] > v[0]) || !(v[3] > v[2])) error(at, "screenwindow needs xmin < xmax, ymin < ymax");
      std::copy(v.begin(), v.end(), sw);
    }
    ps.get_float("shutteropen", 0), ps.get_float("shutterclose", 1);
    double t = 1;  // film extent per screen unit, on the plane z = 1 (orthographic: camera units)
    if (camera_type_ == "perspective") {
      const double fov = ps.get_float("fov", 90);
      if (!(fov > 0 && fov < 180)) error(at, "fov must be in (0, 180) degrees");
      t = std::tan(fov * M_PI / 360);
      const double lr = ps.get_float("lensradius", 0), fd = ps.get_float("focaldistance", 1e6);
      if (!(lr >= 0) || !(fd > 0)) error(at, "need lensradius ≥ 0 and focaldistance > 0");
      cam.type = lr > 0 ? CameraType::ThinLens : CameraType::Perspective;
      cam.lens.aperture_radius = float(lr);
      cam.lens.focus_distance = float(fd);
    } else if (camera_type_ == "orthographic") {
      cam.type = CameraType::Orthographic;
      if (ps.get_float("lensradius", 0) != 0) error(at, "an orthographic camera with a lens is not supported");
      ps.get_float("focaldistance", 1e6);
    } else {
      error(at, "camera '" + camera_type_ + "' is not supported (perspective, orthographic)");
    }
    done(ps);
    // Screen window [x0, x1] × [y0, y1] (pbrt: +x right, +y up) onto Luz's
    // film: half extents and the left / top edges (Luz's x is pbrt's −x).
    cam.tan_half_x = float((sw[1] - sw[0]) * t / 2);
    cam.tan_half_y = float((sw[3] - sw[2]) * t / 2);
    cam.edge_x = float(-2 * sw[0] / (sw[1] - sw[0]));
    cam.edge_y = float(2 * sw[3] / (sw[3] - sw[2]));
    Matrix4 c2w;
    if (!invert(camera_from_world_, c2w)) error(at, "the camera's transform is singular");
    const Vec3 x = c2w.vector({1, 0, 0}), y = c2w.vector({0, 1, 0}), z = c2w.vector({0, 0, 1});
    if (!(length(x) > 0.f) || !(length(y) > 0.f) || !(length(z) > 0.f)) error(at, "the camera's transform is degenerate");
    cam.origin = c2w.point({0, 0, 0});
    if (cam.type == CameraType::Orthographic) {
      cam.x_axis = -x;  // the scale of the view kept (orthographic.h)
      cam.y_axis = y;
    } else {
      cam.x_axis = -normalize(x);
      cam.y_axis = normalize(y);
    }
    cam.z_axis = normalize(z);
    // pbrt's fov is along the shorter side (what a new resolution keeps);
    // an explicit screen window keeps its width.
    builder_.set_camera(at, cam, ps.has("screenwindow") ? FovAxis::X : FovAxis::Smaller);
    if (has_crop || has_pixels) builder_.crop_camera(film_loc_, bounds[0], bounds[1], bounds[2], bounds[3]);
  }

  std::string path_;
  fs::path search_dir_;
  SceneBuilder builder_;
  ReadAhead<PlyMesh> plys_ahead_;
  GraphicsState gs_;
  std::vector<Saved> stack_;
  std::map<std::string, Matrix4> named_coords_;
  std::map<std::string, NamedMaterial> named_;
  std::map<std::string, TexValue> float_tex_, spectrum_tex_;
  std::map<std::string, uint32_t> objects_;
  std::set<std::string> media_, warned_;
  int32_t object_ = -1;
  int32_t default_material_ = -1;
  bool in_world_ = false, camera_given_ = false, camera_made_ = false;
  std::string camera_type_ = "perspective";
  SourceLoc camera_loc_, film_loc_;
  ParamSet camera_params_, film_params_;
  Matrix4 camera_from_world_;
};

}  // namespace
}  // namespace pbrt

Scene load_pbrt(const std::string& path) {
  pbrt::PbrtScene scene(path);
  scene.read_ahead();
  pbrt::parse_file(path, scene);
  return scene.finish();
}

}  // namespace luz
