// Mitsuba XML scenes (Mitsuba 3, and 0.5/0.6 with camelCase names): the
// parser, one class whose parts live one file per plugin family:
//   xml.cpp       reading, <default>/$params, <include>, Props, transforms,
//                 names (camelCase upgrade), errors
//   sensor.cpp    integrator, sensor, sampler, film
//   bsdfs.cpp     bsdfs and their parameters
//   textures.cpp  textures, and the files a scene names (-a search folders)
//   emitters.cpp  top-level emitters
//   shapes.cpp    shapes, their area emitters, shapegroup and instance
// Supported: integrators path, bsdf, light (volpath, volpathmis and direct
// as path; others as path with a warning); sensors perspective, thinlens,
// orthographic; samplers independent, stratified, sobol/ldsampler; hdrfilm
// and ldrfilm with box, tent and gaussian rfilters; shapes obj, ply,
// serialized, rectangle, cube, disk, cylinder, sphere, shapegroup, instance;
// emitters area, constant, envmap, point, spot, directional; bsdfs diffuse,
// phong, blinnphong, conductor, roughconductor, dielectric, roughdielectric,
// thindielectric, plastic, roughplastic, ward, principled, principledthin,
// coating, blendbsdf, twosided, mask, normalmap, bumpmap; textures bitmap and checkerboard; <ref> to
// bsdfs, textures and shapegroups. Anything else is an error naming file and
// line: a renderer that silently ignores what it does not know renders the
// wrong image.
//
// Names of Mitsuba 0.5/0.6 are upgraded as Mitsuba 3's own upgrade does
// (camel_case_name: every parameter name, toWorld -> to_world, intIOR ->
// int_ior); the exceptions it also makes are the <lookAt> tag and a
// texture's uscale/vscale/uoffset/voffset (textures.cpp). The 0.5/0.6 names
// of the parameters Luz reads all follow the rule (alphaU -> alpha_u,
// shapeIndex -> shape_index, emitterSamples -> emitter_samples, sigmaA ->
// sigma_a, maxSmoothAngle -> max_smooth_angle): no table of exceptions.
#pragma once

#include <pugixml.hpp>

#include <filesystem>
#include <initializer_list>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "luz/io/error.h"
#include "luz/io/load.h"
#include "luz/io/mesh_obj.h"
#include "luz/io/mesh_ply.h"
#include "luz/io/read_ahead.h"
#include "luz/math/transform.h"
#include "luz/scene/scene_builder.h"

namespace luz::mitsuba {

namespace fs = std::filesystem;

// A bsdf as parsed: the BSDF with its constant parameters and the textures
// that drive the others (a textured parameter holds the texture's mean).
using ParsedBsdf = MaterialDesc;

class MitsubaParser {
 public:
  MitsubaParser(const std::string& path, const Defines& defines, std::vector<std::string> search_paths = {})
      : path_(path), defines_(defines), search_paths_(std::move(search_paths)) {}
  Scene parse();

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

    Props(const MitsubaParser* parser, pugi::xml_node node);
    pugi::xml_node get(const std::string& name, std::initializer_list<const char*> types);
    double get_float(const std::string& name, double def);
    // An integer in [lo, hi] (the message states the range).
    long get_int(const std::string& name, long def, long lo = -2000000000, long hi = 2000000000);
    bool get_bool(const std::string& name, bool def);
    std::string get_string(const std::string& name, const std::string& def);
    Color get_color(const std::string& name, Color def);
    Vec3 get_point(const std::string& name, Vec3 def);
    Matrix4 get_transform(const std::string& name);
    bool has(const std::string& name) const { return by_name.count(name) > 0; }
    // Any parameter nobody asked for is an error.
    void check_all_used() const;
  };

 private:
  // ---- errors and positions (xml.cpp) ----
  int line_at(size_t offset) const;
  int line(pugi::xml_node n) const { return line_at(size_t(n.offset_debug())); }
  [[noreturn]] void error(pugi::xml_node n, const std::string& msg) const { throw InputError(path_, line(n), msg); }
  SourceLoc loc(pugi::xml_node n) const { return {path_, line(n)}; }

  // ---- names, attributes, numbers, transforms (xml.cpp) ----
  // Mitsuba 3's upgrade of a 0.5/0.6 name (toWorld -> to_world).
  static std::string camel_case_name(const std::string& name);
  // A parameter's name as Luz knows it (Mitsuba 3's).
  std::string param_name(pugi::xml_node n) const;
  // Attribute with $parameter substitution.
  std::string attr(pugi::xml_node n, const char* name, bool required = true) const;
  double number(pugi::xml_node n, const std::string& s) const;
  std::vector<double> numbers(pugi::xml_node n, const std::string& s) const;
  Vec3 vec3_attr(pugi::xml_node n, const char* name) const;
  // Mitsuba 0.5's <srgb>: "#rrggbb" or 1 or 3 numbers in [0, 1], sRGB-encoded,
  // decoded to linear RGB (Mitsuba 3 has no such tag).
  Color srgb_color(pugi::xml_node n, const std::string& v) const;
  // Nested plugin children (everything that is not a property).
  void check_children(pugi::xml_node n, std::initializer_list<const char*> allowed) const;
  Matrix4 parse_transform(pugi::xml_node t) const;

  // ---- integrator, sensor, sampler, film (sensor.cpp) ----
  void parse_integrator(pugi::xml_node n);
  void parse_sensor(pugi::xml_node n);
  void parse_sampler(pugi::xml_node n);
  // The film's size, and its crop window (x0, x1, y0, y1) in pixels.
  void parse_film(pugi::xml_node n, int& width, int& height, long crop[4]);

  // ---- bsdfs (bsdfs.cpp) ----
  Color checked_reflectance(pugi::xml_node n, Props& p, const char* name, Color def);
  MicrofacetType distribution(pugi::xml_node n, Props& p);
  // Mitsuba 3: `alpha` (isotropic), or `alpha_u` and `alpha_v`; default 0.1.
  // Textures may drive them (bound to AlphaU / AlphaV in *tb; their zero
  // texels act as the microfacet models' least roughness, 1e-4) unless tb is
  // null: then a texture is an error.
  void roughness(pugi::xml_node n, Props& p, float& au, float& av, std::vector<TextureBinding>* tb);
  // An index of refraction: a number or one of Mitsuba's named presets.
  float ior(pugi::xml_node n, Props& p, const char* name, const char* def);
  // Conductor: `material` preset, or `eta` and `k` (Mitsuba 3: default
  // material "none", the perfect mirror; eta defaults to 0 and k to 1 when
  // only one is given).
  void conductor_ior(pugi::xml_node n, Props& p, Color& eta, Color& k, std::vector<TextureBinding>& tb);
  uint32_t add_material(pugi::xml_node n, const ParsedBsdf& b) { return builder_.add_material(loc(n), b); }
  // One bsdf element (or a <ref> to one) nested in another.
  ParsedBsdf nested_bsdf(pugi::xml_node c);
  // The bsdfs nested in n (<ref>s to textures are parameters, not bsdfs).
  std::vector<pugi::xml_node> nested_bsdf_nodes(pugi::xml_node n);
  // Moves bindings of one part to another (a nested bsdf becoming a blend's
  // second or a two-sided back).
  static void move_part(std::vector<TextureBinding>& b, BsdfPart from, BsdfPart to);
  ParsedBsdf parse_bsdf_element(pugi::xml_node n);
  ParsedBsdf parse_coating(pugi::xml_node n);
  // Mitsuba 3's principled, or principledthin where `thin`.
  Bsdf principled(pugi::xml_node n, Props& p, std::vector<TextureBinding>& tb, bool thin);
  // A bsdf element as a value; one with an id becomes a material that <ref>s
  // name, nested ones too (as in Mitsuba, where the staircase's bumpmap
  // wraps the bsdf its shapes refer to).
  ParsedBsdf parse_bsdf_value(pugi::xml_node n);
  uint32_t parse_bsdf(pugi::xml_node n);
  // A colour parameter of a bsdf: a constant (a reflectance checked to lie
  // in [0, 1]), or a texture, bound to `param` of the front part, whose mean
  // is returned (what the models' lobe sampling weights use, as Mitsuba's
  // mean()); a reflectance's texels must not exceed 1.
  Color color_param(pugi::xml_node n, Props& p, const char* name, Color def, BsdfParam param, bool is_reflectance,
                    std::vector<TextureBinding>& tb);
  // A float parameter: a number, or a texture (its luminance, Mitsuba's
  // eval_1) bound to each of `params` of the front part; returns the
  // number, or the texture's mean luminance.
  float float_param(Props& p, const char* name, float def, std::initializer_list<BsdfParam> params,
                    std::vector<TextureBinding>& tb);
  // A float in [0, 1] (a mask's opacity, a blend's weight): a number, or a
  // texture (`texture` set; its mean luminance returned) whose texels do not
  // exceed 1.
  float unit_param(pugi::xml_node n, Props& p, const char* plugin, const char* name, float def, int32_t& texture);
  // A colour parameter's greatest value: its texture's maximum when bound, else v.
  Color texture_max(const std::vector<TextureBinding>& tb, BsdfParam param, Color v) const;
  uint32_t resolve_ref(pugi::xml_node r);

  // ---- textures and files (textures.cpp) ----
  // A texture's to_uv (Mitsuba 3: the upper-left 3×3 of the transform, an
  // affine map of uv) or Mitsuba 0.5's uscale, vscale, uoffset, voffset.
  UvTransform uv_transform(pugi::xml_node t, Props& p);
  // A <texture>: `bitmap` (filename relative to the scene file; filter_type,
  // wrap_mode, raw (Mitsuba 3) or gamma (Mitsuba 0.5), to_uv) or
  // `checkerboard` (color0, color1, to_uv). Returns its index in
  // the scene's textures; with load = false the texture is only checked (the file
  // must exist) and -1 returned.
  // Why texture t may exceed 1: its texels, or vertex colours times a scale above 1.
  std::string above_one(int32_t t) const;
  int32_t parse_texture(pugi::xml_node t, bool load);
  // A <ref> naming a top-level texture (a parameter), not a bsdf.
  bool is_texture_ref(pugi::xml_node c) const;
  // Parameter `name` given as a texture (nested, or a <ref> to a top-level
  // one): its index, or -1 when the parameter is absent or a constant.
  int32_t texture_param(Props& p, const char* name, bool load = true);

  // ---- emitters (emitters.cpp) ----
  // Top-level emitters: `constant` (an environment), and the delta lights
  // `point`, `spot` and `directional`.
  void parse_emitter(pugi::xml_node n);
  // An equirectangular environment map: filename (relative to the scene
  // file; OpenEXR, Radiance HDR, PFM, or 8-bit sRGB), scale, to_world.
  void parse_envmap(pugi::xml_node n, Props& p);

  // A file the scene names, as Mitsuba's file resolver finds it: relative
  // to the file being read, then in each search folder (-a); it must be a
  // regular file.
  fs::path resolve_file(pugi::xml_node n, const std::string& file, const char* what) const;
  // A mesh file; a missing .obj is replaced by a .ply of the same name where
  // one is found (Bitterli's scenes ship both forms): `replaced` says so.
  fs::path mesh_file(pugi::xml_node n, const std::string& file, const std::string& type, bool& replaced) const;
  // Reads the bitmaps and OBJ and PLY meshes that the scene file names (not
  // its included files) in parallel, ahead of the translation, which takes
  // them as it meets them. A problem in the file itself is left for the
  // translation to report.
  void read_ahead(pugi::xml_node root);
  // <include filename="...">: the file's elements as if written here.
  void parse_include(pugi::xml_node n);
  void parse_top_level(pugi::xml_node parent);
  bool scene_version_legacy(pugi::xml_node root);

  // ---- shapes (shapes.cpp) ----
  void parse_shape(pugi::xml_node n);
  void parse_shapegroup(pugi::xml_node n);
  void parse_instance(pugi::xml_node n);
  void add_shape(pugi::xml_node n, int64_t object);
  void read_mesh_ply(const fs::path& full, bool flip_uv, bool textured, bool colored, bool face_colored,
                     std::vector<Vec3>& pos, std::vector<Vec3>& nrm, std::vector<Vec2>& uv, std::vector<Color>& col,
                     std::vector<uint32_t>& idx);

  std::string path_;
  Defines defines_;
  Defines params_;
  std::string text_;
  pugi::xml_document doc_;
  std::map<std::string, uint32_t> bsdfs_;
  std::map<std::string, uint32_t> textures_;  // top-level <texture id>, by id
  std::set<int32_t> face_color_textures_;      // mesh_attribute face_color (the others: vertex_color)
  // Which colours material m reads: 1 vertex_color, 2 face_color (a bit each).
  int colour_attributes(uint32_t m) const;
  std::map<std::string, uint32_t> shapegroups_;  // the builder's objects, by id
  std::map<std::string, std::vector<uint8_t>> serialized_files_;  // by path
  ReadAhead<std::shared_ptr<const ObjFile>> objs_ahead_;
  ReadAhead<PlyMesh> plys_ahead_;
  std::vector<std::string> search_paths_;
  std::vector<std::unique_ptr<pugi::xml_document>> included_;  // kept: nodes point into them
  std::vector<std::string> include_stack_;  // files being read, outermost first
  bool have_sensor_ = false, have_integrator_ = false;
  SceneBuilder builder_{path_};
  bool legacy_names_ = false;  // a Mitsuba 0.5/0.6 scene: camelCase parameter names
  int bsdf_depth_ = 0;
  static constexpr int kMaxBsdfNesting = 32;
};

}  // namespace luz::mitsuba
