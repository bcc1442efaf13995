// A mesh file as a whole scene: OBJ (its MTL materials as Luz materials,
// Ke as area lights) or PLY (diffuse), a camera framing the bounds, and,
// when nothing in the file emits, a uniform white sky so that the model shows.
#include <cmath>

#include "luz/io/error.h"
#include "luz/io/load.h"
#include "luz/io/mesh_obj.h"
#include "luz/io/mesh_ply.h"
#include "luz/scene/scene_builder.h"

namespace luz {

namespace {

// The camera and settings of a mesh file rendered as a scene; a white sky
// (radiance 1) when it has no emitter of its own.
Scene finish_mesh_scene(SceneBuilder& builder, bool has_emitter) {
  if (!has_emitter) {
    ConstantLight sky;
    sky.radiance = {1.f, 1.f, 1.f};
    builder.add_light({}, sky);
    builder.warn({}, "no light in the file: lit by a uniform white environment (radiance 1)");
  }
  builder.frame_bounds(512, 512);
  builder.settings().spp = 64;
  builder.settings().integrator.max_depth = -1;
  return builder.finish();
}

}  // namespace

namespace {

// An MTL material as a Luz material: illum 3 and 5 a mirror of reflectance
// Ks, illum 7 glass of index Ni (Ks reflecting, Tf transmitting, each white
// when black), the others Kd/Ks/Ns as modified Phong (diffuse without Ks),
// two-sided. map_Kd and map_Ks drive Kd and Ks (in place of the constants, as
// most renderers read them), map_Ns multiplies Ns (as the MTL specification
// says), map_bump is a bump map (-bm its scale), map_d
// and d the opacity. Texture maps on faces without texture coordinates are
// dropped with a warning.
MaterialDesc obj_material(SceneBuilder& builder, const SourceLoc& at, const ObjMaterial& m, bool has_uvs) {
  for (int k = 0; k < 3; ++k) {
    if (m.kd[k] < 0 || m.ks[k] < 0 || m.kd[k] + m.ks[k] > 1.f)
      builder.error(at, "material '" + m.name + "': Kd + Ks must lie in [0, 1] per channel");
    if (!std::isfinite(m.ke[k]) || m.ke[k] < 0) builder.error(at, "material '" + m.name + "': bad Ke");
  }
  if (!(m.ns >= 0)) builder.error(at, "material '" + m.name + "': Ns must be ≥ 0");
  MaterialDesc d;
  auto white_if_black = [](Color c) { return is_black(c) ? Color{1.f, 1.f, 1.f} : c; };
  if (m.illum == 3 || m.illum == 5) {
    Color eta, k;
    find_conductor_preset("none", eta, k);
    d.bsdf = Bsdf::make_smooth_conductor(eta, k, white_if_black(m.ks), true);
  } else if (m.illum == 7) {
    d.bsdf = Bsdf::make_smooth_dielectric(m.ni, 1.f, white_if_black(m.ks), white_if_black(m.tf));
  } else {
    d.bsdf = is_black(m.ks) && m.map_ks.empty() ? Bsdf::make_diffuse(m.kd, true)
                                                 : Bsdf::make_phong(m.kd, m.ks, m.ns, true);
  }
  d.opacity = m.d;
  const bool phong = d.bsdf.type == BsdfType::Phong;
  const std::string maps[] = {m.map_kd, m.map_ks, m.map_ns, m.map_bump, m.map_d};
  bool any = false;
  for (const std::string& f : maps) any |= !f.empty();
  if (any && !has_uvs) {
    builder.warn(at, "material '" + m.name + "': its texture maps are ignored (its faces have no texture coordinates)");
    return d;
  }
  auto image = [&](const std::string& file, bool srgb) {
    ImageTextureDesc t;
    t.path = file;
    t.srgb = srgb;
    return builder.add_image_texture(at, t);
  };
  const bool reflects = d.bsdf.type == BsdfType::Diffuse || phong;
  const std::string model = m.illum == 7 ? "glass (illum 7)" : "a mirror (illum " + std::to_string(m.illum) + ")";
  if (!m.map_kd.empty()) {
    if (reflects)
      d.bindings.push_back({image(m.map_kd, true), BsdfPart::Front,
                            phong ? BsdfParam::DiffuseReflectance : BsdfParam::Reflectance});
    else
      builder.warn(at, "material '" + m.name + "': map_Kd is ignored: the material is " + model);
  }
  if (!m.map_ks.empty()) {
    if (phong) d.bindings.push_back({image(m.map_ks, true), BsdfPart::Front, BsdfParam::SpecularReflectance});
    else builder.warn(at, "material '" + m.name + "': map_Ks is ignored: the material is " + model);
  }
  // map_Ns: a scalar map (its luminance, linear) that multiplies Ns, as the
  // MTL specification has it.
  if (!m.map_ns.empty()) {
    if (phong) {
      const int32_t ns = builder.add_scaled_texture(at, image(m.map_ns, false), Color{m.ns, m.ns, m.ns});
      d.bindings.push_back({ns, BsdfPart::Front, BsdfParam::Exponent});
      d.bsdf.phong.exponent = luminance(builder.texture_stats(ns).mean);  // a textured parameter holds its mean
    } else {
      builder.warn(at, "material '" + m.name + "': map_Ns is ignored: the material has no glossy part (" +
                           (reflects ? std::string("Ks 0 and no map_Ks") : "it is " + model) + ")");
    }
  }
  if (!m.map_bump.empty()) {
    d.bump_map = image(m.map_bump, false);
    d.bump_scale = m.bump_multiplier;
  }
  if (!m.map_d.empty()) d.opacity_texture = image(m.map_d, false);
  return d;
}

}  // namespace

Scene load_obj_scene(const std::string& path) {
  ObjMesh mesh = read_obj(path, true, ObjTexcoords::IfTextured);
  SceneBuilder builder(path);
  for (const ObjWarning& w : mesh.warnings) builder.warn({w.file, w.line}, w.message);
  const SourceLoc at{path, 0};
  std::vector<uint32_t> mat_index;
  for (const ObjMaterial& m : mesh.materials)
    mat_index.push_back(builder.add_material(at, obj_material(builder, at, m, !mesh.texcoords.empty())));
  MaterialDesc fallback;
  fallback.bsdf = Bsdf::make_diffuse({0.5f, 0.5f, 0.5f}, true);
  const uint32_t fallback_index = builder.add_material(at, fallback);
  // Faces grouped by material, each group one mesh (sharing the positions).
  const size_t nmat = mesh.materials.size();
  bool has_emitter = false;
  for (size_t g = 0; g <= nmat; ++g) {
    TriangleMesh part;
    for (size_t f = 0; f < mesh.face_material.size(); ++f) {
      const int fm = mesh.face_material[f];
      const size_t group = (fm < 0 || size_t(fm) >= nmat) ? nmat : size_t(fm);
      if (group != g) continue;
      part.indices.insert(part.indices.end(), {mesh.indices[3 * f], mesh.indices[3 * f + 1], mesh.indices[3 * f + 2]});
    }
    if (part.indices.empty()) continue;
    part.positions = mesh.positions;
    part.normals = mesh.normals;
    part.uvs = mesh.texcoords;
    AreaEmission area;
    const bool emits = g < nmat && !is_black(mesh.materials[g].ke);
    if (emits) area.radiance = mesh.materials[g].ke;
    has_emitter |= emits;
    builder.add_mesh(at, std::move(part), g < nmat ? mat_index[g] : fallback_index, emits ? &area : nullptr);
  }
  return finish_mesh_scene(builder, has_emitter);
}

Scene load_ply_scene(const std::string& path) {
  PlyMesh ply = read_ply(path);
  SceneBuilder builder(path);
  MaterialDesc d;
  d.bsdf = Bsdf::make_diffuse({0.5f, 0.5f, 0.5f}, true);
  const uint32_t material = builder.add_material({}, d);
  TriangleMesh mesh;
  mesh.positions = std::move(ply.positions);
  mesh.normals = std::move(ply.normals);
  mesh.indices = std::move(ply.indices);
  builder.add_mesh({}, std::move(mesh), material);
  return finish_mesh_scene(builder, false);
}

}  // namespace luz
