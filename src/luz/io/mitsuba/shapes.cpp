// The Mitsuba reader's shapes and their area emitters (see parser.h).
#include <cmath>

#include "luz/io/mesh_obj.h"
#include "luz/io/mitsuba/parser.h"

namespace luz::mitsuba {

void MitsubaParser::parse_shape(pugi::xml_node n) {
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
    ObjMesh mesh = read_obj(full.string(), false, textured ? ObjTexcoords::Yes : ObjTexcoords::No);
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

}  // namespace luz::mitsuba
