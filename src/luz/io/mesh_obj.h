// OBJ meshes through tinyobjloader, with line numbers for errors.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "luz/math/vec.h"

namespace luz {

struct ObjMaterial {
  std::string name;
  Color kd{0.5f, 0.5f, 0.5f}, ks{}, ke{};
  float ns = 1.f;
  int illum = 0;       // 3 and 5: diffuse and a mirror; 4, 6, 7, 9: glass
  float ni = 1.f;      // index of refraction
  Color tf{};          // transmission filter
  float d = 1.f;       // opacity ("d", or 1 - "Tr")
  // Texture files (paths resolved against the OBJ's directory; empty: none).
  std::string map_kd, map_ks, map_ns, map_bump, map_d;
  float bump_multiplier = 1.f;  // map_bump's -bm
  // Each map's -s and -o (u' = s u + o, in the MTL's v-up coordinates), in
  // the order kd, ks, ns, bump, d.
  struct MapPlacement {
    float su = 1.f, sv = 1.f, ou = 0.f, ov = 0.f;
  };
  MapPlacement placement[5];
};

// A warning of the reader: the file and line it concerns.
struct ObjWarning {
  std::string file;
  int line = 0;
  std::string message;
};

struct ObjMesh {
  std::vector<Vec3> positions, normals;  // normals empty or one per position
  // Texture coordinates, empty or one per position, with v flipped (1 - vt.v)
  // as Mitsuba's OBJ loader does by default (texture.h's convention).
  std::vector<Vec2> texcoords;
  // Vertex colours (`v x y z r g b`), empty or one per position: linear,
  // decoded from the sRGB values exporters write; white where a `v` line
  // has none.
  std::vector<Color> colors;
  // Why the file's colours were dropped (a colour outside [0, 1]; line 0: they were not).
  ObjWarning colors_dropped;
  std::vector<uint32_t> indices;
  std::vector<int> face_material;  // per triangle, -1: none
  std::vector<ObjMaterial> materials;
  std::vector<ObjWarning> warnings;  // a missing mtllib, an unknown usemtl
};

// Whether texture coordinates are read: de-indexing by them splits vertices
// at every uv seam, which costs an untextured mesh memory and Embree its quads.
enum class ObjTexcoords { No, Yes, IfTextured /* when a material has a texture map */ };

// Whether the smoothing groups (`s N`) shade faces without vn smooth: the
// OBJ format's reading; Mitsuba's obj shape smooths or not by its own rule.
enum class ObjSmoothing { Ignore, Groups };

// Throws InputError. Faces are triangulated; vertices are de-indexed per
// (position, normal) pair, or per (position, normal, texture coordinate)
// triple when texture coordinates are read (only then is `texcoords` filled).
ObjMesh read_obj(const std::string& path, bool with_materials, ObjTexcoords texcoords = ObjTexcoords::No,
                 ObjSmoothing smoothing = ObjSmoothing::Ignore);

// read_obj(path, false, texcoords) in two steps, for readers that read files
// ahead in parallel: reading, checking and parsing the file (the costly
// part, which throws what read_obj throws)...
struct ObjFile;
std::shared_ptr<const ObjFile> read_obj_file(const std::string& path);
// ...then the de-indexing, which depends on texcoords.
ObjMesh obj_mesh(const ObjFile& file, ObjTexcoords texcoords, ObjSmoothing smoothing = ObjSmoothing::Ignore);

}  // namespace luz
