#include "luz/io/obj.h"

#include <tiny_obj_loader.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <utility>

#include "luz/io/error.h"

namespace luz {

namespace {

// Line of the k-th line starting with `tag` ("v", "vn"), for error messages.
int line_of_element(const std::string& path, const char* tag, size_t k) {
  std::ifstream in(path);
  std::string line, first;
  size_t seen = 0;
  for (int n = 1; std::getline(in, line); ++n) {
    std::istringstream ss(line);
    if (ss >> first && first == tag && seen++ == k) return n;
  }
  return 0;
}

}  // namespace

ObjMesh read_obj(const std::string& path, bool with_materials) {
  std::ifstream probe(path);
  if (!probe) throw InputError(path, 0, "cannot open file");
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  if (!with_materials) config.mtl_search_path = "/nonexistent/";
  tinyobj::ObjReader reader;
  if (!reader.ParseFromFile(path, config)) {
    std::string e = reader.Error();
    while (!e.empty() && (e.back() == '\n' || e.back() == '\r')) e.pop_back();
    for (char& c : e)
      if (c == '\n') c = ' ';
    throw InputError(path, 0, "malformed OBJ: " + e);
  }
  const tinyobj::attrib_t& attrib = reader.GetAttrib();
  for (size_t k = 0; k < attrib.vertices.size(); ++k)
    if (!std::isfinite(attrib.vertices[k]))
      throw InputError(path, line_of_element(path, "v", k / 3), "vertex coordinate is not a finite number");
  for (size_t k = 0; k < attrib.normals.size(); ++k)
    if (!std::isfinite(attrib.normals[k]))
      throw InputError(path, line_of_element(path, "vn", k / 3), "normal is not a finite number");

  ObjMesh mesh;
  if (with_materials)
    for (const tinyobj::material_t& m : reader.GetMaterials()) {
      ObjMaterial om;
      om.name = m.name;
      om.kd = {m.diffuse[0], m.diffuse[1], m.diffuse[2]};
      om.ks = {m.specular[0], m.specular[1], m.specular[2]};
      om.ke = {m.emission[0], m.emission[1], m.emission[2]};
      om.ns = m.shininess;
      mesh.materials.push_back(om);
    }

  bool all_normals = !attrib.normals.empty();
  for (const tinyobj::shape_t& shape : reader.GetShapes())
    for (const tinyobj::index_t& idx : shape.mesh.indices)
      if (idx.normal_index < 0) all_normals = false;

  std::map<std::pair<int, int>, uint32_t> remap;
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    const auto& ix = shape.mesh.indices;
    for (size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
      for (int j = 0; j < 3; ++j) {
        const tinyobj::index_t& idx = ix[3 * f + j];
        std::pair<int, int> key{idx.vertex_index, all_normals ? idx.normal_index : -1};
        auto it = remap.find(key);
        if (it == remap.end()) {
          it = remap.emplace(key, uint32_t(mesh.positions.size())).first;
          const float* v = &attrib.vertices[3 * size_t(idx.vertex_index)];
          mesh.positions.push_back({v[0], v[1], v[2]});
          if (all_normals) {
            const float* n = &attrib.normals[3 * size_t(idx.normal_index)];
            mesh.normals.push_back({n[0], n[1], n[2]});
          }
        }
        mesh.indices.push_back(it->second);
      }
      int mat = f < shape.mesh.material_ids.size() ? shape.mesh.material_ids[f] : -1;
      mesh.face_material.push_back(with_materials ? mat : -1);
    }
  }
  if (mesh.indices.empty()) throw InputError(path, 0, "mesh has no faces");
  return mesh;
}

}  // namespace luz
