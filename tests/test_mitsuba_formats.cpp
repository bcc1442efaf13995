// The Mitsuba reader's formats and plugins beyond the core: serialized meshes
// (mesh_serialized.h, and malformed files), ply, disk, cylinder, shapegroup
// and instance, include, coating, old integrator names, camelCase upgrade,
// hdrfilm's formats in the EXR output, and every shared Mitsuba scene
// loading and rendering with its quirks.
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "sanitizer.h"
#include "scene_helpers.h"
#include "temp_dir.h"
#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "luz/io/mesh_serialized.h"

namespace fs = std::filesystem;
using luz::Vec3;

namespace {

const std::string kScenes = LUZ_SHARED_DIR "/scenes/";

// ---- serialized files, written as Mitsuba's format documents ----
template <typename T>
void put(std::vector<uint8_t>& b, T v) {
  for (size_t i = 0; i < sizeof(T); ++i) b.push_back(uint8_t(uint64_t(v) >> (8 * i)));
}
void put_float(std::vector<uint8_t>& b, float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  put(b, u);
}
void put_double(std::vector<uint8_t>& b, double d) {
  uint64_t u;
  std::memcpy(&u, &d, 8);
  put(b, u);
}
// One shape: header + zlib stream. `tri` a triangle; uvs when `with_uv`,
// vertex colours (0.1, 0.2, 0.3) · (k + 1) when `with_color`.
std::vector<uint8_t> shape_bytes(uint16_t version, bool dbl, bool with_uv, float shift, uint64_t claimed_vertices = 3,
                                 bool with_color = false) {
  std::vector<uint8_t> raw;
  put(raw, uint32_t((dbl ? 0x2000 : 0x1000) | (with_uv ? 0x0002 : 0) | (with_color ? 0x0008 : 0)));
  if (version == 4)
    for (char c : std::string("tri")) raw.push_back(uint8_t(c));
  if (version == 4) raw.push_back(0);
  put(raw, claimed_vertices);
  put(raw, uint64_t(1));
  const float p[9] = {shift, 0, 0, shift + 1, 0, 0, shift, 1, 0};
  for (float v : p) dbl ? put_double(raw, v) : put_float(raw, v);
  if (with_uv)
    for (float v : {0.f, 0.f, 1.f, 0.f, 0.f, 1.f}) dbl ? put_double(raw, v) : put_float(raw, v);
  if (with_color)
    for (int k = 0; k < 3; ++k)
      for (float c : {0.1f, 0.2f, 0.3f}) dbl ? put_double(raw, c * float(k + 1)) : put_float(raw, c * float(k + 1));
  for (uint32_t i : {0u, 1u, 2u}) put(raw, i);
  uLongf len = compressBound(uLong(raw.size()));
  std::vector<uint8_t> z(len);
  EXPECT_EQ(compress(z.data(), &len, raw.data(), uLong(raw.size())), Z_OK);
  z.resize(len);
  std::vector<uint8_t> out;
  put(out, uint16_t(0x041C));
  put(out, version);
  out.insert(out.end(), z.begin(), z.end());
  return out;
}
// Two shapes (shift 0 and 10) with the end-of-file table.
std::vector<uint8_t> two_shapes(uint16_t version, bool dbl) {
  std::vector<uint8_t> f = shape_bytes(version, dbl, true, 0.f);
  const uint64_t second = f.size();
  std::vector<uint8_t> s = shape_bytes(version, dbl, false, 10.f);
  f.insert(f.end(), s.begin(), s.end());
  for (uint64_t off : {uint64_t(0), second}) version == 4 ? put(f, off) : put(f, uint32_t(off));
  put(f, uint32_t(2));
  return f;
}

void expect_serialized_error(const std::vector<uint8_t>& data, uint32_t index, const std::string& problem) {
  try {
    luz::read_serialized_memory("m.serialized", data.data(), data.size(), index);
    ADD_FAILURE() << "accepted (wanted: " << problem << ")";
  } catch (const luz::InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("m.serialized: byte ", 0), 0u) << what;
    EXPECT_NE(what.find(problem), std::string::npos) << what << " (wanted: " << problem << ")";
  }
}

TEST(Serialized, ReadsVersions3And4FloatAndDoubleByShapeIndex) {
  for (uint16_t version : {3, 4})
    for (bool dbl : {false, true}) {
      const std::vector<uint8_t> f = two_shapes(version, dbl);
      luz::SerializedMesh a = luz::read_serialized_memory("m", f.data(), f.size(), 0);
      luz::SerializedMesh b = luz::read_serialized_memory("m", f.data(), f.size(), 1);
      ASSERT_EQ(a.positions.size(), 3u);
      EXPECT_EQ(a.positions[1].x, 1.f);
      EXPECT_EQ(b.positions[1].x, 11.f);
      EXPECT_EQ(a.uvs.size(), 3u);
      EXPECT_TRUE(b.uvs.empty());
      EXPECT_EQ(a.indices, (std::vector<uint32_t>{0, 1, 2}));
      EXPECT_EQ(a.name, version == 4 ? "tri" : "");
    }
}

TEST(Serialized, MalformedFilesAreOneInputErrorAtAByte) {
  const std::vector<uint8_t> good = two_shapes(4, false);
  expect_serialized_error({0x1C}, 0, "truncated header");
  std::vector<uint8_t> bad = good;
  bad[0] = 0;
  expect_serialized_error(bad, 0, "not a Mitsuba .serialized file");
  bad = good;
  bad[2] = 9;
  expect_serialized_error(bad, 0, "unsupported version 9");
  expect_serialized_error(good, 2, "shape_index 2 is out of range (the file holds 2 shapes)");
  bad = good;
  bad[bad.size() - 4] = 0xff;  // a table of 255 shapes
  expect_serialized_error(bad, 1, "does not fit the file");
  bad = good;
  bad[bad.size() - 5] = 0x7f;  // shape 1's offset far beyond the end
  expect_serialized_error(bad, 1, "lies beyond the file's end");
  // A count that no compressed data of this size can hold: refused before allocating.
  const std::vector<uint8_t> lying = shape_bytes(4, false, false, 0.f, uint64_t(1) << 31);
  expect_serialized_error(lying, 0, "need more data than");
  // Every truncation of one shape: an InputError, never a crash.
  const std::vector<uint8_t> one = shape_bytes(3, false, true, 0.f);
  for (size_t n = 0; n < one.size(); ++n) {
    std::vector<uint8_t> t(one.begin(), one.begin() + std::ptrdiff_t(n));
    EXPECT_THROW(luz::read_serialized_memory("m", t.data(), t.size(), 0), luz::InputError) << n;
  }
  // An index past the vertices.
  std::vector<uint8_t> raw;
  put(raw, uint32_t(0x1000));
  put(raw, uint64_t(3));
  put(raw, uint64_t(1));
  for (int i = 0; i < 9; ++i) put_float(raw, 0.f);
  for (uint32_t i : {0u, 1u, 7u}) put(raw, i);
  uLongf len = compressBound(uLong(raw.size()));
  std::vector<uint8_t> z(len);
  compress(z.data(), &len, raw.data(), uLong(raw.size()));
  std::vector<uint8_t> f;
  put(f, uint16_t(0x041C));
  put(f, uint16_t(3));
  f.insert(f.end(), z.begin(), z.begin() + std::ptrdiff_t(len));
  expect_serialized_error(f, 0, "names vertex 7 of 3");
}

class MitsubaFormats : public TempDirTest {
 protected:
  static std::string scene(const std::string& body, const std::string& version = "3.0.0") {
    return "<scene version=\"" + version + "\">\n<sensor type=\"perspective\"/>\n" + body + "</scene>\n";
  }
  // The same with a rectangle after body (a scene needs a shape).
  static std::string scene_with_shape(const std::string& body, const std::string& version = "3.0.0") {
    return scene(body + "<shape type=\"rectangle\"/>\n", version);
  }
  luz::Scene load(const std::string& text) { return luz::load_mitsuba(write("scene.xml", text)); }
  void expect_error(const std::string& text, const std::string& where, const std::string& problem) {
    try {
      load(text);
      ADD_FAILURE() << "accepted (wanted: " << problem << ")";
    } catch (const luz::InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(where), std::string::npos) << what << " (wanted at " << where << ")";
      EXPECT_NE(what.find(problem), std::string::npos) << what << " (wanted: " << problem << ")";
      EXPECT_EQ(what.find('\n'), std::string::npos);
    }
  }
  static double area(const luz::Scene& s) {
    double a = 0;
    for (size_t k = 0; k + 2 < s.indices.size(); k += 3) {
      const Vec3 p0 = s.positions[s.indices[k]], p1 = s.positions[s.indices[k + 1]], p2 = s.positions[s.indices[k + 2]];
      a += 0.5 * luz::length(luz::cross(p1 - p0, p2 - p0));
    }
    return a;
  }
  static bool warned(const luz::Scene& s, const std::string& text) {
    for (const std::string& w : s.warnings)
      if (w.find(text) != std::string::npos) return true;
    return false;
  }
};

TEST_F(MitsubaFormats, SerializedAndPlyShapes) {
  const std::vector<uint8_t> f = two_shapes(3, false);
  std::ofstream(dir / "m.serialized", std::ios::binary).write(reinterpret_cast<const char*>(f.data()), std::streamsize(f.size()));
  write("t.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                 "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n2 0 0\n0 2 0\n3 0 1 2\n");
  luz::Scene s = load(scene("<shape type=\"serialized\"><string name=\"filename\" value=\"m.serialized\"/>"
                            "<integer name=\"shape_index\" value=\"1\"/></shape>\n"
                            "<shape type=\"ply\"><string name=\"filename\" value=\"t.ply\"/>"
                            "<transform name=\"to_world\"><translate z=\"5\"/></transform></shape>\n"));
  ASSERT_EQ(s.positions.size(), 6u);
  EXPECT_EQ(s.positions[1].x, 11.f);  // shape 1 of the file
  EXPECT_EQ(s.positions[4].x, 2.f);
  EXPECT_EQ(s.positions[4].z, 5.f);
  expect_error(scene("<shape type=\"serialized\"><string name=\"filename\" value=\"m.serialized\"/>"
                     "<integer name=\"shape_index\" value=\"5\"/></shape>\n"),
               "m.serialized: byte", "shape_index 5 is out of range");
  write("bad.ply", "ply\nformat ascii 1.0\nelement vertex 1\n");
  expect_error(scene("<shape type=\"ply\"><string name=\"filename\" value=\"bad.ply\"/></shape>\n"), "bad.ply", "");
}

// A serialized file's vertex colours are Mitsuba's vertex_color attribute;
// in a shapegroup placed twice they stay with the instanced object's
// vertices, and an instance's hit reads its object's colours.
TEST_F(MitsubaFormats, SerializedVertexColoursAlsoInInstances) {
  for (bool dbl : {false, true}) {
    const std::vector<uint8_t> f = shape_bytes(4, dbl, false, 0.f, 3, true);
    std::ofstream(dir / "c.serialized", std::ios::binary).write(reinterpret_cast<const char*>(f.data()), std::streamsize(f.size()));
    const std::string shape = "<shape type=\"serialized\"><string name=\"filename\" value=\"c.serialized\"/>"
                              "<bsdf type=\"diffuse\"><texture name=\"reflectance\" type=\"mesh_attribute\">"
                              "<string name=\"name\" value=\"vertex_color\"/></texture></bsdf></shape>";
    luz::Scene s = load(scene(shape + "\n"));
    ASSERT_EQ(s.colors.size(), 3u);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(s.colors[size_t(k)].z, 0.3 * (k + 1), 1e-6) << dbl;
    luz::Scene inst = load(scene("<shape type=\"shapegroup\" id=\"g\">" + shape + "</shape>\n"
                                 "<shape type=\"instance\"><ref id=\"g\"/></shape>\n"
                                 "<shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\"><translate y=\"3\"/></transform></shape>\n"
                                 "<shape type=\"rectangle\"/>\n"));
    ASSERT_EQ(inst.instances.size(), 2u);
    ASSERT_EQ(inst.colors.size(), inst.positions.size());
    const luz::SceneView v = inst.view();
    luz::Hit hit;
    hit.prim = inst.objects[0].first_triangle;
    hit.inst = 1;
    hit.u = 0.f, hit.v = 1.f;  // the object's third vertex
    EXPECT_NEAR(v.hit_color(hit).y, 0.6f, 1e-6f) << dbl;
    hit.prim = 0, hit.inst = luz::kNoInstance;  // the rectangle: white
    EXPECT_EQ(v.hit_color(hit).x, 1.f);
  }
}

TEST_F(MitsubaFormats, DiskAndCylinderKeepMitsubasAreas) {
  // Disk: the unit disk scaled by 2 (area 4π); cylinder radius 0.5, length 3 (lateral area 3π).
  luz::Scene d = load(scene("<shape type=\"disk\"><transform name=\"to_world\"><scale value=\"2\"/></transform></shape>\n"));
  EXPECT_NEAR(area(d), 4 * std::numbers::pi, 1e-4 * 4 * std::numbers::pi);
  for (const Vec3& p : d.positions) EXPECT_LE(luz::length(p), 2.f * 1.0001f);
  luz::Scene c = load(scene("<shape type=\"cylinder\"><float name=\"radius\" value=\"0.5\"/>"
                            "<point name=\"p0\" x=\"1\" y=\"0\" z=\"0\"/><point name=\"p1\" x=\"1\" y=\"3\" z=\"0\"/></shape>\n"));
  EXPECT_NEAR(area(c), 3 * std::numbers::pi, 1e-4 * 3 * std::numbers::pi);
  // Normals point away from the axis (x = 1, z = 0), and so do the faces.
  for (size_t k = 0; k < c.positions.size(); ++k) {
    const Vec3 out{c.positions[k].x - 1.f, 0.f, c.positions[k].z};
    EXPECT_GT(luz::dot(c.normals[k], out), 0.f);
  }
  const Vec3 p0 = c.positions[c.indices[0]], p1 = c.positions[c.indices[1]], p2 = c.positions[c.indices[2]];
  const Vec3 g = luz::cross(p1 - p0, p2 - p0), mid = (p0 + p1 + p2) * (1.f / 3.f);
  EXPECT_GT(luz::dot(g, Vec3{mid.x - 1.f, 0.f, mid.z}), 0.f);
}

TEST_F(MitsubaFormats, InstancesGiveTheFlattenedGeometry) {
  const std::string rect = "<shape type=\"rectangle\"><transform name=\"to_world\"><translate x=\"1\"/></transform></shape>\n";
  luz::Scene inst = load(scene("<shape type=\"shapegroup\" id=\"g\">" + rect + "</shape>\n"
                               "<shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\"><translate y=\"3\"/></transform></shape>\n"
                               "<shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\"><scale value=\"2\"/></transform></shape>\n"));
  luz::Scene flat = load(scene("<shape type=\"rectangle\"><transform name=\"to_world\"><translate x=\"1\"/><translate y=\"3\"/></transform></shape>\n"
                               "<shape type=\"rectangle\"><transform name=\"to_world\"><translate x=\"1\"/><scale value=\"2\"/></transform></shape>\n"));
  // Stored once, placed twice; flattened (exact here: the maps are exact in
  // floats), the same triangles as the flat scene's.
  ASSERT_EQ(inst.objects.size(), 1u);
  ASSERT_EQ(inst.instances.size(), 2u);
  inst.flatten_instances();
  ASSERT_EQ(inst.positions.size(), flat.positions.size());
  for (size_t k = 0; k < flat.positions.size(); ++k) {
    EXPECT_EQ(inst.positions[k].x, flat.positions[k].x);
    EXPECT_EQ(inst.positions[k].y, flat.positions[k].y);
  }
  EXPECT_EQ(inst.indices, flat.indices);
  expect_error(scene("<shape type=\"instance\"><ref id=\"nope\"/></shape>\n"), "scene.xml:3", "no shapegroup with id 'nope'");
  expect_error(scene("<shape type=\"shapegroup\" id=\"g\"><shape type=\"rectangle\"><emitter type=\"area\"/></shape></shape>\n"),
               "scene.xml:3", "emitter on a shape inside a shapegroup");
}

TEST_F(MitsubaFormats, IncludeIsRelativeToTheIncludingFileAndRefusesCycles) {
  fs::create_directories(dir / "sub");
  write("sub/part.xml", "<scene version=\"0.6.0\">\n<shape type=\"rectangle\"><transform name=\"toWorld\"><translate z=\"2\"/></transform>"
                        "<bsdf type=\"diffuse\" id=\"red\"/></shape>\n<include filename=\"more.xml\"/>\n</scene>\n");
  write("sub/more.xml", "<scene version=\"3.0.0\">\n<shape type=\"rectangle\"><ref id=\"red\"/></shape>\n</scene>\n");
  luz::Scene s = load(scene("<include filename=\"sub/part.xml\"/>\n"));
  ASSERT_EQ(s.positions.size(), 8u);
  EXPECT_EQ(s.positions[0].z, 2.f);  // the included 0.6 file's toWorld
  write("sub/loop.xml", "<scene version=\"3.0.0\">\n<include filename=\"../scene.xml\"/>\n</scene>\n");
  expect_error(scene("<include filename=\"sub/loop.xml\"/>\n"), "loop.xml:2", "includes itself");
  expect_error(scene("<include filename=\"missing.xml\"/>\n"), "scene.xml:3", "no such file");
  write("sub/broken.xml", "<scene version=\"3.0.0\">\n<shape type=\"rectangle\">\n</scene>\n");
  expect_error(scene("<include filename=\"sub/broken.xml\"/>\n"), "broken.xml:", "malformed XML");
}

TEST_F(MitsubaFormats, OldIntegratorNames) {
  luz::Scene d = load(scene_with_shape("<integrator type=\"direct\"><integer name=\"emitter_samples\" value=\"4\"/></integrator>\n"));
  EXPECT_EQ(d.settings.integrator.type, luz::IntegratorType::Path);
  EXPECT_EQ(d.settings.integrator.max_depth, 2);
  EXPECT_TRUE(warned(d, "scene.xml:3: warning: integrator 'direct'"));
  luz::Scene v = load(scene_with_shape("<integrator type=\"volpath\"><integer name=\"max_depth\" value=\"7\"/></integrator>\n"));
  EXPECT_EQ(v.settings.integrator.max_depth, 7);
  EXPECT_TRUE(v.warnings.empty());
  luz::Scene o = load(scene_with_shape("<integrator type=\"irrcache\"><integrator type=\"photonmapper\"><integer name=\"maxDepth\" "
                            "value=\"9\"/></integrator></integrator>\n", "0.6.0"));
  EXPECT_EQ(o.settings.integrator.type, luz::IntegratorType::Path);
  EXPECT_EQ(o.settings.integrator.max_depth, 9);
  EXPECT_TRUE(warned(o, "scene.xml:3: warning: integrator 'irrcache' is not supported"));
}

TEST_F(MitsubaFormats, CoatingMapsToTheNearestModel) {
  luz::Scene p = load(scene("<bsdf type=\"coating\" id=\"c\"><float name=\"int_ior\" value=\"1.5\"/>"
                            "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.5 0.4 0.3\"/></bsdf></bsdf>\n"
                            "<shape type=\"rectangle\"><ref id=\"c\"/></shape>\n"));
  EXPECT_EQ(p.materials.back().bsdf.type, luz::BsdfType::SmoothPlastic);
  luz::Scene m = load(scene("<bsdf type=\"coating\" id=\"c\"><float name=\"int_ior\" value=\"1.5\"/>"
                            "<float name=\"ext_ior\" value=\"1\"/><float name=\"thickness\" value=\"2\"/><rgb name=\"sigma_a\" value=\"0 0.1 0\"/>"
                            "<bsdf type=\"roughconductor\"/></bsdf>\n<shape type=\"rectangle\"><ref id=\"c\"/></shape>\n"));
  const luz::Bsdf& b = m.materials.back().bsdf;
  ASSERT_EQ(b.type, luz::BsdfType::RoughConductor);
  const double t = (1 - 0.04) * (1 - 0.04);  // F0 = 0.04 at 1.5
  EXPECT_NEAR(b.rough_conductor.specular_reflectance.x, t, 1e-5);
  EXPECT_NEAR(b.rough_conductor.specular_reflectance.y, t * std::exp(-0.4), 1e-5);
  EXPECT_TRUE(warned(m, "coating over a conductor"));
}

TEST_F(MitsubaFormats, CamelCaseInAVersion2SceneIsUpgradedWithAWarning) {
  luz::Scene s = load(scene_with_shape("<integrator type=\"path\"><integer name=\"maxDepth\" value=\"4\"/></integrator>\n", "2.0.0"));
  EXPECT_EQ(s.settings.integrator.max_depth, 4);
  EXPECT_TRUE(warned(s, "scene.xml:3: warning: parameter 'maxDepth' is a Mitsuba 0.5/0.6 camelCase name"));
}

TEST_F(MitsubaFormats, HdrfilmFormatsShapeTheExrOutput) {
  auto film_text = [](const std::string& params) {
    return "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\">" + params +
           "</film></sensor>\n<shape type=\"rectangle\"/>\n</scene>\n";
  };
  auto film = [&](const std::string& params) { return load(film_text(params)); };
  luz::Scene plain = film("");
  EXPECT_EQ(plain.settings.exr_format.channels, luz::ExrChannels::Rgb);
  EXPECT_FALSE(plain.settings.exr_format.half);
  luz::Scene y = film("<string name=\"pixel_format\" value=\"luminance_alpha\"/><string name=\"component_format\" value=\"float16\"/>");
  EXPECT_EQ(y.settings.exr_format.channels, luz::ExrChannels::Luminance);
  EXPECT_TRUE(y.settings.exr_format.half);
  EXPECT_TRUE(warned(y, "scene.xml:2: warning: pixel_format 'luminance_alpha': Luz's film has no alpha"));
  expect_error(film_text("<string name=\"component_format\" value=\"uint32\"/>"), "scene.xml:2", "component_format 'uint32'");
  expect_error(film_text("<string name=\"pixel_format\" value=\"spectrum\"/>"), "scene.xml:2", "pixel_format 'spectrum'");

  // The file: one half channel Y holding the luminance; X Y Z in floats.
  const luz::Image img{2, 1, {1.f, 0.f, 0.f, 0.25f, 0.5f, 1.f}};
  const std::string path = (dir / "y.exr").string();
  luz::write_image(path, img, y.settings.exr_format);
  {
    Imf::InputFile f(path.c_str());
    const Imf::ChannelList& ch = f.header().channels();
    ASSERT_NE(ch.findChannel("Y"), nullptr);
    EXPECT_EQ(ch.findChannel("Y")->type, Imf::HALF);
    EXPECT_EQ(ch.findChannel("R"), nullptr);
    std::vector<float> yv(2);
    Imf::FrameBuffer fb;
    fb.insert("Y", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(yv.data()), sizeof(float), 2 * sizeof(float)));
    f.setFrameBuffer(fb);
    f.readPixels(0, 0);
    EXPECT_NEAR(yv[0], 0.212671f, 1e-3f);  // half precision: 2^-11 relative
    EXPECT_NEAR(yv[1], 0.212671f * 0.25f + 0.715160f * 0.5f + 0.072169f, 1e-3f);
  }
  const std::string xyz = (dir / "xyz.exr").string();
  luz::write_image(xyz, img, {luz::ExrChannels::Xyz, false});
  Imf::InputFile f(xyz.c_str());
  std::vector<float> x(2), z(2);
  Imf::FrameBuffer fb;
  fb.insert("X", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(x.data()), sizeof(float), 2 * sizeof(float)));
  fb.insert("Z", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(z.data()), sizeof(float), 2 * sizeof(float)));
  f.setFrameBuffer(fb);
  f.readPixels(0, 0);
  EXPECT_FLOAT_EQ(x[0], 0.412453f);
  EXPECT_FLOAT_EQ(z[1], 0.019334f * 0.25f + 0.119193f * 0.5f + 0.950227f);
}

// ---- every shared Mitsuba scene: loads unchanged, renders small and finite ----
luz::Scene load_shared(const std::string& file, const std::vector<std::string>& search = {}) {
  luz::Scene s = luz::load_scene(kScenes + file, {}, search);
  s.camera.width = std::max(1, s.camera.width / 16);
  s.camera.height = std::max(1, s.camera.height / 16);
  s.settings.spp = 2;
  return s;
}

TEST(SharedMitsubaScenes, Sponza) {
  luz::Scene s = load_shared("sponza-dabrovic-mitsuba/sponza.xml");
  EXPECT_EQ(s.indices.size() / 3, 66445u);  // SOURCES.md's count
  EXPECT_TRUE(luz_test::has_warning(s, "integrator 'irrcache' is not supported"));
  luz_test::render_finite(s);
}
TEST(SharedMitsubaScenes, VeachMi) {
  luz::Scene s = load_shared("veach-mi-mitsuba/mi.xml");
  EXPECT_EQ(s.settings.integrator.max_depth, 2);
  EXPECT_EQ(s.spheres.size(), 5u);
  luz_test::render_finite(s);
}
TEST(SharedMitsubaScenes, VeachMis) {
  luz::Scene s = load_shared("veach-mis-bitterli/mitsuba3/scene.xml");
  EXPECT_TRUE(luz_test::has_warning(s, "integrator 'path_guiding_integrator' is not supported: rendered with path (max_depth 3)"));
  luz_test::render_finite(s);
}
TEST(SharedMitsubaScenes, MaterialTestball) {
  // Its OBJ meshes and envmap were not shipped beside it: with the pbrt-v4
  // folder as a search path (-a), the PLY meshes of the same names stand in.
  luz::Scene s = load_shared("material-testball/mitsuba/scene.xml", {kScenes + "material-testball/pbrt-v4"});
  EXPECT_EQ(s.indices.size() / 3, 80770u);
  EXPECT_TRUE(luz_test::has_warning(s, "'models/Mesh002.obj' is missing: read"));
  luz_test::render_finite(s);
  luz_test::expect_load_refused(kScenes + "material-testball/mitsuba/scene.xml", "scene.xml", "no such file");
}
TEST(SharedMitsubaScenes, Staircase) {
  LUZ_SKIP_UNDER_SANITIZERS("test_textures' Staircase.TinyRenderIsFinite loads and renders it sanitized");
  luz_test::render_finite(load_shared("staircase/mitsuba/scene.xml"));
}
TEST(SharedMitsubaScenes, CornellBoxBitterli) {
  luz_test::render_finite(load_shared("cornell-box-bitterli/mitsuba3/scene_v3.xml"));
}

}  // namespace
