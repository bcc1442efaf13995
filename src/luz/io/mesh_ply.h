// PLY meshes (Turk's polygon file format): ASCII, binary little and big
// endian, every scalar type; positions, normals, texture coordinates,
// vertex colours and faces, every other element and property skipped. Debian packages no PLY
// reader; this one reads the whole file at once and checks every count and
// index before using it, so a lying or truncated file is an InputError.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "luz/math/vec.h"

namespace luz {

struct PlyMesh {
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;  // empty, or one per position (nx, ny, nz)
  // Empty, or one per position, as written in the file (no flip): u/v, s/t,
  // texture_u/texture_v or texture_s/texture_t.
  std::vector<Vec2> uvs;
  // Empty, or one per position: the vertex colour (scalar r, g, b or red,
  // green, blue), linear, as Mitsuba 3 reads it: a float channel as written
  // (not checked: SceneBuilder refuses colours outside [0, 1] where they are
  // used), an integer one divided by its type's maximum and sRGB-decoded.
  std::vector<Color> colors;
  // Triangles (vertex_indices or vertex_index); polygons fan-triangulated:
  // face (v0, v1, ..., vn) gives (v0, v1, v2), (v0, v2, v3), ...
  std::vector<uint32_t> indices;
  // Empty when every face is a triangle; else each face's first triangle,
  // one per face (pbrt-v4 makes each face a shape of its own).
  std::vector<uint32_t> face_first_triangle;
  // Empty, or one per output triangle: its face's colour (face properties
  // r, g, b or red, green, blue, read as vertex colours are: Mitsuba 3's
  // face_color).
  std::vector<Color> face_colors;
  // pbrt-v4's per-face material index (face property "face_indices"): empty,
  // or one per output triangle.
  std::vector<int32_t> face_indices;
};

// Throws InputError naming the file and "line N" (header and ASCII data) or
// "byte N" (binary data, counted from the start of the file) and the
// problem. A face of fewer than 3 vertices is refused, as are data after the
// last element, non-finite positions, normals or uvs, and vertex indices out
// of range. Vertices and faces are numbered from 0 in messages, as in the
// file's indices. A gzip-compressed file (pbrt-v4 reads .ply.gz) is
// recognised by its content and decompressed first.
PlyMesh read_ply(const std::string& path);
// The same, from memory (tests, fuzzing); `name` is the file name for messages.
PlyMesh read_ply_memory(const std::string& name, const char* data, size_t size);

}  // namespace luz
