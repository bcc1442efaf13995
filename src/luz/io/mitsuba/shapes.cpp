// The Mitsuba reader's shapes and their area emitters (see parser.h):
// obj, ply, serialized, rectangle, cube, disk, cylinder, sphere, and
// shapegroup with instance.
#include <cmath>
#include <numbers>

#include "luz/io/mesh_obj.h"
#include "luz/io/mesh_ply.h"
#include "luz/io/mesh_serialized.h"
#include "luz/io/mitsuba/parser.h"
#include "luz/scene/mesh_normals.h"

namespace luz::mitsuba {

namespace {

constexpr double kPi = std::numbers::pi;

// Disks and cylinders are triangulated with this many segments around, their
// radius widened so that the polygon keeps the circle's area (an emitter's
// power) or the cylinder its lateral area: the silhouette then lies within
// 1e-4 of the radius of Mitsuba's analytic shape.
constexpr int kSegments = 256;

// Mitsuba 3's coordinate_system (Duff et al. 2017, "Building an orthonormal
// basis, revisited"): the cylinder's angle starts along `s`, as Mitsuba's uv.
void coordinate_system(Vec3 n, Vec3& s, Vec3& t) {
  const float sign = std::copysign(1.f, n.z), a = -1.f / (sign + n.z), b = n.x * n.y * a;
  s = {1.f + sign * n.x * n.x * a, sign * b, -sign * n.x};
  t = {b, sign + n.y * n.y * a, -n.y};
}

// Mitsuba's unit disk at z = 0 facing +z: uv = (r, φ / 2π) as its disk plugin.
void disk_mesh(std::vector<Vec3>& pos, std::vector<Vec3>& nrm, std::vector<Vec2>& uv, std::vector<uint32_t>& idx) {
  const double r = std::sqrt(2.0 * kPi / (kSegments * std::sin(2.0 * kPi / kSegments)));
  for (int i = 0; i <= kSegments; ++i) {
    const double phi = 2.0 * kPi * i / kSegments;
    pos.push_back({float(r * std::cos(phi)), float(r * std::sin(phi)), 0.f});
    uv.push_back({1.f, float(i) / kSegments});
    pos.push_back({0.f, 0.f, 0.f});  // the centre, once per segment: its v follows the segment
    uv.push_back({0.f, (i + 0.5f) / kSegments});
  }
  nrm.assign(pos.size(), {0, 0, 1});
  for (uint32_t i = 0; i < uint32_t(kSegments); ++i) idx.insert(idx.end(), {2 * i + 1, 2 * i, 2 * i + 2});
}

// Mitsuba's cylinder: open (no caps), from p0 to p1 with `radius`, normals
// outward, uv = (φ / 2π, distance along the axis / length).
void cylinder_mesh(Vec3 p0, Vec3 p1, float radius, std::vector<Vec3>& pos, std::vector<Vec3>& nrm,
                   std::vector<Vec2>& uv, std::vector<uint32_t>& idx) {
  const Vec3 d = normalize(p1 - p0);
  Vec3 s, t;
  coordinate_system(d, s, t);
  const double r = radius * kPi / (kSegments * std::sin(kPi / kSegments));
  for (int i = 0; i <= kSegments; ++i) {
    const double phi = 2.0 * kPi * i / kSegments;
    const Vec3 radial = s * float(std::cos(phi)) + t * float(std::sin(phi));
    for (int end = 0; end < 2; ++end) {
      pos.push_back((end ? p1 : p0) + radial * float(r));
      nrm.push_back(radial);
      uv.push_back({float(i) / kSegments, float(end)});
    }
  }
  for (uint32_t i = 0; i < uint32_t(kSegments); ++i) {
    const uint32_t a = 2 * i, b = 2 * i + 2;
    idx.insert(idx.end(), {a, b, b + 1, a, b + 1, a + 1});
  }
}

}  // namespace

void MitsubaParser::parse_shape(pugi::xml_node n) {
  const std::string type = attr(n, "type");
  if (type == "shapegroup") return parse_shapegroup(n);
  if (type == "instance") return parse_instance(n);
  add_shape(n, -1);
}

// Mitsuba's shapegroup: shapes stored once (an object of the builder),
// placed by instances that <ref> it. Its shapes take no emitter (as in
// Mitsuba 3) and no sphere (Luz's objects hold triangles).
void MitsubaParser::parse_shapegroup(pugi::xml_node n) {
  const std::string id = n.attribute("id").value();
  if (id.empty()) error(n, "a shapegroup needs an id (instances refer to it)");
  if (shapegroups_.count(id) || bsdfs_.count(id) || textures_.count(id)) error(n, "duplicate id '" + id + "'");
  check_children(n, {"shape"});
  Props p(this, n);
  p.check_all_used();
  const uint32_t object = builder_.begin_object(loc(n), id);
  for (pugi::xml_node c : n.children("shape")) {
    const std::string type = attr(c, "type");
    if (type == "shapegroup" || type == "instance") error(c, "a " + type + " inside a shapegroup is not supported");
    add_shape(c, int64_t(object));
  }
  shapegroups_[id] = object;
}

void MitsubaParser::parse_instance(pugi::xml_node n) {
  check_children(n, {"ref"});
  Props p(this, n);
  const Matrix4 to_world = p.get_transform("to_world");
  p.check_all_used();
  std::vector<pugi::xml_node> refs;
  for (pugi::xml_node c : n.children("ref")) refs.push_back(c);
  if (refs.size() != 1) error(n, "an instance needs exactly one <ref> to a shapegroup");
  const std::string id = attr(refs[0], "id");
  auto it = shapegroups_.find(id);
  if (it == shapegroups_.end()) error(refs[0], "no shapegroup with id '" + id + "' defined before this point");
  builder_.add_instance(loc(n), it->second, to_world);
}

// One shape: into the scene (object < 0) or into a shapegroup's object.
void MitsubaParser::add_shape(pugi::xml_node n, int64_t object) {
  const std::string type = attr(n, "type");
  static const char* kSupported =
      "(supported: obj, ply, serialized, rectangle, cube, disk, cylinder, sphere, shapegroup, instance)";
  if (type != "sphere" && type != "rectangle" && type != "cube" && type != "obj" && type != "ply" &&
      type != "serialized" && type != "disk" && type != "cylinder")
    error(n, "unknown shape '" + type + "' " + kSupported);
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

  if (emission && object >= 0) error(n, "an emitter on a shape inside a shapegroup is not supported (as in Mitsuba 3)");

  // Textures, masks, normal and bump maps need texture coordinates: the
  // built-in shapes have them (the sphere's are computed at each hit),
  // meshes where their files do, or else each face's barycentrics (below).
  // Only a textured shape keeps them (see read_obj).
  // Vertex colours (mesh_attribute) likewise: kept where the material reads them.
  const Material& mat = builder_.scene().materials[size_t(material)];
  const bool textured = builder_.material_reads_uv(uint32_t(material)) || area.texture >= 0;
  const int colours = colour_attributes(uint32_t(material));
  if (colours == 3) error(n, "a material reading both vertex_color and face_color is not supported");
  const bool colored = colours == 1, face_colored = colours == 2;
  std::vector<Vec3> pos, nrm;
  std::vector<Vec2> uv;
  std::vector<Color> col;
  std::vector<uint32_t> idx;
  // Built-in shapes whose faces are flat: the normal given by the normal
  // transform sets the winding, then the geometric normal is exact.
  bool flat = true;
  bool face_normals = false;  // a mesh file's: shade flat
  double smooth_angle = -1;   // a mesh file's max_smooth_angle (< 0: none)
  bool barycentric_uv = false;  // a textured mesh file without texture coordinates
  if (type == "sphere") {
    if (object >= 0) error(n, "a sphere inside a shapegroup is not supported (objects hold triangle meshes)");
    Vec3 center = p.get_point("center", {});
    double radius = p.get_float("radius", 1.0);
    if (!(radius > 0)) error(n, "radius must be positive");
    p.check_all_used();
    Vec3 c = to_world.point(center);
    float sx = length(to_world.vector({1, 0, 0})), sy = length(to_world.vector({0, 1, 0})),
          sz = length(to_world.vector({0, 0, 1}));
    if (std::fabs(sx - sy) > 1e-4f * sx || std::fabs(sx - sz) > 1e-4f * sx)
      error(n, "a sphere's to_world must scale uniformly");
    // Mitsuba 3's sphere is to_world · translate(center) · scale(radius) of
    // the unit sphere: its uv angles are taken in to_world's axes. A
    // mirroring to_world turns its normals inward, as in Mitsuba 3 (the scale
    // it decomposes to_world into takes the determinant's sign, and a
    // negative one flips the normals).
    if (to_world.det3() < 0) flip = !flip;
    builder_.add_sphere(loc(n), c, float(radius) * sx, uint32_t(material), emission, flip, to_world);
    return;
  }
  if (type == "rectangle") {
    p.check_all_used();
    pos = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    nrm.assign(4, {0, 0, 1});
    if (textured) uv = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};  // Mitsuba's rectangle
    idx = {0, 1, 2, 2, 3, 0};
  } else if (type == "disk") {
    p.check_all_used();
    disk_mesh(pos, nrm, uv, idx);
  } else if (type == "cylinder") {
    const Vec3 p0 = p.get_point("p0", {0, 0, 0}), p1 = p.get_point("p1", {0, 0, 1});
    const double radius = p.get_float("radius", 1.0);
    p.check_all_used();
    if (!(radius > 0)) error(n, "radius must be positive");
    if (!(length(p1 - p0) > 0.f)) error(n, "the cylinder's p0 and p1 coincide");
    cylinder_mesh(p0, p1, float(radius), pos, nrm, uv, idx);
    flat = false;  // the radial vertex normals shade it round
  } else if (type == "cube") {
    p.check_all_used();
    // Each face: 4 corners counter-clockwise seen from outside, with Mitsuba
    // 3's uvs (its cube plugin): on each face u and v are (1 + s x_i) / 2 of
    // one coordinate x_i and a sign s, per face as its vertex table gives.
    struct FaceUv {
      int u_axis, u_sign, v_axis, v_sign;
    };
    // Faces by (axis, sign): -x, +x, -y, +y, -z, +z.
    constexpr FaceUv kFaceUv[3][2] = {{{1, 1, 2, 1}, {1, 1, 2, -1}},
                                      {{2, 1, 0, 1}, {0, -1, 2, -1}},
                                      {{1, -1, 0, 1}, {1, 1, 0, 1}}};
    for (int axis = 0; axis < 3; ++axis)
      for (int sgn = -1; sgn <= 1; sgn += 2) {
        Vec3 nn{};
        nn[axis] = float(sgn);
        int a = (axis + 1) % 3, b = (axis + 2) % 3;
        uint32_t base = uint32_t(pos.size());
        const float corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
        const FaceUv& f = kFaceUv[axis][sgn > 0];
        for (const auto& cr : corners) {
          Vec3 v{};
          v[axis] = float(sgn);
          v[a] = cr[0] * float(sgn);
          v[b] = cr[1];
          pos.push_back(v);
          nrm.push_back(nn);
          uv.push_back({0.5f * (1.f + float(f.u_sign) * v[f.u_axis]), 0.5f * (1.f + float(f.v_sign) * v[f.v_axis])});
        }
        idx.insert(idx.end(), {base, base + 1, base + 2, base + 2, base + 3, base});
      }
  } else {
    // Meshes from files. Without normals they get smooth vertex normals
    // (Mitsuba 3's), unless face_normals; Mitsuba 0.5/0.6's max_smooth_angle
    // rebuilds them, smooth across edges below the angle and creased above
    // (mesh_normals.h).
    flat = false;
    std::string file = p.get_string("filename", "");
    if (file.empty()) error(n, type + " shape needs a 'filename'");
    face_normals = p.get_bool("face_normals", false);
    if (p.has("max_smooth_angle")) {
      smooth_angle = p.get_float("max_smooth_angle", 0.0);
      if (!(smooth_angle >= 0 && smooth_angle <= 180)) error(n, "max_smooth_angle must be between 0 and 180 degrees");
    }
    bool replaced = false;
    const fs::path full = mesh_file(n, file, type, replaced);
    if (replaced)
      builder_.warn(loc(n), "'" + file + "' is missing: read '" + full.string() + "' (the same name as PLY) instead");
    if (type == "obj") {
      // Mitsuba flips OBJ's v by default (read_obj does); flip_tex_coords false keeps vt as written.
      const bool flip_uv = p.get_bool("flip_tex_coords", true);
      p.check_all_used();
      if (full.extension() == ".ply") {  // mesh_file's fallback: the same mesh as PLY
        read_mesh_ply(full, flip_uv, textured, colored, face_colored, pos, nrm, uv, col, idx);
      } else {
        const std::optional<std::shared_ptr<const ObjFile>> ahead = objs_ahead_.take(full.string());
        ObjMesh mesh = obj_mesh(ahead ? **ahead : *read_obj_file(full.string()),
                                textured ? ObjTexcoords::Yes : ObjTexcoords::No);
        pos = std::move(mesh.positions);
        nrm = std::move(mesh.normals);
        uv = std::move(mesh.texcoords);
        if (colored) col = std::move(mesh.colors);  // (Mitsuba 3's obj reads none)
        if (colored && mesh.colors_dropped.line > 0)
          throw InputError(mesh.colors_dropped.file, mesh.colors_dropped.line,
                           mesh.colors_dropped.message.substr(0, mesh.colors_dropped.message.find(':')));
        if (!flip_uv)
          for (Vec2& t : uv) t.y = 1.f - t.y;
        idx = std::move(mesh.indices);
      }
    } else if (type == "ply") {
      // Mitsuba 3's ply flips v by default too (flip_tex_coords, default true).
      const bool flip_uv = p.get_bool("flip_tex_coords", true);
      p.check_all_used();
      read_mesh_ply(full, flip_uv, textured, colored, face_colored, pos, nrm, uv, col, idx);
    } else {
      const long index = p.get_int("shape_index", 0);
      p.check_all_used();
      if (index < 0) error(n, "shape_index must be ≥ 0");
      // Scenes read many shapes from one file: it is read once.
      auto it = serialized_files_.find(full.string());
      if (it == serialized_files_.end()) it = serialized_files_.emplace(full.string(), read_binary_file(full.string())).first;
      SerializedMesh mesh =
          read_serialized_memory(full.string(), it->second.data(), it->second.size(), uint32_t(index));
      pos = std::move(mesh.positions);
      nrm = std::move(mesh.normals);
      if (textured) uv = std::move(mesh.uvs);  // as stored: Mitsuba's serialized plugin does not flip
      if (colored) col = std::move(mesh.colors);
      idx = std::move(mesh.indices);
      face_normals = face_normals || mesh.face_normals;
    }
    if (face_normals) nrm.clear();
    if ((colored || face_colored) && col.empty())
      error(n, std::string("the material reads ") + (colored ? "vertex" : "face") +
                   " colours (mesh_attribute), and '" + file + "' has none");
    for (size_t t = 0; face_colored && t < col.size(); ++t)
      if (!is_unit_color(col[t]))
        error(n, "'" + file + "': the colour of the face of triangle " + std::to_string(t) + " is not within [0, 1]");
    if (textured && uv.empty()) {
      // Mitsuba 3 takes such a mesh's tangents from the normal alone, which
      // a normal or bump map would need here too.
      if (mat.normal_map >= 0 || mat.bump_map >= 0)
        error(n, "a normal or bump map on a mesh without texture coordinates ('" + file + "')");
      barycentric_uv = true;
    }
  }
  if (!textured) uv.clear();

  // Bake the transform. The built-in shapes keep the normal given by the
  // normal transform; the winding is set to agree with it.
  const bool analytic = type != "obj" && type != "ply" && type != "serialized";
  for (Vec3& v : pos) v = to_world.point(v);
  for (Vec3& v : nrm) v = to_world.normal(v);
  // From the world's positions and the file's winding, as Mitsuba does.
  if (!analytic && !face_normals && (nrm.empty() || smooth_angle >= 0)) {
    compute_vertex_normals(pos, idx, uv, nrm, smooth_angle, colored ? &col : nullptr);
    // Planar faces that share no vertex across an edge (a box's walls):
    // every normal is its faces' own, which flat shading gives exactly and
    // sooner.
    if (normals_are_flat(pos, idx, nrm)) nrm.clear();
  }
  if (barycentric_uv || face_colored) {
    // Mitsuba 3's uv where a mesh has none: each face's barycentrics (b1, b2)
    // of its second and third vertices. Every face gets its own three
    // vertices, at uv (0, 0), (1, 0), (0, 1), after the smooth normals.
    std::vector<Vec3> face_pos, face_nrm;
    std::vector<Color> face_col;
    face_pos.reserve(idx.size());
    face_nrm.reserve(nrm.empty() ? 0 : idx.size());
    face_col.reserve(col.empty() ? 0 : idx.size());
    std::vector<Vec2> face_uv;
    face_uv.reserve(barycentric_uv || !uv.empty() ? idx.size() : 0);
    for (size_t k = 0; k < idx.size(); ++k) {
      face_pos.push_back(pos[idx[k]]);
      if (!nrm.empty()) face_nrm.push_back(nrm[idx[k]]);
      // Face colours: one per triangle (read_mesh_ply), given to its corners.
      if (!col.empty()) face_col.push_back(face_colored ? col[k / 3] : col[idx[k]]);
      if (barycentric_uv) face_uv.push_back(k % 3 == 0 ? Vec2{0, 0} : k % 3 == 1 ? Vec2{1, 0} : Vec2{0, 1});
      else if (!uv.empty()) face_uv.push_back(uv[idx[k]]);
      idx[k] = uint32_t(k);
    }
    pos = std::move(face_pos);
    nrm = std::move(face_nrm);
    col = std::move(face_col);
    uv = std::move(face_uv);
  }
  for (size_t k = 0; k + 2 < idx.size(); k += 3) {
    Vec3 g = cross(pos[idx[k + 1]] - pos[idx[k]], pos[idx[k + 2]] - pos[idx[k]]);
    if (length(g) == 0.f) continue;
    bool swap = analytic && dot(g, nrm[idx[k]]) < 0.f;
    if (swap != flip) std::swap(idx[k + 1], idx[k + 2]);
  }
  if (flip)
    for (Vec3& v : nrm) v = -v;
  if (analytic && flat) nrm.clear();  // flat faces: the geometric normal is exact
  TriangleMesh mesh{std::move(pos), std::move(nrm), std::move(uv), std::move(idx), std::move(col)};
  if (object >= 0) builder_.add_object_mesh(loc(n), uint32_t(object), std::move(mesh), uint32_t(material));
  else builder_.add_mesh(loc(n), std::move(mesh), uint32_t(material), emission);
}

// A PLY mesh's arrays; v flipped (1 - v) when flip_uv.
void MitsubaParser::read_mesh_ply(const fs::path& full, bool flip_uv, bool textured, bool colored, bool face_colored,
                                  std::vector<Vec3>& pos, std::vector<Vec3>& nrm, std::vector<Vec2>& uv,
                                  std::vector<Color>& col, std::vector<uint32_t>& idx) {
  std::optional<PlyMesh> ahead = plys_ahead_.take(full.string());
  PlyMesh mesh = ahead ? std::move(*ahead) : read_ply(full.string());
  pos = std::move(mesh.positions);
  nrm = std::move(mesh.normals);
  if (textured) uv = std::move(mesh.uvs);
  if (colored) col = std::move(mesh.colors);
  if (face_colored) col = std::move(mesh.face_colors);  // one per triangle until add_shape gives each its corners
  if (flip_uv)
    for (Vec2& t : uv) t.y = 1.f - t.y;
  idx = std::move(mesh.indices);
}

}  // namespace luz::mitsuba
