// A mesh file as a whole scene: OBJ (its MTL materials as Luz materials,
// Ke as area lights; faces without a material diffuse, of the vertex
// colours where the file has them, else grey) or PLY (likewise, of its
// vertex or else face colours), a camera framing the bounds, and,
// when nothing in the file emits, a uniform white sky so that the model shows.
#include <cmath>
#include <cstdio>

#include "luz/core/memory.h"
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

// An MTL material as a Luz material, two-sided:
//  - illum 4, 6, 7 and 9 (the MTL specification's transparent ones, as
//    Blender's importer and Mitsuba 0.6 read them) glass of index Ni (Ks
//    reflecting, Tf transmitting, each white when black);
//  - illum 3 and 5 the specification's Kd diffuse plus a mirror of
//    reflectance Ks: a blend of the two (without Ks, plain diffuse);
//  - the others Kd/Ks/Ns as modified Phong (diffuse without Ks).
// Kd + Ks above 1 (Blender writes Kd 0.8, Ks 0.5) is scaled to 1 with a
// warning: the models conserve energy. map_Kd and map_Ks drive Kd and Ks
// (in place of the constants, as most renderers read them), map_Ns
// multiplies Ns (as the MTL specification says), map_bump is a bump map
// (-bm its scale), d times map_d (its alpha, or else its luminance) the
// opacity; maps are placed by their -s and -o. Texture maps on faces without texture coordinates are dropped
// with a warning.
MaterialDesc obj_material(SceneBuilder& builder, const SourceLoc& at, const ObjMaterial& m, bool has_uvs) {
  for (int k = 0; k < 3; ++k) {
    if (!(m.kd[k] >= 0.f && m.ks[k] >= 0.f) || !std::isfinite(m.kd[k] + m.ks[k]))
      builder.error(at, "material '" + m.name + "': Kd and Ks must be finite and not negative");
    if (!std::isfinite(m.ke[k]) || m.ke[k] < 0) builder.error(at, "material '" + m.name + "': bad Ke");
  }
  if (!(m.ns >= 0)) builder.error(at, "material '" + m.name + "': Ns must be ≥ 0");
  MaterialDesc d;
  d.opacity = m.d;
  const std::string maps[] = {m.map_kd, m.map_ks, m.map_ns, m.map_bump, m.map_d};
  bool any = false;
  for (const std::string& f : maps) any |= !f.empty();
  const bool textured = any && has_uvs;
  if (any && !has_uvs)
    builder.warn(at, "material '" + m.name + "': its texture maps are ignored (its faces have no texture coordinates)");
  // Map k (kd, ks, ns, bump, d) placed by its -s and -o: u' = s u + o in
  // the MTL's v-up coordinates; Luz's v (1 - the file's) maps to
  // s_v v + 1 - s_v - o_v.
  auto image = [&](const std::string& file, bool srgb, int k) {
    const ObjMaterial::MapPlacement& p = m.placement[k];
    ImageTextureDesc t;
    t.path = file;
    t.srgb = srgb;
    t.to_uv = {p.su, 0.f, p.ou, 0.f, p.sv, 1.f - p.sv - p.ov};
    return builder.add_image_texture(at, t);
  };
  const int32_t kd_tex = textured && !m.map_kd.empty() ? image(m.map_kd, true, 0) : -1;
  const int32_t ks_tex = textured && !m.map_ks.empty() ? image(m.map_ks, true, 1) : -1;
  auto white_if_black = [](Color c) { return is_black(c) ? Color{1.f, 1.f, 1.f} : c; };
  auto ignored = [&](const char* map, const std::string& model) {
    builder.warn(at, "material '" + m.name + "': " + map + " is ignored: the material is " + model);
  };
  const bool glass = m.illum == 4 || m.illum == 6 || m.illum == 7 || m.illum == 9;
  if (glass) {
    d.bsdf = Bsdf::make_smooth_dielectric(m.ni, 1.f, white_if_black(m.ks), white_if_black(m.tf));
    const std::string model = "glass (illum " + std::to_string(m.illum) + ")";
    if (kd_tex >= 0) ignored("map_Kd", model);
    if (ks_tex >= 0) ignored("map_Ks", model);
    if (textured && !m.map_ns.empty()) ignored("map_Ns", model);
  } else {
    // The largest Kd + Ks over the channels (a map's by its largest texel).
    const Color kd = kd_tex >= 0 ? builder.texture_stats(kd_tex).max : m.kd;
    const Color ks = ks_tex >= 0 ? builder.texture_stats(ks_tex).max : m.ks;
    const float sum = max_component(kd + ks), scale = sum > 1.f ? 1.f / sum : 1.f;
    if (scale < 1.f) {
      char msg[160];
      std::snprintf(msg, sizeof msg, "Kd + Ks reaches %.3g: both scaled by %.3g (the model conserves energy)", sum, scale);
      builder.warn(at, "material '" + m.name + "': " + msg);
    }
    auto scaled = [&](int32_t tex, float k) { return k == 1.f ? tex : builder.add_scaled_texture(at, tex, Color{k, k, k}); };
    const bool specular = !is_black(m.ks) || ks_tex >= 0;
    if ((m.illum == 3 || m.illum == 5) && specular) {
      // Kd/π + Ks δ as (1 - w) (Kd / (1 - w)) / π + w (Ks / w) δ, with w
      // Ks's share of the two largest values, so that both stay in [0, 1].
      const float sd = max_component(kd) * scale, ss = max_component(ks) * scale;
      const float w = ss / (sd + ss);
      Color eta, k;
      find_conductor_preset("none", eta, k);
      const Bsdf mirror = Bsdf::make_smooth_conductor(eta, k, m.ks * (scale / w), true);
      if (sd > 0.f) {
        d.bsdf = Bsdf::make_blend(Bsdf::make_diffuse(m.kd * (scale / (1.f - w)), true), mirror, w);
        if (kd_tex >= 0) d.bindings.push_back({scaled(kd_tex, scale / (1.f - w)), BsdfPart::Front, BsdfParam::Reflectance});
        if (ks_tex >= 0) d.bindings.push_back({scaled(ks_tex, scale / w), BsdfPart::Second, BsdfParam::SpecularReflectance});
      } else {
        d.bsdf = mirror;
        if (ks_tex >= 0) d.bindings.push_back({scaled(ks_tex, scale / w), BsdfPart::Front, BsdfParam::SpecularReflectance});
      }
      if (textured && !m.map_ns.empty()) ignored("map_Ns", "a mirror (illum " + std::to_string(m.illum) + ")");
    } else {
      const bool phong = specular;
      d.bsdf = phong ? Bsdf::make_phong(m.kd * scale, m.ks * scale, m.ns, true) : Bsdf::make_diffuse(m.kd * scale, true);
      if (kd_tex >= 0)
        d.bindings.push_back({scaled(kd_tex, scale), BsdfPart::Front, phong ? BsdfParam::DiffuseReflectance : BsdfParam::Reflectance});
      if (ks_tex >= 0) d.bindings.push_back({scaled(ks_tex, scale), BsdfPart::Front, BsdfParam::SpecularReflectance});
      // map_Ns: a scalar map (its luminance, linear) that multiplies Ns, as
      // the MTL specification has it.
      if (textured && !m.map_ns.empty()) {
        if (phong) {
          const int32_t ns = builder.add_scaled_texture(at, image(m.map_ns, false, 2), Color{m.ns, m.ns, m.ns});
          d.bindings.push_back({ns, BsdfPart::Front, BsdfParam::Exponent});
          d.bsdf.phong.exponent = luminance(builder.texture_stats(ns).mean);  // a textured parameter holds its mean
        } else {
          builder.warn(at, "material '" + m.name + "': map_Ns is ignored: the material has no glossy part (Ks 0 and no map_Ks)");
        }
      }
    }
  }
  if (!textured) return d;
  if (!m.map_bump.empty()) {
    d.bump_map = image(m.map_bump, false, 3);
    d.bump_scale = m.bump_multiplier;
  }
  // map_d times d, as the MTL specification says: an 8-bit image's alpha
  // where it has transparent texels (an RGBA map, as Blender's importer
  // reads it), else its luminance (a grey mask).
  if (!m.map_d.empty()) {
    int32_t alpha = image(m.map_d, false, 4);
    Texture a = builder.scene().textures[size_t(alpha)];
    if (a.type == TextureType::Bitmap && !a.bitmap.is_float) {
      a.bitmap.channel = TextureChannel::A;
      const int32_t from_alpha = builder.add_texture(at, a);
      if (builder.texture_stats(from_alpha).min.x < 1.f) alpha = from_alpha;
    }
    d.opacity_texture = m.d < 1.f ? builder.add_scaled_texture(at, alpha, Color{m.d, m.d, m.d}) : alpha;
  }
  return d;
}

// The material of a mesh file's faces that name none: diffuse (two-sided),
// of the vertex colours where the file has them (as MeshLab and Blender
// show them), else grey.
MaterialDesc default_material(SceneBuilder& builder, bool colored) {
  MaterialDesc d;
  d.bsdf = Bsdf::make_diffuse({0.5f, 0.5f, 0.5f}, true);
  if (colored) {
    const int32_t t = builder.add_vertex_color_texture({builder.file(), 0});
    d.bindings.push_back({t, BsdfPart::Front, BsdfParam::Reflectance});
    d.bsdf.diffuse.reflectance = builder.texture_stats(t).mean;
  }
  return d;
}

}  // namespace

Scene load_obj_scene(const std::string& path) {
  ObjMesh mesh = read_obj(path, true, ObjTexcoords::IfTextured, ObjSmoothing::Groups);
  SceneBuilder builder(path);
  for (const ObjWarning& w : mesh.warnings) builder.warn({w.file, w.line}, w.message);
  const SourceLoc at{path, 0};
  std::vector<uint32_t> mat_index;
  for (const ObjMaterial& m : mesh.materials)
    mat_index.push_back(builder.add_material(at, obj_material(builder, at, m, !mesh.texcoords.empty())));
  const uint32_t fallback_index = builder.add_material(at, default_material(builder, !mesh.colors.empty()));
  // Faces grouped by material, each group one mesh (sharing the positions).
  const size_t nmat = mesh.materials.size();
  bool has_emitter = false;
  size_t colored_faces = 0;  // the faces without a material, which show the vertex colours
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
    if (g == nmat) part.colors = mesh.colors, colored_faces = part.indices.size() / 3;
    AreaEmission area;
    const bool emits = g < nmat && !is_black(mesh.materials[g].ke);
    if (emits) area.radiance = mesh.materials[g].ke;
    has_emitter |= emits;
    builder.add_mesh(at, std::move(part), g < nmat ? mat_index[g] : fallback_index, emits ? &area : nullptr);
  }
  if (!mesh.colors.empty() && colored_faces < mesh.face_material.size())
    builder.warn(at, std::to_string(mesh.face_material.size() - colored_faces) +
                         " triangles have an MTL material: the vertex colours are not used there");
  return finish_mesh_scene(builder, has_emitter);
}

Scene load_ply_scene(const std::string& path) {
  PlyMesh ply = read_ply(path);
  SceneBuilder builder(path);
  // Face colours where the file has no vertex colours: each triangle gets
  // vertices of its own, of its face's colour.
  if (ply.colors.empty() && !ply.face_colors.empty()) {
    require_memory(uint64_t(ply.indices.size()) * (2 * sizeof(Vec3) + sizeof(Color)), path,
                   "the face-coloured triangles' own vertices");
    std::vector<Vec3> pos, nrm;
    for (size_t k = 0; k < ply.indices.size(); ++k) {
      pos.push_back(ply.positions[ply.indices[k]]);
      if (!ply.normals.empty()) nrm.push_back(ply.normals[ply.indices[k]]);
      ply.colors.push_back(ply.face_colors[k / 3]);
      ply.indices[k] = uint32_t(k);
    }
    ply.positions = std::move(pos);
    ply.normals = std::move(nrm);
  } else if (!ply.face_colors.empty()) {
    builder.warn({path, 0}, "the face colours are not used (the vertex colours are)");
  }
  for (size_t k = 0; k < ply.colors.size(); ++k) {
    if (!is_unit_color(ply.colors[k])) {
      builder.warn({path, 0}, "the colour of vertex " + std::to_string(k) + " is not within [0, 1]: the colours are not used");
      ply.colors.clear();
    }
  }
  const uint32_t material = builder.add_material({}, default_material(builder, !ply.colors.empty()));
  TriangleMesh mesh;
  mesh.positions = std::move(ply.positions);
  mesh.normals = std::move(ply.normals);
  mesh.indices = std::move(ply.indices);
  mesh.colors = std::move(ply.colors);
  builder.add_mesh({}, std::move(mesh), material);
  return finish_mesh_scene(builder, false);
}

}  // namespace luz
