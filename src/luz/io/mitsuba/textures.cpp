// The Mitsuba reader's textures (bitmap, checkerboard, mesh_attribute) and the files a scene
// names (see parser.h).
#include <cmath>

#include <tbb/parallel_invoke.h>

#include "luz/io/image.h"
#include "luz/io/mitsuba/parser.h"

namespace luz::mitsuba {

fs::path MitsubaParser::resolve_file(pugi::xml_node n, const std::string& file, const char* what) const {
  const fs::path full = fs::path(path_).parent_path() / file;
  std::error_code ec;
  if (fs::is_regular_file(full, ec)) return full;
  if (fs::path(file).is_relative())
    for (const std::string& dir : search_paths_)
      if (fs::is_regular_file(fs::path(dir) / file, ec)) return fs::path(dir) / file;
  error(n, std::string("cannot open ") + what + " '" + full.string() +
               "': " + (fs::exists(full, ec) ? "not a regular file" : "no such file"));
}

fs::path MitsubaParser::mesh_file(pugi::xml_node n, const std::string& file, const std::string& type,
                                  bool& replaced) const {
  const std::string what = (type == "obj" ? "OBJ" : type == "ply" ? "PLY" : type) + " file";
  const std::string ext = lower_extension(file);
  if (type == "obj" && ext == ".obj") {
    try {
      return resolve_file(n, file, what.c_str());
    } catch (const InputError&) {
      const fs::path ply = fs::path(file).replace_extension(".ply");
      try {
        const fs::path full = resolve_file(n, ply.string(), what.c_str());
        replaced = true;
        return full;
      } catch (const InputError&) {
      }
      throw;
    }
  }
  return resolve_file(n, file, what.c_str());
}

void MitsubaParser::read_ahead(pugi::xml_node root) {
  std::vector<std::string> images, objs, plys;
  std::vector<pugi::xml_node> stack{root};
  while (!stack.empty()) {
    const pugi::xml_node n = stack.back();
    stack.pop_back();
    for (pugi::xml_node c = n.last_child(); c; c = c.previous_sibling())
      if (c.type() == pugi::node_element) stack.push_back(c);
    const std::string tag = n.name(), type = n.attribute("type").value();
    const bool bitmap = tag == "texture" && type == "bitmap";
    if (!bitmap && !(tag == "shape" && (type == "obj" || type == "ply"))) continue;
    for (pugi::xml_node c : n.children("string")) {
      if (std::string(c.attribute("name").value()) != "filename") continue;
      try {
        const std::string file = attr(c, "value");
        bool replaced = false;
        const fs::path full = bitmap ? resolve_file(c, file, "bitmap") : mesh_file(c, file, type, replaced);
        (bitmap ? images : type == "obj" && full.extension() != ".ply" ? objs : plys).push_back(full.string());
      } catch (const InputError&) {
      }
    }
  }
  tbb::parallel_invoke([&] { builder_.read_images_ahead(images); },
                       [&] { objs_ahead_.run(largest_first(objs), read_obj_file); },
                       [&] { plys_ahead_.run(largest_first(plys), [](const std::string& f) { return read_ply(f); }); });
}

UvTransform MitsubaParser::uv_transform(pugi::xml_node t, Props& p) {
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

int32_t MitsubaParser::parse_texture(pugi::xml_node t, bool load) {
  std::string type = attr(t, "type");
  if (type != "bitmap" && type != "checkerboard" && type != "mesh_attribute")
    error(t, "unknown texture '" + type + "' (supported: bitmap, checkerboard, mesh_attribute)");
  check_children(t, {});
  Props p(this, t);
  if (type == "mesh_attribute") {
    // The shape's vertex colours (its PLY file's r, g, b or red, green, blue;
    // a serialized file's colours; an OBJ's), or its PLY file's face
    // colours (each face's triangles get vertices of their own: add_shape),
    // times `scale`.
    const std::string name = p.get_string("name", "");
    if (name != "vertex_color" && name != "face_color")
      error(t, "mesh attribute '" + name + "' is not supported (supported: vertex_color, face_color)");
    const double scale = p.get_float("scale", 1.0);
    p.check_all_used();
    if (!load) return -1;
    const int32_t index = builder_.add_vertex_color_texture(loc(t), Color{1.f, 1.f, 1.f} * float(scale));
    if (name == "face_color") face_color_textures_.insert(index);
    return index;
  }
  const UvTransform to_uv = uv_transform(t, p);
  if (type == "checkerboard") {
    // Mitsuba 3's colours may be textures themselves, looked up at the
    // surface's uv (not through the checkerboard's to_uv): then a mix of the
    // two by a checkerboard of 0 and 1.
    const char* names[2] = {"color0", "color1"};
    const CheckerboardTexture defaults;
    SceneBuilder::TextureOperand colour[2] = {{-1, defaults.color0}, {-1, defaults.color1}};
    bool nested = false;
    for (int k = 0; k < 2; ++k) {
      auto it = p.by_name.find(names[k]);
      const std::string tag = it == p.by_name.end() ? "" : it->second.name();
      if (tag == "texture" || tag == "ref") {
        colour[k].texture = texture_param(p, names[k], load);
        nested = true;
      } else {
        colour[k].value = p.get_color(names[k], colour[k].value);
        if (!is_finite(colour[k].value) || !(colour[k].value.x >= 0.f && colour[k].value.y >= 0.f && colour[k].value.z >= 0.f))
          error(t, "checkerboard colours must be finite and not negative");
      }
    }
    p.check_all_used();
    if (!load) return -1;
    if (!nested) return builder_.add_checkerboard(loc(t), colour[0].value, colour[1].value, to_uv);
    const int32_t which = builder_.add_checkerboard(loc(t), {0, 0, 0}, {1, 1, 1}, to_uv);
    return builder_.add_mix_texture(loc(t), colour[0], colour[1], {which, {}});
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
  const fs::path full = resolve_file(t, file, "bitmap");
  if (!load) return -1;
  return builder_.add_image_texture(loc(t), {full.string(), bm.srgb, bm.filter, bm.wrap, to_uv});
}

int MitsubaParser::colour_attributes(uint32_t m) const {
  const Scene& s = builder_.scene();
  const Material& mat = s.materials.at(m);
  int kinds = 0;
  auto leaf = [&](int32_t t) {
    if (t >= 0 && s.textures[size_t(t)].type == TextureType::VertexColor) kinds |= face_color_textures_.count(t) ? 2 : 1;
  };
  auto texture = [&](int32_t t) {
    if (t < 0) return;
    const Texture& x = s.textures[size_t(t)];
    if (x.type != TextureType::Mix) return leaf(t);
    leaf(x.mix.a), leaf(x.mix.b), leaf(x.mix.amount);
  };
  for (uint32_t k = 0; k < mat.num_bindings; ++k) texture(s.texture_bindings[mat.first_binding + k].texture);
  texture(mat.opacity_texture);
  return kinds;
}

bool MitsubaParser::is_texture_ref(pugi::xml_node c) const {
  return std::string(c.name()) == "ref" && c.attribute("name") && textures_.count(c.attribute("id").value()) > 0;
}

int32_t MitsubaParser::texture_param(Props& p, const char* name, bool load) {
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

}  // namespace luz::mitsuba
