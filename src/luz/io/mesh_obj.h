// OBJ meshes through tinyobjloader, with line numbers for errors.
#pragma once

#include <string>
#include <vector>

#include "luz/math/vec.h"

namespace luz {

struct ObjMaterial {
  std::string name;
  Color kd{0.5f, 0.5f, 0.5f}, ks{}, ke{};
  float ns = 1.f;
};

struct ObjMesh {
  std::vector<Vec3> positions, normals;  // normals empty or one per position
  // Texture coordinates, empty or one per position, with v flipped (1 - vt.v)
  // as Mitsuba's OBJ loader does by default (texture.h's convention).
  std::vector<Vec2> texcoords;
  std::vector<uint32_t> indices;
  std::vector<int> face_material;  // per triangle, -1: none
  std::vector<ObjMaterial> materials;
};

// Throws InputError. Faces are triangulated; vertices are de-indexed per
// (position, normal) pair, or per (position, normal, texture coordinate)
// triple with `with_texcoords` (only then is `texcoords` filled: de-indexing
// by texture coordinates splits vertices at every uv seam, which costs an
// untextured mesh memory and Embree its quads).
ObjMesh read_obj(const std::string& path, bool with_materials, bool with_texcoords = false);

}  // namespace luz
