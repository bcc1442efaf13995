// The PLY reader (luz/io/mesh_ply.h): one mesh written by this test in the
// three encodings gives the same arrays, equal to the values written; the
// shared bunny and every shared PLY load with their documented counts; every
// malformed input (a table, every truncation, random byte flips) is one
// InputError naming the file and the line or byte. Prints the load times of
// the bunny and the staircase's 774 meshes.
#include <gtest/gtest.h>
#include <zlib.h>

#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "temp_dir.h"
#include "luz/io/error.h"
#include "luz/io/mesh_ply.h"

namespace fs = std::filesystem;
using luz::PlyMesh;

namespace {

// A PLY file described by value, encoded in any of the three formats.
struct PlyProperty {
  std::string type, name;
  std::string count_type;  // empty: a scalar
};
struct PlyElement {
  std::string name;
  std::vector<PlyProperty> props;
  std::vector<std::vector<std::vector<double>>> rows;  // [entry][property] -> values (1 for a scalar)
};

void put(std::string& out, const std::string& type, double v, bool big) {
  char b[8];
  size_t n = 0;
  auto raw = [&](auto x) {
    n = sizeof x;
    std::memcpy(b, &x, n);
  };
  if (type == "char" || type == "int8") raw((int8_t)v);
  else if (type == "uchar" || type == "uint8") raw((uint8_t)v);
  else if (type == "short" || type == "int16") raw((int16_t)v);
  else if (type == "ushort" || type == "uint16") raw((uint16_t)v);
  else if (type == "int" || type == "int32") raw((int32_t)v);
  else if (type == "uint" || type == "uint32") raw((uint32_t)v);
  else if (type == "float" || type == "float32") raw((float)v);
  else raw(v);
  if (big == (std::endian::native == std::endian::little)) std::reverse(b, b + n);
  out.append(b, n);
}

std::string ascii(const std::string& type, double v) {
  char buf[64];
  if (type == "float" || type == "float32") std::snprintf(buf, sizeof buf, "%.9g", (float)v);
  else if (type == "double" || type == "float64") std::snprintf(buf, sizeof buf, "%.17g", v);
  else std::snprintf(buf, sizeof buf, "%lld", (long long)v);
  return buf;
}

std::string encode(const std::vector<PlyElement>& elements, const std::string& format) {
  std::string out = "ply\nformat " + format + " 1.0\ncomment written by test_mesh_ply\nobj_info nothing\n";
  for (const PlyElement& e : elements) {
    out += "element " + e.name + " " + std::to_string(e.rows.size()) + "\n";
    for (const PlyProperty& p : e.props)
      out += "property " + (p.count_type.empty() ? "" : "list " + p.count_type + " ") + p.type + " " + p.name + "\n";
  }
  out += "end_header\n";
  for (const PlyElement& e : elements)
    for (const auto& row : e.rows) {
      for (size_t j = 0; j < e.props.size(); ++j) {
        const PlyProperty& p = e.props[j];
        if (format == "ascii") {
          if (!p.count_type.empty()) out += std::to_string(row[j].size()) + " ";
          for (double v : row[j]) out += ascii(p.type, v) + " ";
        } else {
          if (!p.count_type.empty()) put(out, p.count_type, (double)row[j].size(), format == "binary_big_endian");
          for (double v : row[j]) put(out, p.type, v, format == "binary_big_endian");
        }
      }
      if (format == "ascii") out.back() = '\n';
    }
  return out;
}

// Six vertices (positions of mixed types, double normals, texture_u/_v,
// skipped scalars and a skipped list), a triangle, a quad and a pentagon
// with per-face material indices, and elements before and after them.
std::vector<PlyElement> test_mesh() {
  PlyElement camera{"camera", {{"float", "view_px"}, {"double", "view_py"}}, {{{1.5}, {-2.25}}}};
  PlyElement vertex{"vertex",
                    {{"float", "x"},
                     {"double", "y"},
                     {"short", "z"},
                     {"uchar", "confidence"},
                     {"float64", "nx"},
                     {"float32", "ny"},
                     {"double", "nz"},
                     {"int", "ids", "uint8"},
                     {"float", "texture_u"},
                     {"float", "texture_v"},
                     {"uchar", "red"},
                     {"ushort", "green"},
                     {"float", "blue"}},
                    {}};
  for (int i = 0; i < 6; ++i) {
    double a = 0.1 * i + 1e-3;
    vertex.rows.push_back({{a}, {-3.7 * a + 1e10 * (i == 5)}, {(double)(i * 1000 - 2000)}, {(double)(200 + i)},
                           {std::sin(a)}, {std::cos(a)}, {-a}, std::vector<double>(i % 3, 7.0), {a * a}, {1 - a},
                           {10.0 * i}, {1000.0 * i}, {0.1 * i}});
  }
  PlyElement face{"face",
                  {{"uint16", "intensity"}, {"uint", "vertex_indices", "ushort"}, {"int8", "face_indices"},
                   {"float", "r"}, {"float", "g"}, {"uchar", "b"}},
                  {{{65535}, {0, 1, 2}, {-3}, {.25}, {.5}, {255}},
                   {{0}, {1, 2, 3, 4}, {5}, {0}, {1}, {0}},
                   {{12}, {5, 4, 3, 2, 1}, {127}, {1}, {.125}, {64}}}};
  PlyElement grid{"range_grid", {{"int", "vertex_indices", "uchar"}}, {{{}}, {{1, 2, 3}}, {{-4}}}};
  return {camera, vertex, face, grid};
}

void expect_equal_meshes(const PlyMesh& a, const PlyMesh& b) {
  auto bytes = [](const auto& v) { return std::string((const char*)v.data(), v.size() * sizeof v[0]); };
  EXPECT_EQ(bytes(a.positions), bytes(b.positions));
  EXPECT_EQ(bytes(a.normals), bytes(b.normals));
  EXPECT_EQ(bytes(a.uvs), bytes(b.uvs));
  EXPECT_EQ(bytes(a.colors), bytes(b.colors));
  EXPECT_EQ(bytes(a.face_colors), bytes(b.face_colors));
  EXPECT_EQ(a.indices, b.indices);
  EXPECT_EQ(a.face_indices, b.face_indices);
  EXPECT_EQ(a.face_first_triangle, b.face_first_triangle);
}

PlyMesh read(const std::string& text, const std::string& name = "mem.ply") {
  return luz::read_ply_memory(name, text.data(), text.size());
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

const std::string kShared = LUZ_SHARED_DIR "/scenes";

}  // namespace

TEST(Ply, ThreeEncodingsGiveTheValuesWritten) {
  std::vector<PlyElement> elements = test_mesh();
  PlyMesh asc = read(encode(elements, "ascii"));
  PlyMesh le = read(encode(elements, "binary_little_endian"));
  PlyMesh be = read(encode(elements, "binary_big_endian"));

  const PlyElement& v = elements[1];
  ASSERT_EQ(asc.positions.size(), 6u);
  ASSERT_EQ(asc.normals.size(), 6u);
  ASSERT_EQ(asc.uvs.size(), 6u);
  ASSERT_EQ(asc.colors.size(), 6u);
  for (size_t i = 0; i < 6; ++i) {
    const auto& r = v.rows[i];
    EXPECT_EQ(asc.positions[i].x, (float)r[0][0]);
    EXPECT_EQ(asc.positions[i].y, (float)r[1][0]);
    EXPECT_EQ(asc.positions[i].z, (float)r[2][0]);
    EXPECT_EQ(asc.normals[i].x, (float)r[4][0]);
    EXPECT_EQ(asc.normals[i].y, (float)r[5][0]);
    EXPECT_EQ(asc.normals[i].z, (float)r[6][0]);
    EXPECT_EQ(asc.uvs[i].x, (float)r[8][0]);
    EXPECT_EQ(asc.uvs[i].y, (float)r[9][0]);
    // Colours: integer channels over their type's maximum, sRGB-decoded
    // (Mitsuba 3's reading); a float channel as written.
    auto srgb = [](double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); };
    EXPECT_NEAR(asc.colors[i].x, srgb(r[10][0] / 255.0), 1e-7);
    EXPECT_NEAR(asc.colors[i].y, srgb(r[11][0] / 65535.0), 1e-7);
    EXPECT_EQ(asc.colors[i].z, (float)r[12][0]);
  }
  // Fans: (0 1 2), (1 2 3 4) -> 2 triangles, (5 4 3 2 1) -> 3.
  std::vector<uint32_t> tris = {0, 1, 2, 1, 2, 3, 1, 3, 4, 5, 4, 3, 5, 3, 2, 5, 2, 1};
  EXPECT_EQ(asc.indices, tris);
  EXPECT_EQ(asc.face_indices, (std::vector<int32_t>{-3, 5, 5, 127, 127, 127}));
  EXPECT_EQ(asc.face_first_triangle, (std::vector<uint32_t>{0, 1, 3}));
  // Face colours, one per output triangle (a float channel as written, a uchar one sRGB-decoded).
  ASSERT_EQ(asc.face_colors.size(), 6u);
  EXPECT_EQ(asc.face_colors[0].x, .25f);
  EXPECT_EQ(asc.face_colors[0].z, 1.f);
  EXPECT_EQ(asc.face_colors[2].y, 1.f);
  EXPECT_EQ(asc.face_colors[5].y, .125f);
  EXPECT_NEAR(asc.face_colors[5].z, std::pow((64 / 255.0 + 0.055) / 1.055, 2.4), 1e-7);
  expect_equal_meshes(asc, le);
  expect_equal_meshes(asc, be);
}

TEST(Ply, NamesAndLayouts) {
  // s/t and vertex_index; CRLF line endings; blank lines between entries;
  // faces before vertices; an element without properties.
  std::string text =
      "ply\r\nformat ascii 1.0\r\nelement empty 5\r\nelement face 2\r\nproperty list int int vertex_index\r\n"
      "element vertex 4\r\nproperty float s\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n"
      "property float t\r\nend_header\r\n3 0 1 2\r\n\r\n4 0 1 2 3\r\n0.25 0 0 0 0.5\r\n1 1 0 0 1\r\n"
      "1 1 1 0 1\r\n 1 0 1 0 1 \r\n\r\n";
  PlyMesh m = read(text);
  EXPECT_EQ(m.positions.size(), 4u);
  EXPECT_TRUE(m.normals.empty());
  ASSERT_EQ(m.uvs.size(), 4u);
  EXPECT_EQ(m.uvs[0].x, 0.25f);
  EXPECT_EQ(m.uvs[0].y, 0.5f);
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2, 0, 1, 2, 0, 2, 3}));
  EXPECT_EQ(m.face_first_triangle, (std::vector<uint32_t>{0, 1}));
  EXPECT_TRUE(m.face_indices.empty());

  // u/v and texture_s/texture_t; an empty face element.
  for (std::string uv : {"u v", "texture_s texture_t"}) {
    std::string u = uv.substr(0, uv.find(' ')), w = uv.substr(uv.find(' ') + 1);
    PlyMesh n = read("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                     "property float " + u + "\nproperty float " + w +
                     "\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n1 2 3 4 5\n");
    ASSERT_EQ(n.uvs.size(), 1u) << uv;
    EXPECT_EQ(n.uvs[0].x, 4.f);
    EXPECT_EQ(n.uvs[0].y, 5.f);
    EXPECT_TRUE(n.indices.empty());
  }
}

// Stanford's bunny: counts from SOURCES.md, the first and last vertex and
// face read back with sscanf.
TEST(Ply, Bunny) {
  std::string path = kShared + "/bunny/bun_zipper.ply";
  auto t0 = std::chrono::steady_clock::now();
  PlyMesh m = luz::read_ply(path);
  double t = seconds_since(t0);
  std::printf("[   TIME   ] read_ply(bun_zipper.ply): %.4f s (35,947 vertices, 69,451 triangles, ASCII)\n", t);
  ASSERT_EQ(m.positions.size(), 35947u);
  ASSERT_EQ(m.indices.size(), 3u * 69451u);
  EXPECT_TRUE(m.normals.empty() && m.uvs.empty() && m.face_indices.empty());
  EXPECT_TRUE(m.face_first_triangle.empty()) << "every face a triangle";

  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line) && line != "end_header") {}
  std::vector<std::string> lines;
  while (std::getline(in, line)) lines.push_back(line);
  ASSERT_EQ(lines.size(), 35947u + 69451u);
  for (size_t i : {size_t(0), size_t(35946)}) {
    float x, y, z;
    ASSERT_EQ(std::sscanf(lines[i].c_str(), "%f %f %f", &x, &y, &z), 3);
    EXPECT_EQ(m.positions[i].x, x);
    EXPECT_EQ(m.positions[i].y, y);
    EXPECT_EQ(m.positions[i].z, z);
  }
  for (size_t f : {size_t(0), size_t(69450)}) {
    unsigned n, a, b, c;
    ASSERT_EQ(std::sscanf(lines[35947 + f].c_str(), "%u %u %u %u", &n, &a, &b, &c), 4);
    EXPECT_EQ(n, 3u);
    EXPECT_EQ(m.indices[3 * f], a);
    EXPECT_EQ(m.indices[3 * f + 1], b);
    EXPECT_EQ(m.indices[3 * f + 2], c);
  }
}

// Every PLY under the shared scenes; the staircase's 774 meshes hold the
// 262,661 triangles SOURCES.md gives for its meshes.
TEST(Ply, EverySharedFileLoads) {
  size_t files = 0, staircase_files = 0, staircase_triangles = 0;
  double staircase_seconds = 0;
  for (const auto& entry : fs::recursive_directory_iterator(kShared)) {
    if (entry.path().extension() != ".ply") continue;
    std::string path = entry.path().string();
    auto t0 = std::chrono::steady_clock::now();
    PlyMesh m;
    try {
      m = luz::read_ply(path);
    } catch (const luz::InputError& e) {
      ADD_FAILURE() << e.what();
      continue;
    }
    double t = seconds_since(t0);
    ++files;
    EXPECT_FALSE(m.positions.empty()) << path;
    EXPECT_FALSE(m.indices.empty()) << path;
    EXPECT_EQ(m.indices.size() % 3, 0u) << path;
    EXPECT_TRUE(m.normals.empty() || m.normals.size() == m.positions.size()) << path;
    EXPECT_TRUE(m.uvs.empty() || m.uvs.size() == m.positions.size()) << path;
    for (uint32_t i : m.indices) ASSERT_LT(i, m.positions.size()) << path;
    if (path.find("/staircase/pbrt-v4/") != std::string::npos) {
      ++staircase_files;
      staircase_triangles += m.indices.size() / 3;
      staircase_seconds += t;
    }
  }
  std::printf("[   TIME   ] read_ply of the staircase's %zu PLY files, one after another: %.3f s (%zu triangles)\n",
              staircase_files, staircase_seconds, staircase_triangles);
  EXPECT_EQ(files, 4u + 774u + 3u + 12u);
  EXPECT_EQ(staircase_files, 774u);
  EXPECT_EQ(staircase_triangles, 262661u);
}

namespace {

// The what() of the InputError that reading `text` throws ("" if none).
std::string error_of(const std::string& text, const std::string& name = "bad.ply") {
  try {
    read(text, name);
  } catch (const luz::InputError& e) {
    return e.what();
  }
  return "";
}

const std::string kVertexHeader =
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
const std::string kFaceHeader = "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
const std::string kData = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";  // lines 10 to 13

}  // namespace

TEST(Ply, MalformedInputs) {
  std::string le = encode(test_mesh(), "binary_little_endian");
  size_t header_end = le.find("end_header\n") + 11;
  // Three float vertices (36 bytes), then a face: count at byte 36, indices at 37, 41, 45.
  PlyElement vertex{"vertex", {{"float", "x"}, {"float", "y"}, {"float", "z"}}, {{{0}, {0}, {0}}, {{1}, {0}, {0}}, {{0}, {1}, {0}}}};
  PlyElement face{"face", {{"int", "vertex_indices", "uchar"}}, {{{0, 1, 3}}}};
  std::string bad_index = encode({vertex, face}, "binary_big_endian");
  size_t bad_index_at = bad_index.find("end_header\n") + 11 + 45;
  struct Case {
    std::string what, text, expected;  // expected: the message's start
  };
  std::vector<Case> cases = {
      {"empty file", "", "bad.ply:1: not a PLY file"},
      {"not ply", "plx\n", "bad.ply:1: not a PLY file"},
      {"ply then text", "plyfoo\nformat ascii 1.0\n", "bad.ply:1: not a PLY file"},
      {"no end_header", kVertexHeader, "bad.ply:6: the header has no end_header"},
      {"no format", "ply\nelement vertex 1\n", "bad.ply:2: an element before the format line"},
      {"unknown format", "ply\nformat binary 1.0\n", "bad.ply:2: unknown format 'binary'"},
      {"version", "ply\nformat ascii 2.0\n", "bad.ply:2: unsupported PLY version"},
      {"unknown keyword", "ply\nformat ascii 1.0\nelemnt vertex 1\n", "bad.ply:3: unknown header line"},
      {"unknown type", kVertexHeader + "property float128 w\n" + kFaceHeader + kData, "bad.ply:7: unknown property type 'float128'"},
      {"unknown list type", kVertexHeader + "element face 1\nproperty list byte int vertex_indices\nend_header\n",
       "bad.ply:8: unknown property type 'byte'"},
      {"float list count", kVertexHeader + "element face 1\nproperty list float int vertex_indices\nend_header\n",
       "bad.ply:8: list 'vertex_indices': the count type"},
      {"float indices", kVertexHeader + "element face 1\nproperty list uchar float vertex_indices\nend_header\n",
       "bad.ply:8: face property 'vertex_indices' must list an integer type"},
      {"property first", "ply\nformat ascii 1.0\nproperty float x\n", "bad.ply:3: a property before any element"},
      {"bad count", "ply\nformat ascii 1.0\nelement vertex -1\n", "bad.ply:3: element 'vertex': count '-1'"},
      {"duplicate property", kVertexHeader + "property float x\n", "bad.ply:7: element 'vertex' has a second property 'x'"},
      {"duplicate element", kVertexHeader + "element vertex 1\n", "bad.ply:7: a second element 'vertex'"},
      {"missing vertex", "ply\nformat ascii 1.0\n" + kFaceHeader + "3 0 1 2\n", "bad.ply:5: the header declares no 'vertex'"},
      {"missing face", kVertexHeader + "end_header\n0 0 0\n1 0 0\n0 1 0\n", "bad.ply:7: the header declares no 'face'"},
      {"tristrips", kVertexHeader + "element tristrips 1\nproperty list int int vertex_indices\nend_header\n",
       "bad.ply:7: triangle strips (element 'tristrips') are not supported"},
      {"missing z", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n" + kFaceHeader,
       "bad.ply:4: vertex property 'x' without 'z'"},
      {"half normal", kVertexHeader + "property float nx\n" + kFaceHeader, "bad.ply:7: vertex property 'nx' without 'ny'"},
      {"list x", "ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\n" + kFaceHeader, "bad.ply:4: property 'x' must be a scalar"},
      {"no indices", kVertexHeader + "element face 1\nproperty uchar n\nend_header\n", "bad.ply:7: element 'face' has no 'vertex_indices'"},
      {"absurd vertex count", "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\n"
                              "property float z\n" + kFaceHeader + kData,
       "bad.ply:3: element 'vertex' declares 4000000000 entries"},
      {"absurd face count", kVertexHeader + "element face 99999999999999999\nproperty list uchar int vertex_indices\n"
                            "end_header\n" + kData,
       "bad.ply:7: element 'face' declares 99999999999999999 entries"},
      {"count past 2^64", kVertexHeader + "element face 99999999999999999999\n", "bad.ply:7: element 'face': count"},
      {"header lies (fewer)", kVertexHeader + kFaceHeader + kData + "3 0 1 2\n", "bad.ply:14: data after the last element"},
      {"header lies (more)", kVertexHeader + "element face 2\nproperty list uchar int vertex_indices\nend_header\n" + kData,
       "bad.ply:7: element 'face' declares 2 entries, which need at least 2 x 8 bytes, but only 26 bytes follow"},
      {"header lies (more, padded)", kVertexHeader + "element face 2\nproperty list uchar int vertex_indices\nend_header\n" + kData + "\n\n\n\n\n\n\n\n",
       "bad.ply:22: face 1: the file ends before it"},
      {"non-numeric", kVertexHeader + kFaceHeader + "0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n", "bad.ply:11: vertex 1: 'zero' is not a number"},
      {"non-integer index", kVertexHeader + kFaceHeader + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2.0\n", "bad.ply:13: face 0: '2.0' is not an integer"},
      {"uchar out of range", kVertexHeader + kFaceHeader + "0 0 0\n1 0 0\n0 1 0\n256 0 1 2\n", "bad.ply:13: face 0: '256' is out of"},
      {"extra tokens", kVertexHeader + kFaceHeader + "0 0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", "bad.ply:10: vertex 0: extra value '0'"},
      {"too few tokens", kVertexHeader + kFaceHeader + "0 0 0\n1 0   \n0 1 0\n3 0 1 2\n", "bad.ply:11: vertex 1: too few values"},
      {"index too large", kVertexHeader + kFaceHeader + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "bad.ply:13: face 0: vertex index 3 is out of range"},
      {"negative index", kVertexHeader + kFaceHeader + "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", "bad.ply:13: face 0: vertex index -1"},
      {"two-vertex face", kVertexHeader + kFaceHeader + "0 0 0\n1 0 0\n0 1 0\n2 0 1   \n", "bad.ply:13: face 0: it has 2 vertices"},
      {"nan position", kVertexHeader + kFaceHeader + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", "bad.ply:11: vertex 1: its position is not finite"},
      {"inf position", kVertexHeader + kFaceHeader + "0 0 0\n1 0 1e39\n0 1 0\n3 0 1 2\n", "bad.ply:11: vertex 1: its position is not finite"},
      {"binary index too large", bad_index, "bad.ply: byte " + std::to_string(bad_index_at) + ": face 0: vertex index 3 is out of range"},
      // The last entry of range_grid is a count (1 byte) and one int.
      {"binary truncated by 1", le.substr(0, le.size() - 1), "bad.ply: byte " + std::to_string(le.size() - 4) + ": range_grid 2: the file ends inside it"},
      {"binary truncated by 4", le.substr(0, le.size() - 4), "bad.ply: byte " + std::to_string(le.size() - 4) + ": range_grid 2: the file ends inside it"},
      {"binary truncated after header", le.substr(0, header_end), "bad.ply:5: element 'camera' declares 1 entries"},
      {"binary trailing bytes", le + "x", "bad.ply: byte " + std::to_string(le.size()) + ": data after the last element (1 bytes"},
  };
  // Cuts inside the data that the header's minimum sizes still allow (they
  // count 3 indices per face and no items for other lists).
  for (size_t cut : {size_t(10), size_t(20), size_t(30)}) {
    size_t n = le.size() - cut;
    cases.push_back({"binary truncated by " + std::to_string(cut), le.substr(0, n), "bad.ply: byte "});
  }
  for (const Case& c : cases) {
    std::string msg = error_of(c.text);
    EXPECT_EQ(msg.substr(0, c.expected.size()), c.expected) << c.what << ": " << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << c.what;
  }
}

// Every prefix of each encoding, and random bytes overwritten: each either
// loads or gives an InputError that names the file and a line or byte.
TEST(Ply, TruncationsAndCorruptionsAreInputErrors) {
  std::regex located(R"(^bad\.ply(:[0-9]+|: byte [0-9]+): [^\n]+$)");
  std::mt19937 rng(18);
  for (std::string format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
    std::string full = encode(test_mesh(), format);
    for (size_t n = 0; n + 1 < full.size(); ++n) {
      std::string msg = error_of(full.substr(0, n));
      EXPECT_TRUE(std::regex_match(msg, located)) << format << " cut at " << n << ": '" << msg << "'";
    }
    for (int trial = 0; trial < 3000; ++trial) {
      std::string text = full;
      for (int k = 0; k < 3; ++k) text[rng() % text.size()] = (char)(rng() % 256);
      try {
        read(text, "bad.ply");
      } catch (const luz::InputError& e) {
        EXPECT_TRUE(std::regex_match(std::string(e.what()), located)) << e.what();
      }
    }
  }
}

std::string gzip(const std::string& in) {
  z_stream zs{};
  EXPECT_EQ(deflateInit2(&zs, 9, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out(deflateBound(&zs, in.size()), '\0');
  zs.next_in = (Bytef*)in.data();
  zs.avail_in = (uInt)in.size();
  zs.next_out = (Bytef*)out.data();
  zs.avail_out = (uInt)out.size();
  EXPECT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

class PlyFile : public TempDirTest {};

TEST_F(PlyFile, Gzip) {
  std::string le = encode(test_mesh(), "binary_little_endian");
  std::string gz = gzip(le);
  expect_equal_meshes(luz::read_ply(write("mesh.ply.gz", gz)), read(le));

  std::string path = write("cut.ply.gz", gz.substr(0, gz.size() / 2));
  std::string msg;
  try {
    luz::read_ply(path);
  } catch (const luz::InputError& e) {
    msg = e.what();
  }
  EXPECT_EQ(msg.rfind(path + ": byte ", 0), 0u) << msg;
  EXPECT_NE(msg.find("truncated"), std::string::npos) << msg;

  // Corrupted compressed data: an InputError at a byte, or (where the
  // damage misses the checksummed parts) a mesh.
  std::mt19937 rng(18);
  for (int trial = 0; trial < 300; ++trial) {
    std::string text = gz;
    text[2 + rng() % (text.size() - 2)] = (char)(rng() % 256);
    path = write("bad.ply.gz", text);
    try {
      luz::read_ply(path);
    } catch (const luz::InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path + ": byte ", 0), 0u) << e.what();
    }
  }

  // An error in the decompressed data says where its byte count starts.
  std::string bad = le + "x";
  path = write("long.ply.gz", gzip(bad));
  msg.clear();
  try {
    luz::read_ply(path);
  } catch (const luz::InputError& e) {
    msg = e.what();
  }
  EXPECT_EQ(msg, path + ": byte " + std::to_string(le.size()) +
                     " of the decompressed data: data after the last element (1 bytes; do the header's counts match the data?)");
}

TEST(Ply, FileErrors) {
  std::string msg;
  try {
    luz::read_ply("/nonexistent/mesh.ply");
  } catch (const luz::InputError& e) {
    msg = e.what();
  }
  EXPECT_EQ(msg.rfind("/nonexistent/mesh.ply: cannot open", 0), 0u) << msg;
}
