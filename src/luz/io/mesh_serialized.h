// Mitsuba's .serialized meshes (format 0x041C, versions 3 and 4, as
// Mitsuba 3's serialized plugin documents): per shape a little-endian header
// (uint16 format, uint16 version) and a zlib stream holding uint32 flags, the
// name (version 4), uint64 vertex and triangle counts, positions, normals,
// uvs and colours (float or double, by the flags) and uint32 indices; after
// the last shape an offset table (uint32 in version 3, uint64 in version 4)
// and the uint32 shape count. Every count and offset is checked against the
// file before it is used, so a lying or truncated file is an InputError
// "file: byte N: problem".
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "luz/math/vec.h"

namespace luz {

struct SerializedMesh {
  std::string name;           // version 4 only
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;  // empty, or one per position
  std::vector<Vec2> uvs;      // empty, or one per position, as stored
  std::vector<Color> colors;  // empty, or one per position, as stored (Mitsuba's vertex_color)
  std::vector<uint32_t> indices;
  bool face_normals = false;  // flag 0x0010: shade with face normals
};

SerializedMesh read_serialized(const std::string& path, uint32_t shape_index);
// A whole file's bytes (scenes that read many shapes of one file keep them).
std::vector<uint8_t> read_binary_file(const std::string& path);
// The same, from memory (tests, fuzzing); `name` is the file name for messages.
SerializedMesh read_serialized_memory(const std::string& name, const uint8_t* data, size_t size, uint32_t shape_index);

}  // namespace luz
