// An OBJ file as a whole scene: its MTL materials as Luz materials, Ke as
// area lights, a camera framing the bounds.
#include <cmath>

#include "luz/io/error.h"
#include "luz/io/load.h"
#include "luz/io/mesh_obj.h"
#include "luz/scene/scene_builder.h"

namespace luz {

Scene load_obj_scene(const std::string& path) {
  ObjMesh mesh = read_obj(path, true);
  SceneBuilder builder(path);
  const SourceLoc at{path, 0};
  // One Luz material per MTL material (Kd/Ks/Ns: modified Phong, two-sided).
  std::vector<uint32_t> mat_index;
  for (const ObjMaterial& m : mesh.materials) {
    for (int k = 0; k < 3; ++k) {
      if (m.kd[k] < 0 || m.ks[k] < 0 || m.kd[k] + m.ks[k] > 1.f)
        builder.error(at, "material '" + m.name + "': Kd + Ks must lie in [0, 1] per channel");
      if (!std::isfinite(m.ke[k]) || m.ke[k] < 0) builder.error(at, "material '" + m.name + "': bad Ke");
    }
    if (!(m.ns >= 0)) builder.error(at, "material '" + m.name + "': Ns must be ≥ 0");
    MaterialDesc d;
    d.bsdf = is_black(m.ks) ? Bsdf::make_diffuse(m.kd, true) : Bsdf::make_phong(m.kd, m.ks, m.ns, true);
    mat_index.push_back(builder.add_material(at, d));
  }
  MaterialDesc fallback;
  fallback.bsdf = Bsdf::make_diffuse({0.5f, 0.5f, 0.5f}, true);
  const uint32_t fallback_index = builder.add_material(at, fallback);
  // Faces grouped by material, each group one mesh (sharing the positions).
  const size_t nmat = mesh.materials.size();
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
    AreaEmission area;
    const bool emits = g < nmat && !is_black(mesh.materials[g].ke);
    if (emits) area.radiance = mesh.materials[g].ke;
    builder.add_mesh(at, std::move(part), g < nmat ? mat_index[g] : fallback_index, emits ? &area : nullptr);
  }
  builder.frame_bounds(512, 512);
  builder.settings().spp = 64;
  builder.settings().integrator.max_depth = -1;
  return builder.finish();
}

}  // namespace luz
