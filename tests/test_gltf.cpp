// The glTF 2.0 loader (io/gltf.cpp): the shared sample models load (.gltf
// and .glb alike) and render with no non-finite sample; the helmet's
// emissive texture shows where the camera sees emissive texels (checked
// against the JPEG read on its own); the Box's red metal under a constant
// environment gives the directional albedo of the specification's BRDF
// (quadrature); primitives' modes, index types, transforms, materials and
// lights from small files written here; COLOR_0 times the base colour;
// KHR_materials_specular's and KHR_materials_clearcoat's factors and textures;
// malformed and truncated files give
// one InputError naming the file.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "luz/accel/embree_tracer.h"
#include "luz/io/gltf.h"
#include "luz/io/image.h"
#include "luz/material/opacity.h"
#include "cli_helpers.h"
#include "scene_helpers.h"
#include "temp_dir.h"

using namespace luz;

namespace {

const std::string kDir = std::string(LUZ_SHARED_DIR) + "/scenes/gltf/";
const std::string kBox = kDir + "Box/glTF-Embedded/Box.gltf";
const std::string kHelmet = kDir + "DamagedHelmet/glTF/DamagedHelmet.gltf";
const std::string kHelmetGlb = kDir + "DamagedHelmet/glTF-Binary/DamagedHelmet.glb";

std::string read_file(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// The same view at another resolution (the aspect ratio kept).
void resize(Scene& s, int w, int h) {
  s.camera.width = w;
  s.camera.height = h;
}

// A constant environment of radiance 1 (the one the loader adds to a file
// without lights, or added here).
void add_environment(Scene& s) {
  bool has = false;
  for (const Light& l : s.lights) has |= l.type == LightType::Constant && l.constant.radiance.x == 1.f;
  if (!has) {
    ConstantLight c;
    c.radiance = {1.f, 1.f, 1.f};
    s.lights.push_back(c);
  }
  s.compile();
}

std::string base64(const std::string& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const uint32_t v = (uint8_t(in[i]) << 16) | (uint8_t(in[i + 1]) << 8) | uint8_t(in[i + 2]);
    out += {t[v >> 18], t[(v >> 12) & 63], t[(v >> 6) & 63], t[v & 63]};
  }
  if (i + 1 == in.size()) {
    const uint32_t v = uint8_t(in[i]) << 16;
    out += {t[v >> 18], t[(v >> 12) & 63], '=', '='};
  } else if (i + 2 == in.size()) {
    const uint32_t v = (uint8_t(in[i]) << 16) | (uint8_t(in[i + 1]) << 8);
    out += {t[v >> 18], t[(v >> 12) & 63], t[(v >> 6) & 63], '='};
  }
  return out;
}
template <class T>
std::string bytes(const std::vector<T>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

}  // namespace

// Both sample models load; the helmet's .gltf and .glb give the same arrays.
TEST(Gltf, SampleModelsLoad) {
  Scene box = load_scene(kBox);
  EXPECT_EQ(box.num_triangles(), 12u);
  ASSERT_EQ(box.materials.size(), 1u);
  EXPECT_EQ(box.materials[0].bsdf.type, BsdfType::GltfPbr);
  EXPECT_FLOAT_EQ(box.materials[0].bsdf.gltf_pbr.base_color.x, 0.8f);
  EXPECT_EQ(box.materials[0].bsdf.gltf_pbr.metallic, 1.f);  // glTF's default
  // No light in the file: a white sky, and one warning saying so.
  ASSERT_EQ(box.lights.size(), 1u);
  EXPECT_EQ(box.lights[0].type, LightType::Constant);
  ASSERT_EQ(box.warnings.size(), 1u);
  EXPECT_NE(box.warnings[0].find("no light in the file"), std::string::npos) << box.warnings[0];

  Scene a = load_scene(kHelmet), b = load_scene(kHelmetGlb);
  EXPECT_EQ(a.num_triangles(), 46356u / 3);
  ASSERT_EQ(a.positions.size(), b.positions.size());
  for (size_t i = 0; i < a.positions.size(); ++i) {
    ASSERT_EQ(a.positions[i].x, b.positions[i].x);
    ASSERT_EQ(a.positions[i].z, b.positions[i].z);
  }
  EXPECT_EQ(a.indices, b.indices);
  EXPECT_EQ(a.texels8, b.texels8);
  ASSERT_EQ(a.uvs.size(), a.positions.size());
  // Textures: base colour, roughness (G), metallic (B), normal, emissive.
  const Material& m = a.materials[0];
  EXPECT_EQ(m.num_bindings, 3u);
  EXPECT_GE(m.normal_map, 0);
  EXPECT_EQ(a.textures[size_t(a.texture_bindings[1].texture)].bitmap.channel, TextureChannel::G);
  EXPECT_EQ(a.textures[size_t(a.texture_bindings[2].texture)].bitmap.channel, TextureChannel::B);
  EXPECT_FALSE(a.textures[size_t(a.texture_bindings[1].texture)].bitmap.srgb);
  // Emitters: the triangles whose emissive texels are not all black, each
  // weighed by its texels' mean.
  std::printf("helmet: %zu of %u triangles emit\n", a.lights.size(), a.num_triangles());
  EXPECT_GT(a.lights.size(), 100u);
  EXPECT_LT(a.lights.size(), a.num_triangles() / 2);
  for (const Light& l : a.lights) EXPECT_GT(luminance(l.triangle.radiance), 0.f);
}

// Each file renders at low resolution under a constant environment with no
// non-finite sample, and not black.
TEST(Gltf, SampleModelsRenderFinite) {
  for (const std::string& p : {kBox, kHelmet, kHelmetGlb}) {
    Scene s = load_scene(p);
    resize(s, 24, 24);
    s.settings.spp = 4;
    add_environment(s);
    Film f = luz_test::render_finite(s);
    double sum = 0;
    for (float v : f.mean()) {
      ASSERT_TRUE(std::isfinite(v)) << p;
      sum += v;
    }
    EXPECT_GT(sum, 0.0) << p;
  }
}

// The helmet's emission, seen directly (max_depth 1: emitted light only),
// against its emissive texture read on its own (stb through read_image8,
// sRGB-decoded here, the nearest texel) at the hits of camera rays traced
// here (Embree) through an 8×8 grid of points per pixel: the box-filtered
// pixel's expectation up to the grid's quadrature error. Compared over
// 8×8-pixel blocks: |rendered - expected| ≤ 4 σ (the render's own variance
// of the block sum) + 3% (the grid and the nearest texel against the
// render's bilinear one), and over the whole image. A texture read in the
// wrong place (v flipped, another texture) moves light between blocks.
TEST(Gltf, HelmetEmissiveTextureShowsWhereItShould) {
  Scene s = load_scene(kHelmet);
  const int W = 96, H = 96, G = 8, B = 8;
  resize(s, W, H);
  s.settings.spp = 64;
  s.settings.integrator.max_depth = 1;
  s.compile();
  const Film film = luz_test::render_finite(s);
  const std::vector<float> img = film.mean();
  const std::vector<double> var = film.variance_of_mean();
  const Image8 tex = read_image8(kDir + "DamagedHelmet/glTF/Default_emissive.jpg");
  EmbreeScene embree(s);
  const EmbreeTracer tracer = embree.tracer();
  auto emitted = [&](float fx, float fy) {
    Ray r = s.camera.generate_ray(fx, fy);
    Hit hit;
    if (!tracer.intersect(r, hit)) return 0.0;
    const Vec2 uv = triangle_uv(s.uvs.data(), s.indices.data(), hit);
    const double u = uv.x - std::floor(uv.x), v = uv.y - std::floor(uv.y);  // the sampler repeats
    const int i = std::min(tex.width - 1, int(u * tex.width)), j = std::min(tex.height - 1, int(v * tex.height));
    const uint32_t t = tex.rgba[size_t(j) * size_t(tex.width) + size_t(i)];
    double l = 0;
    const double w[3] = {0.2126, 0.7152, 0.0722};
    for (int k = 0; k < 3; ++k) l += w[k] * srgb_to_linear(((t >> (8 * k)) & 255) / 255.0);
    return l;
  };
  double total_got = 0, total_exp = 0, total_var = 0, worst = 0;
  int lit_blocks = 0;
  for (int by = 0; by < H / B; ++by)
    for (int bx = 0; bx < W / B; ++bx) {
      double got = 0, exp = 0, v = 0;
      for (int y = by * B; y < (by + 1) * B; ++y)
        for (int x = bx * B; x < (bx + 1) * B; ++x) {
          const size_t p = 3 * (size_t(y) * W + size_t(x));
          got += 0.2126 * img[p] + 0.7152 * img[p + 1] + 0.0722 * img[p + 2];
          v += 0.2126 * 0.2126 * var[p] + 0.7152 * 0.7152 * var[p + 1] + 0.0722 * 0.0722 * var[p + 2];
          for (int j = 0; j < G; ++j)
            for (int i = 0; i < G; ++i) exp += emitted(x + (i + 0.5f) / G, y + (j + 0.5f) / G) / (G * G);
        }
      const double bound = 4 * std::sqrt(v) + 0.03 * exp + 1e-3;
      worst = std::max(worst, std::fabs(got - exp) / bound);
      EXPECT_NEAR(got, exp, bound) << "block " << bx << ", " << by;
      lit_blocks += exp > 0.5;
      total_got += got, total_exp += exp, total_var += v;
    }
  std::printf("helmet emission: image sum %.3f rendered, %.3f expected (σ %.3f); %d lit blocks; worst block at %.2f of its bound\n",
              total_got, total_exp, std::sqrt(total_var), lit_blocks, worst);
  EXPECT_GE(lit_blocks, 10);
  EXPECT_NEAR(total_got, total_exp, 4 * std::sqrt(total_var) + 0.01 * total_exp);
}

// The Box (baseColorFactor (0.8, 0, 0); metallic and roughness 1 by
// default: a red rough metal) framed from +z (no camera in the file) at
// 15×15 pixels, lit by a constant environment of radiance 1 (the box is
// convex: one bounce). The centre pixel sees the front face at normal
// incidence, so its value is the BRDF's directional albedo there,
//   A = 2π ∫ f(n, ω(θ)) cos θ sin θ dθ
// (isotropic: f depends on θ only when wo = n), per channel, with f the
// specification's metal lobe written out here (α = 1: D = 1/π,
// V = 1/((cos θ + 1)·2), w = (1 - cos(θ/2))⁵). Bound: 4 σ of the pixel's
// mean plus 1e-3 relative (the pixel spans ±0.034 rad of view direction).
TEST(Gltf, BoxBaseColourUnderConstantLight) {
  Scene s = load_scene(kBox);
  resize(s, 15, 15);
  s.settings.spp = 16384;
  add_environment(s);
  const Film f = luz_test::render_finite(s);
  const std::vector<float> m = f.mean();
  const std::vector<double> var = f.variance_of_mean();
  const size_t c = 3 * (7 * 15 + 7);
  const double pi = 3.14159265358979323846;
  const double base[3] = {0.8, 0.0, 0.0};
  const int n = 200000;
  for (int k = 0; k < 3; ++k) {
    double a = 0;
    for (int i = 0; i < n; ++i) {
      const double th = (i + 0.5) * (pi / 2) / n, ct = std::cos(th);
      const double D = 1.0 / pi, V = 1.0 / ((ct + 1.0) * 2.0);  // α = 1 in §B.3.2's D and separable V
      const double w = std::pow(1.0 - std::cos(th / 2), 5.0);   // v·h = cos(θ/2) for v = n
      a += D * V * (base[k] + (1 - base[k]) * w) * ct * std::sin(th);
    }
    a *= 2 * pi * (pi / 2) / n;
    const double sd = std::sqrt(var[c + size_t(k)]);
    std::printf("box centre channel %d: %.5f ± %.5f, albedo by quadrature %.5f\n", k, m[c + size_t(k)], sd, a);
    EXPECT_NEAR(m[c + size_t(k)], a, 4 * sd + 1e-3 * a) << "channel " << k;
  }
}

// Small files written here: a strip and a fan of 4 vertices (2 triangles
// each, as §3.7.2.1 lists them), byte indices, points (skipped), a node
// with a mirroring scale (winding reversed), a camera, punctual lights,
// and a MASK material.
class GltfFiles : public TempDirTest {
 protected:
  // A glTF whose one buffer holds `bin` (a data URI), with the given JSON
  // members after "buffers".
  std::string gltf(const std::string& name, const std::string& bin, const std::string& rest) {
    return write(name, "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":" + std::to_string(bin.size()) +
                           ",\"uri\":\"data:application/octet-stream;base64," + base64(bin) + "\"}]," + rest + "}");
  }
  // Four vertices of a unit square in z = 0 (0,0), (1,0), (0,1), (1,1); byte
  // indices 0 1 2 3 (accessor 1: a strip), short indices 0 1 3 2 (accessor 2: a fan).
  std::string quad_bin() {
    std::vector<float> p = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0};
    std::vector<uint8_t> idx = {0, 1, 2, 3};
    std::vector<uint16_t> fan = {0, 1, 3, 2};
    return bytes(p) + bytes(idx) + bytes(fan);
  }
  // tex.png, 2×2 texels: red, green (top row), blue, white.
  Image four_texels() {
    Image img;
    img.width = img.height = 2;
    img.rgb = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
    write_image((dir / "tex.png").string(), img);
    return img;
  }
  // rgba.tga, 2×2 RGBA texels of other values than 0 and 1 (stored B, G, R,
  // A, top row first: top right (R, G, B, A) = (200, 100, 50, 128)); returns
  // `doc` with tex.png replaced by it.
  std::string with_rgba_texels(std::string doc) {
    const unsigned char tga[18 + 16] = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 2, 0, 32, 8 | 0x20,
                                        32, 64, 128, 255, 50, 100, 200, 128,  // top row
                                        30, 20, 10, 64, 255, 255, 255, 0};    // bottom row
    write("rgba.tga", std::string(reinterpret_cast<const char*>(tga), sizeof tga));
    doc.replace(doc.find("tex.png"), 7, "rgba.tga");
    return doc;
  }
  // The quad with TEXCOORD_0 (0, 0), (1, 0), (0, 1), (1, 1) (accessor 3):
  // its bytes, and its JSON up to a primitive of material 0 and tex.png as image 0.
  std::string textured_quad_bin() { return quad_bin() + bytes(std::vector<float>{0, 0, 1, 0, 0, 1, 1, 1}); }
  std::string textured_quad_json() {
    return views(",{\"buffer\":0,\"byteOffset\":60,\"byteLength\":32}",
                 ",{\"bufferView\":3,\"componentType\":5126,\"count\":4,\"type\":\"VEC2\"}") +
           ",\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":3},\"indices\":1,\"mode\":5,"
           "\"material\":0}]}],\"nodes\":[{\"mesh\":0}],\"images\":[{\"uri\":\"tex.png\"}]";
  }
  // Its bufferViews and accessors 0-2, then `more_views` and `more_accessors` (each ",{...}").
  std::string views(const std::string& more_views = "", const std::string& more_accessors = "") {
    return "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":48},{\"buffer\":0,\"byteOffset\":48,"
           "\"byteLength\":4},{\"buffer\":0,\"byteOffset\":52,\"byteLength\":8}" + more_views + "],"
           "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"},"
           "{\"bufferView\":1,\"componentType\":5121,\"count\":4,\"type\":\"SCALAR\"},"
           "{\"bufferView\":2,\"componentType\":5123,\"count\":4,\"type\":\"SCALAR\"}" + more_accessors + "]";
  }
};

TEST_F(GltfFiles, ModesIndicesTransformsCameraLights) {
  const std::string json =
      views() +
      ",\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":5},"
      "{\"attributes\":{\"POSITION\":0},\"indices\":2,\"mode\":6},{\"attributes\":{\"POSITION\":0},\"mode\":0}]}],"
      "\"nodes\":[{\"mesh\":0,\"translation\":[0,0,-5]},{\"mesh\":0,\"scale\":[-1,1,1]},"
      "{\"camera\":0,\"translation\":[0,0,10]},{\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},"
      "{\"extensions\":{\"KHR_lights_punctual\":{\"light\":1}},\"rotation\":[0.7071068,0,0,0.7071068]}],"
      "\"scenes\":[{\"nodes\":[0,1,2,3,4]}],\"scene\":0,"
      "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.5,\"aspectRatio\":2,\"znear\":0.1}}],"
      "\"extensionsUsed\":[\"KHR_lights_punctual\"],\"extensions\":{\"KHR_lights_punctual\":{\"lights\":["
      "{\"type\":\"point\",\"intensity\":683,\"color\":[1,0.5,0.25]},{\"type\":\"directional\",\"intensity\":6830}]}}";
  Scene s = load_scene(gltf("modes.gltf", quad_bin(), json));
  ASSERT_EQ(s.num_triangles(), 8u);  // 2 strip + 2 fan per node, points skipped
  auto tri = [&](uint32_t t, int k) { return s.positions[s.indices[3 * t + uint32_t(k)]]; };
  auto normal_z = [&](uint32_t t) { return cross(tri(t, 1) - tri(t, 0), tri(t, 2) - tri(t, 0)).z; };
  // Node 0's mesh (used twice, so an object) is placed once: flattened when
  // the scene is finished, after node 1's mirrored copy (triangles 0-3).
  const uint32_t n0 = 4, n1 = 0;
  // Strip {v0,v1,v2}, {v1,v3,v2}; fan over 0 1 3 2: {v1,v3,v0}, {v3,v2,v0}:
  // all counter-clockwise seen from +z.
  EXPECT_EQ(tri(n0, 0).x, 0.f);
  EXPECT_EQ(tri(n0 + 1, 0).x, 1.f);  // the second strip triangle starts at v1, then v3
  EXPECT_EQ(tri(n0 + 1, 1).y, 1.f);
  EXPECT_EQ(tri(n0 + 1, 1).x, 1.f);
  EXPECT_EQ(tri(n0 + 2, 2).x, 0.f);  // the fan's centre last
  EXPECT_EQ(tri(n0 + 2, 2).y, 0.f);
  EXPECT_EQ(tri(n0, 0).z, -5.f);
  for (uint32_t t = 0; t < 8; ++t) EXPECT_GT(normal_z(t), 0.f) << "triangle " << t << " (mirrored node: winding reversed)";
  EXPECT_EQ(tri(n1, 2).x, -1.f);  // the mirrored copy: {v0, v2, v1}
  // Camera: at z = 10 looking down -z, 2:1.
  EXPECT_EQ(s.camera.origin.z, 10.f);
  EXPECT_EQ(s.camera.z_axis.z, -1.f);
  EXPECT_EQ(s.camera.width, 2 * s.camera.height);
  EXPECT_NEAR(s.camera.tan_half_y, std::tan(0.25f), 1e-6f);
  // Lights: 683 cd -> 1 W/sr (times the colour); 6830 lux -> 10 W/m², shining along the node's -z rotated by 90° about x: +y.
  ASSERT_EQ(s.lights.size(), 2u);
  EXPECT_EQ(s.lights[0].type, LightType::Point);
  EXPECT_NEAR(s.lights[0].point.intensity.y, 0.5f, 1e-6f);
  EXPECT_EQ(s.lights[1].type, LightType::Directional);
  EXPECT_NEAR(s.lights[1].directional.irradiance.x, 10.f, 1e-5f);
  EXPECT_NEAR(s.lights[1].directional.direction.y, 1.f, 1e-6f);
}

// A spot light: inner -> beam, outer -> cutoff, with the extension's falloff
// (the square of a linear ramp in cos θ; an inner angle of 0 allowed); a
// `range` is ignored with a warning.
TEST_F(GltfFiles, SpotLightFalloffAndRange) {
  const std::string json =
      views() + ",\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":5}]}],"
      "\"nodes\":[{\"mesh\":0},{\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}},\"translation\":[0,0,3]}],"
      "\"scenes\":[{\"nodes\":[0,1]}],\"extensionsUsed\":[\"KHR_lights_punctual\"],"
      "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"spot\",\"intensity\":683,\"range\":5,"
      "\"spot\":{\"innerConeAngle\":0,\"outerConeAngle\":0.5}}]}}";
  Scene s = load_scene(gltf("spot.gltf", quad_bin(), json));
  ASSERT_EQ(s.lights.size(), 1u);
  ASSERT_EQ(s.lights[0].type, LightType::Spot);
  const SpotLight& l = s.lights[0].spot;
  EXPECT_EQ(l.falloff_kind, SpotFalloff::SquaredRampCos);
  EXPECT_EQ(l.beam, 0.f);
  EXPECT_NEAR(l.cutoff, 0.5f, 1e-7f);
  EXPECT_NEAR(l.intensity.x, 1.f, 1e-6f);
  // Halfway down the ramp in cos θ: a quarter (the extension's sample code).
  const double c = 0.5 * (1.0 + std::cos(0.5)), th = std::acos(c);
  EXPECT_NEAR(l.falloff({float(std::sin(th)), 0.f, float(c)}), 0.25f, 2e-4f);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("range is ignored"), std::string::npos) << s.warnings[0];
}

// Several cameras: the first in traversal order, or one by its camera's or
// its node's name (luz render --camera); an unknown name lists the file's.
TEST_F(GltfFiles, CameraByName) {
  const std::string json =
      views() + ",\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":5}]}],"
      "\"nodes\":[{\"mesh\":0},{\"camera\":0,\"translation\":[0,0,10]},"
      "{\"name\":\"side\",\"camera\":1,\"translation\":[0,0,20]},{\"camera\":2,\"translation\":[0,0,30]}],"
      "\"scenes\":[{\"nodes\":[0,1,2,3]}],\"scene\":0,\"cameras\":["
      "{\"name\":\"front\",\"type\":\"perspective\",\"perspective\":{\"yfov\":0.5,\"znear\":0.1}},"
      "{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.5,\"znear\":0.1}},"
      "{\"name\":\"far\",\"type\":\"perspective\",\"perspective\":{\"yfov\":0.5,\"znear\":0.1}}]";
  const std::string path = gltf("cameras.gltf", quad_bin(), json);
  EXPECT_EQ(load_scene(path).camera.origin.z, 10.f);
  EXPECT_EQ(load_scene(path, {}, {}, "front").camera.origin.z, 10.f);
  EXPECT_EQ(load_scene(path, {}, {}, "side").camera.origin.z, 20.f);  // the node's name
  EXPECT_EQ(load_scene(path, {}, {}, "far").camera.origin.z, 30.f);
  auto refusal = [](const std::string& file, const std::string& camera) -> std::string {
    try {
      load_scene(file, {}, {}, camera);
    } catch (const InputError& e) {
      return e.what();
    }
    return "accepted";
  };
  EXPECT_NE(refusal(path, "top").find("cameras.gltf: cameras: no camera named 'top' (the file has 'front', 'side', 'far')"),
            std::string::npos)
      << refusal(path, "top");
  EXPECT_NE(refusal(LUZ_SOURCE_DIR "/scenes/cornell-box.xml", "front").find("--camera front: only glTF files name their cameras"),
            std::string::npos);
}

// A camera node's scale is ignored (§3.10.2): a mirroring scale neither
// mirrors the view nor, uneven, shears it; at another resolution the
// vertical field of view (yfov) is kept.
TEST_F(GltfFiles, CameraIgnoresScaleAndKeepsYfov) {
  auto load = [&](const std::string& name, const std::string& scale) {
    const std::string json = views() +
        ",\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":5}]}],"
        "\"nodes\":[{\"mesh\":0},{\"camera\":0,\"translation\":[0,0,10]" + scale + "}],\"scenes\":[{\"nodes\":[0,1]}],"
        "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.5,\"aspectRatio\":1.5,\"znear\":0.1}}]";
    return load_scene(gltf(name, quad_bin(), json));
  };
  const Scene plain = load("plain.gltf", ""), mirrored = load("mirrored.gltf", ",\"scale\":[-1,3,0.5]");
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(mirrored.camera.x_axis[k], plain.camera.x_axis[k], 1e-6f) << k;
    EXPECT_NEAR(mirrored.camera.y_axis[k], plain.camera.y_axis[k], 1e-6f) << k;
    EXPECT_NEAR(mirrored.camera.z_axis[k], plain.camera.z_axis[k], 1e-6f) << k;
  }
  EXPECT_EQ(plain.camera.x_axis.x, -1.f);  // the image's left
  Scene wide = plain;
  wide.set_resolution(300, 100);
  EXPECT_NEAR(wide.camera.tan_half_y, std::tan(0.25f), 1e-6f);
  EXPECT_NEAR(wide.camera.tan_half_x, 3 * std::tan(0.25f), 1e-6f);
}

// KHR_mesh_quantization: normalised short positions where the file uses
// it; refused, naming the extension, where it does not. Extensions the
// file uses and Luz does not, and COLOR_0, are left out with a warning.
TEST_F(GltfFiles, QuantizedPositionsAndIgnoredExtensions) {
  std::vector<int16_t> p = {0, 0, 0, 32767, 0, 0, 0, 32767, 0, 32767, 32767, 0};
  std::vector<uint8_t> idx = {0, 1, 2, 3};
  std::vector<float> color(16, 0.5f);
  const std::string bin = bytes(p) + bytes(idx) + bytes(color);
  auto json = [](const std::string& used) {
    return "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":24},{\"buffer\":0,\"byteOffset\":24,\"byteLength\":4},"
           "{\"buffer\":0,\"byteOffset\":28,\"byteLength\":64}],"
           "\"accessors\":[{\"bufferView\":0,\"componentType\":5122,\"normalized\":true,\"count\":4,\"type\":\"VEC3\"},"
           "{\"bufferView\":1,\"componentType\":5121,\"count\":4,\"type\":\"SCALAR\"},"
           "{\"bufferView\":2,\"componentType\":5126,\"count\":4,\"type\":\"VEC4\"}],"
           "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"COLOR_0\":2},\"indices\":1,\"mode\":5}]}],"
           "\"nodes\":[{\"mesh\":0}],\"extensionsUsed\":[" + used + "]";
  };
  Scene s = load_scene(gltf("q.gltf", bin, json("\"KHR_mesh_quantization\",\"KHR_materials_sheen\"")));
  ASSERT_EQ(s.positions.size(), 4u);
  EXPECT_EQ(s.positions[3].x, 1.f);
  EXPECT_EQ(s.positions[3].y, 1.f);
  std::string all;
  for (const std::string& w : s.warnings) all += w + "\n";
  EXPECT_NE(all.find("extension KHR_materials_sheen is not supported: rendered without it"), std::string::npos) << all;
  ASSERT_EQ(s.colors.size(), 4u);  // COLOR_0, VEC4 floats
  EXPECT_EQ(s.colors[2].y, 0.5f);
  EXPECT_EQ(all.find("COLOR_0"), std::string::npos) << all;  // opaque: its alpha does not matter
  luz_test::expect_load_refused(gltf("nq.gltf", bin, json("")), "nq.gltf",
                                "POSITION must be VEC3 of floats (other types need KHR_mesh_quantization)");
}

// Skins (§3.7.3): each vertex by its joints' world transforms times their
// inverse bind matrices, weighted; the skinned node's own transform is
// ignored. Joint 0 at (0, 2, 0) (identity inverse bind), joint 1 at
// (0, 0, 3) with an inverse bind of a translation by (-1, 0, 0).
TEST_F(GltfFiles, SkinsPlaceVerticesByTheirJoints) {
  std::vector<uint8_t> joints = {0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0};
  std::vector<float> weights = {1, 0, 0, 0, 0, 1, 0, 0, 0.5f, 0.5f, 0, 0, 0.25f, 0.25f, 0, 0};  // the last sums to 1/2
  std::vector<float> ibm = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -1, 0, 0, 1};
  const std::string bin = quad_bin() + bytes(joints) + bytes(weights) + bytes(ibm);
  const std::string json =
      views(",{\"buffer\":0,\"byteOffset\":60,\"byteLength\":16},{\"buffer\":0,\"byteOffset\":76,\"byteLength\":64},"
            "{\"buffer\":0,\"byteOffset\":140,\"byteLength\":128}",
            ",{\"bufferView\":3,\"componentType\":5121,\"count\":4,\"type\":\"VEC4\"},"
            "{\"bufferView\":4,\"componentType\":5126,\"count\":4,\"type\":\"VEC4\"},"
            "{\"bufferView\":5,\"componentType\":5126,\"count\":2,\"type\":\"MAT4\"}") +
      ",\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"JOINTS_0\":3,\"WEIGHTS_0\":4},\"indices\":1,\"mode\":5}]}],"
      "\"nodes\":[{\"mesh\":0,\"skin\":0,\"translation\":[10,0,0]},{\"translation\":[0,2,0]},{\"translation\":[0,0,3]}],"
      "\"scenes\":[{\"nodes\":[0,1,2]}],\"skins\":[{\"joints\":[1,2],\"inverseBindMatrices\":5}]";
  Scene s = load_scene(gltf("skin.gltf", bin, json));
  ASSERT_EQ(s.positions.size(), 4u);
  // v0 (0,0,0) by joint 0: (0,2,0); v1 (1,0,0) by joint 1: (0,0,3);
  // v2 (0,1,0) halfway: ((0,3,0) + (-1,1,3)) / 2; v3 (1,1,0) the same halves: ((1,3,0) + (0,1,3)) / 2.
  const Vec3 want[4] = {{0, 2, 0}, {0, 0, 3}, {-0.5f, 2, 1.5f}, {0.5f, 2, 1.5f}};
  for (int v = 0; v < 4; ++v)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(s.positions[size_t(v)][k], want[v][k], 1e-6f) << "vertex " << v << " axis " << k;
  // A joint outside the scene, a vertex naming a joint the skin lacks.
  std::string outside = json;
  outside.replace(outside.find("\"nodes\":[0,1,2]"), 15, "\"nodes\":[0,1]");
  luz_test::expect_load_refused(gltf("outside.gltf", bin, outside), "outside.gltf", "skins[0]: joint 2 is not a node of the scene");
  std::vector<uint8_t> bad = joints;
  bad[5] = 7;  // vertex 1's weighted joint
  luz_test::expect_load_refused(gltf("badjoint.gltf", quad_bin() + bytes(bad) + bytes(weights) + bytes(ibm), json),
                                "badjoint.gltf", "JOINTS_0 names joint 7 of 2");
}

// Morph targets (§3.7.2.2): positions plus the weighted displacements, at
// the node's weights, else the mesh's; a mesh placed twice with different
// weights is not instanced.
TEST_F(GltfFiles, MorphTargetsAtTheirWeights) {
  std::vector<float> delta = {0, 0, 0, 0, 4, 0, 0, 0, 0, 0, 4, 0};  // v1 and v3 up by 4
  const std::string bin = quad_bin() + bytes(delta);
  const std::string json =
      views(",{\"buffer\":0,\"byteOffset\":60,\"byteLength\":48}", ",{\"bufferView\":3,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"}") +
      ",\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":5,\"targets\":[{\"POSITION\":3}]}],"
      "\"weights\":[1]}],\"nodes\":[{\"mesh\":0},{\"mesh\":0,\"weights\":[0.5],\"translation\":[0,0,-5]}],"
      "\"scenes\":[{\"nodes\":[0,1]}]";
  Scene s = load_scene(gltf("morph.gltf", bin, json));
  EXPECT_TRUE(s.instances.empty());
  float top_front = 0, top_back = 0;  // the highest y at z = 0 and at z = -5
  for (const Vec3& p : s.positions) (p.z == 0.f ? top_front : top_back) = std::max(p.z == 0.f ? top_front : top_back, p.y);
  EXPECT_EQ(top_front, 5.f);
  EXPECT_EQ(top_back, 3.f);
  std::string wrong = json;
  wrong.replace(wrong.find("\"weights\":[0.5]"), 15, "\"weights\":[0.5,1]");
  luz_test::expect_load_refused(gltf("wrong.gltf", bin, wrong), "wrong.gltf", "nodes[1]: weights has 2 numbers for 1 morph targets");
  // KHR_mesh_quantization: displacements of (unnormalised) shorts, the same.
  std::vector<int16_t> qdelta = {0, 0, 0, 0, 4, 0, 0, 0, 0, 0, 4, 0};
  std::string quantized = json;
  auto swap = [&](const std::string& from, const std::string& to) { quantized.replace(quantized.find(from), from.size(), to); };
  swap("\"byteOffset\":60,\"byteLength\":48}", "\"byteOffset\":60,\"byteLength\":24}");
  swap("{\"bufferView\":3,\"componentType\":5126", "{\"bufferView\":3,\"componentType\":5122");
  Scene q = load_scene(gltf("qmorph.gltf", quad_bin() + bytes(qdelta), quantized + ",\"extensionsUsed\":[\"KHR_mesh_quantization\"]"));
  float top = 0;
  for (const Vec3& p : q.positions) top = std::max(top, p.y);
  EXPECT_EQ(top, 5.f);
  luz_test::expect_load_refused(gltf("qmorph2.gltf", quad_bin() + bytes(qdelta), quantized), "qmorph2.gltf",
                                "POSITION must be VEC3 of floats (other types need KHR_mesh_quantization)");
}

// alphaMode MASK with a constant alpha: opacity 0 below the cutoff, 1 at or
// above; BLEND: the alpha itself. doubleSided (two-sided emission too),
// KHR_materials_ior, emissive strength.
TEST_F(GltfFiles, MaterialProperties) {
  const std::string json =
      views() +
      ",\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":5,\"material\":0},"
      "{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":5,\"material\":1},"
      "{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":5,\"material\":2},"
      "{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":5,\"material\":3}]}],"
      "\"nodes\":[{\"mesh\":0}],\"materials\":["
      "{\"alphaMode\":\"MASK\",\"alphaCutoff\":0.6,\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,1,1,0.5]}},"
      "{\"alphaMode\":\"BLEND\",\"doubleSided\":true,\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,1,1,0.25],"
      "\"metallicFactor\":0.5,\"roughnessFactor\":0.25},\"extensions\":{\"KHR_materials_ior\":{\"ior\":2}}},"
      "{\"emissiveFactor\":[1,0.5,0],\"extensions\":{\"KHR_materials_emissive_strength\":{\"emissiveStrength\":4}}},"
      "{\"pbrMetallicRoughness\":{\"metallicFactor\":0},\"extensions\":{\"KHR_materials_transmission\":"
      "{\"transmissionFactor\":0.75}}}]";
  Scene s = load_scene(gltf("materials.gltf", quad_bin(), json));
  ASSERT_EQ(s.materials.size(), 4u);
  EXPECT_EQ(s.materials[0].opacity, 0.f);
  EXPECT_EQ(s.materials[1].opacity, 0.25f);
  EXPECT_TRUE(s.materials[1].bsdf.two_sided);
  EXPECT_FALSE(s.materials[0].bsdf.two_sided);
  EXPECT_NEAR(s.materials[1].bsdf.gltf_pbr.f0, 1.f / 9.f, 1e-7f);
  EXPECT_EQ(s.materials[1].bsdf.gltf_pbr.roughness, 0.25f);
  EXPECT_EQ(s.materials[3].bsdf.type, BsdfType::GltfPbrTransmission);
  EXPECT_EQ(s.materials[3].bsdf.gltf_pbr_transmission.transmission, 0.75f);
  EXPECT_EQ(s.materials[3].bsdf.gltf_pbr_transmission.surface.metallic, 0.f);
  ASSERT_EQ(s.lights.size(), 1u);  // the emissive strip's two triangles, merged into a parallelogram by compile()
  ASSERT_EQ(s.lights[0].type, LightType::Parallelogram);
  EXPECT_EQ(s.lights[0].parallelogram.radiance.x, 4.f);
  EXPECT_EQ(s.lights[0].parallelogram.radiance.y, 2.f);
  EXPECT_FALSE(s.lights[0].parallelogram.two_sided);
  {
    // doubleSided: its "double-sided lighting" emits from the back too.
    std::string two = json;
    const std::string emissive = "{\"emissiveFactor\"";
    two.replace(two.find(emissive), emissive.size(), "{\"doubleSided\":true,\"emissiveFactor\"");
    const Scene d = load_scene(gltf("two.gltf", quad_bin(), two));
    ASSERT_EQ(d.lights.size(), 1u);
    EXPECT_TRUE(d.lights[0].parallelogram.two_sided);
  }
  // Renders finite with all four (alpha-tested, blended, emitting, transmitting).
  resize(s, 16, 16);
  s.settings.spp = 16;
  add_environment(s);
  luz_test::render_finite(s);
}

// Textures of a material: factors as scales, metallic-roughness as the B
// and G channels (linear), base colour and emission sRGB, the normal map
// raw, the MASK cutoff on the base colour's alpha (scaled by the factor's),
// KHR_texture_transform as to_uv (T R S with R = [cos sin; -sin cos]).
TEST_F(GltfFiles, MaterialTextures) {
  four_texels();
  const std::string bin = textured_quad_bin();
  const std::string doc =
      textured_quad_json() + ","
      "\"samplers\":[{\"magFilter\":9728,\"wrapS\":33071,\"wrapT\":33071}],"
      "\"textures\":[{\"source\":0,\"sampler\":0}],\"materials\":[{\"alphaMode\":\"MASK\",\"alphaCutoff\":0.3,"
      "\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.25,1,0.5],\"baseColorTexture\":{\"index\":0,"
      "\"extensions\":{\"KHR_texture_transform\":{\"offset\":[0.5,0],\"rotation\":1.5707963267948966,"
      "\"scale\":[2,3]}}},\"metallicFactor\":0.5,\"roughnessFactor\":0.75,\"metallicRoughnessTexture\":{\"index\":0}},"
      "\"normalTexture\":{\"index\":0},\"emissiveFactor\":[1,1,1],\"emissiveTexture\":{\"index\":0}}]";
  Scene s = load_scene(gltf("textured.gltf", bin, doc));
  ASSERT_EQ(s.materials.size(), 1u);
  const Material& m = s.materials[0];
  ASSERT_EQ(m.num_bindings, 3u);
  auto tex = [&](uint32_t k) { return s.textures[size_t(s.texture_bindings[m.first_binding + k].texture)]; };
  EXPECT_EQ(s.texture_bindings[m.first_binding].param, BsdfParam::BaseColor);
  const Texture base = tex(0), rough = tex(1), metal = tex(2);
  EXPECT_TRUE(base.bitmap.srgb);
  EXPECT_EQ(base.bitmap.channel, TextureChannel::Rgb);
  EXPECT_EQ(base.bitmap.filter, TextureFilter::Nearest);
  EXPECT_EQ(base.bitmap.wrap, WrapMode::Clamp);
  EXPECT_EQ(base.scale.y, 0.25f);
  EXPECT_NEAR(base.to_uv.a, 0.f, 1e-6f);
  EXPECT_NEAR(base.to_uv.b, 3.f, 1e-6f);
  EXPECT_NEAR(base.to_uv.c, 0.5f, 1e-6f);
  EXPECT_NEAR(base.to_uv.d, -2.f, 1e-6f);
  EXPECT_NEAR(base.to_uv.e, 0.f, 1e-6f);
  EXPECT_EQ(s.texture_bindings[m.first_binding + 1].param, BsdfParam::Roughness);
  EXPECT_EQ(rough.bitmap.channel, TextureChannel::G);
  EXPECT_FALSE(rough.bitmap.srgb);
  EXPECT_EQ(rough.scale.x, 0.75f);
  EXPECT_EQ(s.texture_bindings[m.first_binding + 2].param, BsdfParam::Metallic);
  EXPECT_EQ(metal.bitmap.channel, TextureChannel::B);
  EXPECT_EQ(metal.scale.x, 0.5f);
  // The constants hold the textures' means: G over the 4 texels is 0.5 linear.
  EXPECT_NEAR(m.bsdf.gltf_pbr.roughness, 0.75f * 0.5f, 1e-6f);
  ASSERT_GE(m.opacity_texture, 0);
  const Texture alpha = s.textures[size_t(m.opacity_texture)];
  EXPECT_EQ(alpha.bitmap.channel, TextureChannel::A);
  EXPECT_EQ(alpha.scale.x, 0.5f);
  EXPECT_EQ(m.alpha_cutoff, 0.3f);
  ASSERT_GE(m.normal_map, 0);
  EXPECT_FALSE(s.textures[size_t(m.normal_map)].bitmap.srgb);
  // Masked and emissive: the emission goes, with a warning (and the white sky comes).
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].type, LightType::Constant);
  ASSERT_FALSE(s.warnings.empty());
  EXPECT_NE(s.warnings[0].find("without its emission"), std::string::npos) << s.warnings[0];
}

// KHR_materials_specular: specularFactor and the A channel of
// specularTexture (linear) make the strength, specularColorFactor (above 1
// allowed) and specularColorTexture (sRGB) the F0 colour; the extension is
// not warned about; bad factors are errors.
TEST_F(GltfFiles, SpecularExtensionFactorsAndTextures) {
  four_texels();
  const std::string bin = textured_quad_bin();
  auto doc = [&](const std::string& specular) {
    return textured_quad_json() + ","
           "\"textures\":[{\"source\":0}],\"extensionsUsed\":[\"KHR_materials_specular\"],\"materials\":[{"
           "\"pbrMetallicRoughness\":{\"metallicFactor\":0},\"extensions\":{\"KHR_materials_specular\":{" + specular + "}}}]";
  };
  Scene c = load_scene(gltf("constant.gltf", bin, doc("\"specularFactor\":0.3,\"specularColorFactor\":[2,1,0.5]")));
  ASSERT_EQ(c.materials.size(), 1u);
  EXPECT_EQ(c.materials[0].num_bindings, 0u);
  EXPECT_EQ(c.materials[0].bsdf.gltf_pbr.specular_strength, 0.3f);
  EXPECT_EQ(c.materials[0].bsdf.gltf_pbr.specular_color.x, 2.f);
  EXPECT_EQ(c.materials[0].bsdf.gltf_pbr.specular_color.z, 0.5f);
  EXPECT_TRUE(c.warnings.empty() || !luz_test::has_warning(c, "KHR_materials_specular")) << c.warnings.front();
  Scene t = load_scene(gltf("textured.gltf", bin,
                            doc("\"specularFactor\":0.3,\"specularTexture\":{\"index\":0},"
                                "\"specularColorFactor\":[2,1,0.5],\"specularColorTexture\":{\"index\":0}")));
  const Material& m = t.materials[0];
  ASSERT_EQ(m.num_bindings, 2u);
  const TextureBinding& a = t.texture_bindings[m.first_binding], &b = t.texture_bindings[m.first_binding + 1];
  EXPECT_EQ(a.param, BsdfParam::Specular);
  EXPECT_EQ(t.textures[size_t(a.texture)].bitmap.channel, TextureChannel::A);
  EXPECT_EQ(t.textures[size_t(a.texture)].scale.x, 0.3f);
  EXPECT_EQ(b.param, BsdfParam::SpecularColor);
  EXPECT_TRUE(t.textures[size_t(b.texture)].bitmap.srgb);
  EXPECT_EQ(t.textures[size_t(b.texture)].scale.x, 2.f);
  // At the hit on the (1, 0) texel (green): strength 0.3 · A = 0.3, colour (2, 1, 0.5) · (0, 1, 0).
  const SceneView v = t.view();
  const Bsdf at = v.materials.bsdf(0, v.textures, {0.75f, 0.25f});
  EXPECT_NEAR(at.gltf_pbr.specular_strength, 0.3f, 1e-6f);
  EXPECT_NEAR(at.gltf_pbr.specular_color.x, 0.f, 1e-6f);
  EXPECT_NEAR(at.gltf_pbr.specular_color.y, 1.f, 1e-6f);
  // Texels of other values than 0 and 1: the strength reads A linearly, the
  // colour RGB as sRGB.
  Scene r = load_scene(gltf("rgba.gltf", bin, with_rgba_texels(doc("\"specularFactor\":0.3,\"specularTexture\":{\"index\":0},"
                                                                  "\"specularColorFactor\":[2,1,0.5],\"specularColorTexture\":{\"index\":0}"))));
  const SceneView rv = r.view();
  const Bsdf texel = rv.materials.bsdf(0, rv.textures, {0.75f, 0.25f});  // top right: (200, 100, 50, 128)
  auto srgb = [](double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); };
  EXPECT_NEAR(texel.gltf_pbr.specular_strength, 0.3 * 128 / 255.0, 1e-6);
  EXPECT_NEAR(texel.gltf_pbr.specular_color.x, 2.0 * srgb(200 / 255.0), 1e-5);
  EXPECT_NEAR(texel.gltf_pbr.specular_color.y, 1.0 * srgb(100 / 255.0), 1e-5);
  EXPECT_NEAR(texel.gltf_pbr.specular_color.z, 0.5 * srgb(50 / 255.0), 1e-5);
  // Specular-glossiness carried by the extension (its README's conversion):
  // KHR_materials_ior's ior 0 is f0 = 1, so F0 is the specular colour.
  Scene sg = load_scene(gltf("sg.gltf", bin, doc("\"specularColorFactor\":[0.2,0.5,0.9]},\"KHR_materials_ior\":{\"ior\":0")));
  EXPECT_EQ(sg.materials[0].bsdf.gltf_pbr.f0, 1.f);
  luz_test::expect_load_refused(gltf("ior.gltf", bin, doc("},\"KHR_materials_ior\":{\"ior\":0.5")), "ior.gltf",
                                "KHR_materials_ior's ior must be 0 or >= 1");
  luz_test::expect_load_refused(gltf("bad1.gltf", bin, doc("\"specularColorFactor\":[1,-1,1]")), "bad1.gltf",
                                "specularColorFactor must be finite and >= 0");
  luz_test::expect_load_refused(gltf("bad2.gltf", bin, doc("\"specularFactor\":2")), "bad2.gltf",
                                "specularFactor must lie in [0, 1]");
  luz_test::expect_load_refused(gltf("bad3.gltf", bin, doc("\"specularTexture\":{\"texCoord\":0}")), "bad3.gltf",
                                "specularTexture needs an index");
}

// KHR_materials_clearcoat: clearcoatFactor times clearcoatTexture's R is the
// coat's weight, clearcoatRoughnessFactor times clearcoatRoughnessTexture's
// G its roughness (linear); a zero factor disables the coat; what Luz
// leaves out (the coat's own normal texture, the coat on a transmitting
// material) is warned about; bad factors are errors.
TEST_F(GltfFiles, ClearcoatExtensionFactorsAndTextures) {
  four_texels();
  const std::string bin = textured_quad_bin();
  auto doc = [&](const std::string& coat, const std::string& more = "") {
    return textured_quad_json() + ",\"textures\":[{\"source\":0}],\"materials\":[{"
           "\"pbrMetallicRoughness\":{\"metallicFactor\":0},\"extensions\":{\"KHR_materials_clearcoat\":{" + coat + "}" +
           more + "}}]";
  };
  Scene c = load_scene(gltf("constant.gltf", bin, doc("\"clearcoatFactor\":0.6,\"clearcoatRoughnessFactor\":0.2")));
  EXPECT_EQ(c.materials[0].num_bindings, 0u);
  EXPECT_EQ(c.materials[0].bsdf.gltf_pbr.clearcoat, 0.6f);
  EXPECT_EQ(c.materials[0].bsdf.gltf_pbr.clearcoat_roughness, 0.2f);
  Scene off = load_scene(gltf("off.gltf", bin, doc("\"clearcoatFactor\":0,\"clearcoatTexture\":{\"index\":0}")));
  EXPECT_EQ(off.materials[0].bsdf.gltf_pbr.clearcoat, 0.f);
  EXPECT_EQ(off.materials[0].num_bindings, 0u);
  Scene t = load_scene(gltf("textured.gltf", bin,
                            doc("\"clearcoatFactor\":0.5,\"clearcoatTexture\":{\"index\":0},"
                                "\"clearcoatRoughnessFactor\":0.8,\"clearcoatRoughnessTexture\":{\"index\":0},"
                                "\"clearcoatNormalTexture\":{\"index\":0}")));
  const Material& m = t.materials[0];
  ASSERT_EQ(m.num_bindings, 2u);
  EXPECT_EQ(t.texture_bindings[m.first_binding].param, BsdfParam::Clearcoat);
  EXPECT_EQ(t.textures[size_t(t.texture_bindings[m.first_binding].texture)].bitmap.channel, TextureChannel::R);
  EXPECT_EQ(t.texture_bindings[m.first_binding + 1].param, BsdfParam::ClearcoatRoughness);
  EXPECT_EQ(t.textures[size_t(t.texture_bindings[m.first_binding + 1].texture)].bitmap.channel, TextureChannel::G);
  // At the red texel (top left): weight 0.5 · 1, roughness 0.8 · 0.
  const SceneView v = t.view();
  const Bsdf at = v.materials.bsdf(0, v.textures, {0.25f, 0.25f});
  EXPECT_NEAR(at.gltf_pbr.clearcoat, 0.5f, 1e-6f);
  EXPECT_NEAR(at.gltf_pbr.clearcoat_roughness, 0.f, 1e-6f);
  EXPECT_TRUE(luz_test::has_warning(t, "clearcoatNormalTexture is ignored"));
  Scene sheet = load_scene(gltf("sheet.gltf", bin,
                                doc("\"clearcoatFactor\":0.5", ",\"KHR_materials_transmission\":{\"transmissionFactor\":1}")));
  EXPECT_TRUE(luz_test::has_warning(sheet, "KHR_materials_clearcoat on a transmitting material is not supported"));
  EXPECT_EQ(sheet.materials[0].bsdf.type, BsdfType::GltfPbrTransmission);
  // A transmission texture times the default factor 0 is no transmission: the coat stays.
  Scene opaque = load_scene(gltf("opaque.gltf", bin, doc("\"clearcoatFactor\":0.5",
                                                          ",\"KHR_materials_transmission\":{\"transmissionTexture\":{\"index\":0}}")));
  EXPECT_EQ(opaque.materials[0].bsdf.type, BsdfType::GltfPbr);
  EXPECT_EQ(opaque.materials[0].bsdf.gltf_pbr.clearcoat, 0.5f);
  luz_test::expect_load_refused(gltf("bad.gltf", bin, doc("\"clearcoatFactor\":1.5")), "bad.gltf",
                                "clearcoatFactor must lie in [0, 1]");
}

// KHR_materials_diffuse_transmission: diffuseTransmissionFactor times its
// texture's A (linear) is the share of the diffuse part that passes through,
// diffuseTransmissionColorFactor times its texture (sRGB) its colour; a
// factor above 0 makes the thin transmitting sheet (also without
// KHR_materials_transmission); the extension is not warned about; bad
// factors are errors.
TEST_F(GltfFiles, DiffuseTransmissionExtensionFactorsAndTextures) {
  four_texels();
  const std::string bin = textured_quad_bin();
  auto doc = [&](const std::string& dt, const std::string& more = "") {
    return textured_quad_json() + ",\"textures\":[{\"source\":0}],"
           "\"extensionsUsed\":[\"KHR_materials_diffuse_transmission\"],\"materials\":[{"
           "\"pbrMetallicRoughness\":{\"metallicFactor\":0},\"extensions\":{\"KHR_materials_diffuse_transmission\":{" +
           dt + "}" + more + "}}]";
  };
  Scene c = load_scene(gltf("constant.gltf", bin, doc("\"diffuseTransmissionFactor\":0.6,"
                                                      "\"diffuseTransmissionColorFactor\":[1,0.5,0.25]")));
  ASSERT_EQ(c.materials[0].bsdf.type, BsdfType::GltfPbrTransmission);
  const GltfPbrTransmissionBsdf& sheet = c.materials[0].bsdf.gltf_pbr_transmission;
  EXPECT_EQ(sheet.transmission, 0.f);
  EXPECT_EQ(sheet.diffuse_transmission, 0.6f);
  EXPECT_EQ(sheet.diffuse_transmission_color.y, 0.5f);
  EXPECT_EQ(c.materials[0].num_bindings, 0u);
  EXPECT_FALSE(luz_test::has_warning(c, "KHR_materials_diffuse_transmission"));
  // A zero factor (the default) is no transmission, its texture none.
  Scene off = load_scene(gltf("off.gltf", bin, doc("\"diffuseTransmissionTexture\":{\"index\":0}")));
  EXPECT_EQ(off.materials[0].bsdf.type, BsdfType::GltfPbr);
  EXPECT_EQ(off.materials[0].num_bindings, 0u);
  // With specular transmission as well (the extension's combined mix).
  Scene both = load_scene(gltf("both.gltf", bin, doc("\"diffuseTransmissionFactor\":1",
                                                     ",\"KHR_materials_transmission\":{\"transmissionFactor\":0.5}")));
  EXPECT_EQ(both.materials[0].bsdf.gltf_pbr_transmission.transmission, 0.5f);
  EXPECT_EQ(both.materials[0].bsdf.gltf_pbr_transmission.diffuse_transmission, 1.f);
  // Textures of texels other than 0 and 1.
  Scene t = load_scene(gltf("textured.gltf", bin,
                            with_rgba_texels(doc("\"diffuseTransmissionFactor\":0.8,\"diffuseTransmissionTexture\":{\"index\":0},"
                                                 "\"diffuseTransmissionColorFactor\":[1,0.5,0.25],"
                                                 "\"diffuseTransmissionColorTexture\":{\"index\":0}"))));
  const Material& m = t.materials[0];
  ASSERT_EQ(m.num_bindings, 2u);
  const TextureBinding& a = t.texture_bindings[m.first_binding], &b = t.texture_bindings[m.first_binding + 1];
  EXPECT_EQ(a.param, BsdfParam::DiffuseTransmission);
  EXPECT_EQ(t.textures[size_t(a.texture)].bitmap.channel, TextureChannel::A);
  EXPECT_EQ(b.param, BsdfParam::DiffuseTransmissionColor);
  EXPECT_TRUE(t.textures[size_t(b.texture)].bitmap.srgb);
  const SceneView v = t.view();
  const Bsdf texel = v.materials.bsdf(0, v.textures, {0.75f, 0.25f});  // top right: (200, 100, 50, 128)
  auto srgb = [](double x) { return x <= 0.04045 ? x / 12.92 : std::pow((x + 0.055) / 1.055, 2.4); };
  EXPECT_NEAR(texel.gltf_pbr_transmission.diffuse_transmission, 0.8 * 128 / 255.0, 1e-6);
  EXPECT_NEAR(texel.gltf_pbr_transmission.diffuse_transmission_color.x, srgb(200 / 255.0), 1e-5);
  EXPECT_NEAR(texel.gltf_pbr_transmission.diffuse_transmission_color.y, 0.5 * srgb(100 / 255.0), 1e-5);
  EXPECT_NEAR(texel.gltf_pbr_transmission.diffuse_transmission_color.z, 0.25 * srgb(50 / 255.0), 1e-5);
  luz_test::expect_load_refused(gltf("bad1.gltf", bin, doc("\"diffuseTransmissionFactor\":1.5")), "bad1.gltf",
                                "diffuseTransmissionFactor must lie in [0, 1]");
  luz_test::expect_load_refused(gltf("bad2.gltf", bin, doc("\"diffuseTransmissionFactor\":0.5,"
                                                           "\"diffuseTransmissionColorFactor\":[1,2,1]")),
                                "bad2.gltf", "diffuseTransmissionColorFactor must lie in [0, 1]");
  luz_test::expect_load_refused(gltf("bad3.gltf", bin, doc("\"diffuseTransmissionColorFactor\":[1,1]")), "bad3.gltf",
                                "diffuseTransmissionColorFactor needs 3 numbers");
}

// Normal textures (§3.9.3, tangents by MikkTSpace where TANGENT is absent):
// the map's x follows +u, its y the image's up (glTF's v runs down), on a
// mirrored uv layout too; `scale` multiplies x and y. A constant map of the
// tangent-space normal n on the quad of z = 0 facing +z, its image's up
// along world +y: u along +x gives (n.x, n.y, n.z), u along -x (mirrored)
// (-n.x, n.y, n.z).
TEST_F(GltfFiles, NormalTexturesFollowTheImagesUp) {
  const double nx = 0.3, ny = 0.4, nz = std::sqrt(1 - nx * nx - ny * ny);
  Image img;
  img.width = img.height = 2;
  for (int k = 0; k < 4; ++k)
    for (double c : {nx, ny, nz}) img.rgb.push_back(float((c + 1) / 2));
  write_image((dir / "n.png").string(), img);
  // The map as its bytes say (the PNG holds sRGB-encoded values; glTF reads normal textures raw).
  const Image8 bytes8 = read_image8((dir / "n.png").string());
  auto raw = [&](int c) { return 2.0 * ((bytes8.rgba[0] >> (8 * c)) & 255) / 255.0 - 1.0; };
  const Vec3 n = normalize(Vec3{float(raw(0)), float(raw(1)), float(raw(2))});
  EXPECT_GT(n.x, 0.1f);
  EXPECT_GT(n.y, 0.1f);
  auto frame = [&](const std::string& name, std::vector<float> uv, double scale) {
    const std::string doc =
        views(",{\"buffer\":0,\"byteOffset\":60,\"byteLength\":32}",
              ",{\"bufferView\":3,\"componentType\":5126,\"count\":4,\"type\":\"VEC2\"}") +
        ",\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":3},\"indices\":1,\"mode\":5,"
        "\"material\":0}]}],\"nodes\":[{\"mesh\":0}],\"images\":[{\"uri\":\"n.png\"}],\"textures\":[{\"source\":0}],"
        "\"materials\":[{\"normalTexture\":{\"index\":0,\"scale\":" + std::to_string(scale) + "}}]";
    Scene s = load_scene(gltf(name, quad_bin() + bytes(uv), doc));
    const SceneView v = s.view();
    EXPECT_EQ(v.num_triangles, 2u);
    Vec3 first{0, 0, 0};  // both triangles' normals agree
    for (uint32_t prim = 0; prim < v.num_triangles; ++prim) {
      Hit hit;
      hit.prim = prim, hit.u = 1.f / 3, hit.v = 1.f / 3, hit.t = 4.f;
      const Vec3 c = (s.positions[s.indices[3 * prim]] + s.positions[s.indices[3 * prim + 1]] + s.positions[s.indices[3 * prim + 2]]) / 3.f;
      Ray ray{c + Vec3{0, 0, 4}, {0, 0, -1}};
      Interaction it = v.interaction(ray, hit);
      const Frame f = v.shading_frame(it, hit);
      if (prim == 0) first = f.n;
      EXPECT_NEAR(length(f.n - first), 0.f, 1e-5f) << name << ": triangle " << prim;
    }
    return first;
  };
  // Image up along +y: v = 1 - y. Vertices (0,0), (1,0), (0,1), (1,1).
  const Vec3 plain = frame("plain.gltf", {0, 1, 1, 1, 0, 0, 1, 0}, 1.0);
  const Vec3 mirrored = frame("mirrored.gltf", {1, 1, 0, 1, 1, 0, 0, 0}, 1.0);
  const Vec3 want_plain = n, want_mirrored{-n.x, n.y, n.z};
  EXPECT_NEAR(length(plain - want_plain), 0.f, 1e-5f) << plain.x << " " << plain.y << " " << plain.z;
  EXPECT_NEAR(length(mirrored - want_mirrored), 0.f, 1e-5f) << mirrored.x << " " << mirrored.y << " " << mirrored.z;
  const Vec3 half = frame("half.gltf", {0, 1, 1, 1, 0, 0, 1, 0}, 0.5);
  const Vec3 want_half = normalize(Vec3{n.x / 2, n.y / 2, n.z});
  EXPECT_NEAR(length(half - want_half), 0.f, 1e-5f) << half.x << " " << half.y << " " << half.z;
}

// Texture channels and scales (the glTF factors): one bitmap read as RGB,
// as G and as A (linear), scaled; and the MASK cutoff on a texture's alpha.
// COLOR_0 multiplies the base colour (§3.7.2.1: "vertex colour linear
// multiplier"): factor × COLOR_0, and factor × texture × COLOR_0 with a
// baseColorTexture; a primitive without COLOR_0 sharing the material gets the
// factor alone. Normalised unsigned bytes (VEC4) on one quad drawn three
// times; at a hit the material's base colour must be the product computed
// here from the file's bytes, interpolated with the hit's barycentrics. The
// alpha of COLOR_0 is ignored with a warning where the material blends.
TEST_F(GltfFiles, VertexColoursMultiplyTheBaseColour) {
  const Image img = four_texels();
  const std::vector<uint8_t> rgba = {255, 0, 0, 255, 0, 255, 0, 128, 0, 0, 255, 255, 51, 102, 204, 255};
  const std::vector<float> uv = {0, 0, 1, 0, 0, 1, 1, 1};
  const std::string bin = quad_bin() + bytes(rgba) + bytes(uv);
  const std::string doc =
      views(",{\"buffer\":0,\"byteOffset\":60,\"byteLength\":16},{\"buffer\":0,\"byteOffset\":76,\"byteLength\":32}",
            ",{\"bufferView\":3,\"componentType\":5121,\"normalized\":true,\"count\":4,\"type\":\"VEC4\"},"
            "{\"bufferView\":4,\"componentType\":5126,\"count\":4,\"type\":\"VEC2\"}") +
      ",\"meshes\":[{\"primitives\":["
      "{\"attributes\":{\"POSITION\":0,\"COLOR_0\":3},\"indices\":1,\"mode\":5,\"material\":0},"
      "{\"attributes\":{\"POSITION\":0},\"indices\":1,\"mode\":5,\"material\":0},"
      "{\"attributes\":{\"POSITION\":0,\"COLOR_0\":3,\"TEXCOORD_0\":4},\"indices\":1,\"mode\":5,\"material\":1}]}],"
      "\"nodes\":[{\"mesh\":0}],\"images\":[{\"uri\":\"tex.png\"}],\"samplers\":[{\"magFilter\":9728}],"
      "\"textures\":[{\"source\":0,\"sampler\":0}],\"materials\":["
      "{\"alphaMode\":\"BLEND\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,1,0.25,1]}},"
      "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,0.5,1,1],\"baseColorTexture\":{\"index\":0}}}]";
  Scene s = load_scene(gltf("colors.gltf", bin, doc));
  ASSERT_EQ(s.num_triangles(), 6u);
  ASSERT_EQ(s.colors.size(), s.positions.size());
  EXPECT_TRUE(luz_test::has_warning(s, "COLOR_0's alpha is ignored")) << s.warnings.size();
  const SceneView v = s.view();
  const double factor[2][3] = {{0.5, 1, 0.25}, {1, 0.5, 1}};
  for (uint32_t t = 0; t < 6; ++t) {
    const uint32_t prim = t / 2;  // each primitive's strip gives two triangles, in order
    const uint32_t* idx = s.indices.data() + 3 * t;
    ASSERT_EQ(idx[0] / 4, prim);
    Hit hit;
    hit.prim = t;
    hit.u = 0.2f, hit.v = 0.5f;
    const double w[3] = {0.3, 0.2, 0.5};
    double want[3] = {0, 0, 0}, u = 0, vv = 0;
    for (int c = 0; c < 3; ++c) {
      const uint32_t j = idx[c] % 4;  // the vertex in the file
      for (int k = 0; k < 3; ++k) want[k] += w[c] * (prim == 1 ? 1.0 : rgba[4 * j + size_t(k)] / 255.0);
      u += w[c] * uv[2 * j], vv += w[c] * uv[2 * j + 1];
    }
    const Vec2 huv = v.hit_uv(hit, {});
    const Bsdf b = v.materials.bsdf(s.tri_material[t], v.textures, huv, v.hit_color(hit));
    const int texel = int(std::floor(vv * 2)) * 2 + int(std::floor(u * 2));
    for (int k = 0; k < 3; ++k) {
      const double tex = prim == 2 ? img.rgb[3 * size_t(texel) + size_t(k)] : 1.0;
      EXPECT_NEAR(b.gltf_pbr.base_color[k], factor[prim == 2][k] * tex * want[k], 1e-5) << t << " " << k;
    }
  }
  EXPECT_NE(s.tri_material[0], s.tri_material[2]) << "the material without COLOR_0 is its own";
  EXPECT_EQ(s.materials[s.tri_material[2]].num_bindings, 0u);
  // An emissive texture splits the primitive into one mesh per lit
  // triangle: each vertex keeps its colour (found by its position: the
  // quad's corners (0, 0), (1, 0), (0, 1), (1, 1) in the file's order).
  std::string lit = doc;
  const std::string tail = "\"baseColorTexture\":{\"index\":0}}}]";
  ASSERT_NE(lit.find(tail), std::string::npos);
  lit.replace(lit.find(tail), tail.size(),
              "\"baseColorTexture\":{\"index\":0}},\"emissiveFactor\":[1,1,1],\"emissiveTexture\":{\"index\":0}}]");
  Scene e = load_scene(gltf("lit.gltf", bin, lit));
  ASSERT_EQ(e.lights.size(), 2u);  // every texel lit: both triangles emit
  ASSERT_EQ(e.positions.size(), 4u + 4u + 6u);  // primitives 0 and 1, then the lit triangles' own vertices
  ASSERT_EQ(e.colors.size(), e.positions.size());
  for (size_t k = 0; k < e.positions.size(); ++k) {
    const size_t j = size_t(e.positions[k].x) + 2 * size_t(e.positions[k].y);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(e.colors[k][c], k >= 4 && k < 8 ? 1.0 : rgba[4 * j + size_t(c)] / 255.0, 1e-6) << k;
  }
  luz_test::expect_load_refused(
      gltf("badcolor.gltf", bin,
           views(",{\"buffer\":0,\"byteOffset\":60,\"byteLength\":16}",
                 ",{\"bufferView\":3,\"componentType\":5121,\"count\":4,\"type\":\"VEC4\"}") +
               ",\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"COLOR_0\":3},\"indices\":1}]}],"
               "\"nodes\":[{\"mesh\":0}]"),
      "badcolor.gltf", "COLOR_0 must be VEC3 or VEC4 of floats or normalised unsigned bytes or shorts");
}

TEST(GltfTextures, ChannelScaleAndCutoff) {
  Scene s;
  BitmapTexture b;
  b.width = 2;
  b.height = 1;
  b.srgb = false;
  b.filter = TextureFilter::Nearest;
  const uint32_t rgb = s.add_bitmap(b, {}, std::vector<uint32_t>{pack_rgba8(255, 51, 102, 0), pack_rgba8(0, 0, 0, 204)});
  Texture g = s.textures[rgb];
  g.bitmap.channel = TextureChannel::G;
  g.scale = {2.f, 2.f, 2.f};
  const uint32_t tg = s.add_texture(g);
  Texture a = s.textures[rgb];
  a.bitmap.channel = TextureChannel::A;
  a.bitmap.srgb = true;  // alpha is linear whatever the colour encoding
  const uint32_t ta = s.add_texture(a);
  s.compile();
  const SceneView v = s.view();
  const Color c = v.textures.eval(rgb, {0.25f, 0.5f});
  EXPECT_NEAR(c.y, 0.2f, 1e-6f);
  const Color cg = v.textures.eval(tg, {0.25f, 0.5f});
  EXPECT_NEAR(cg.x, 0.4f, 1e-6f);
  EXPECT_NEAR(cg.z, 0.4f, 1e-6f);
  EXPECT_NEAR(luminance(cg), 0.4f, 1e-6f);
  EXPECT_NEAR(v.textures.eval(ta, {0.75f, 0.5f}).y, 0.8f, 1e-6f);
  EXPECT_EQ(v.textures.eval(ta, {0.25f, 0.5f}).y, 0.f);
}

// Malformed and truncated files: one InputError line naming the file, never
// a crash. Variants of the Box (its buffer is a data URI), then the GLB cut
// at 97 lengths and with its chunk lengths lying.
TEST_F(GltfFiles, MalformedFilesGiveOneInputError) {
  const std::string box = read_file(kBox);
  ASSERT_FALSE(box.empty());
  auto variant = [&](const std::string& from, const std::string& to) {
    std::string t = box;
    const size_t at = t.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) t.replace(at, from.size(), to);
    return t;
  };
  struct Case {
    std::string text, problem;
  };
  const std::vector<Case> cases = {
      {box.substr(0, box.size() / 2), ""},
      {"", ""},
      {"{}", ""},
      {variant("\"count\": 36", "\"count\": 360000000"), "do not fit"},
      {variant("\"count\": 24", "\"count\": 25"), "differ in count"},
      {variant("\"byteOffset\": 288", "\"byteOffset\": 290"), "do not fit"},
      {variant("\"children\": [\n                1\n            ]", "\"children\": [\n                0\n            ]"),
       "reached twice"},
      {variant("\"mesh\": 0", "\"mesh\": 7"), ""},
      {variant("\"material\": 0", "\"material\": 3"), "no material"},
      {variant("\"mode\": 4", "\"mode\": 9"), "unknown mode"},
      {variant("0.800000011920929", "1.5"), "baseColorFactor"},
      {variant("\"asset\": {", "\"extensionsRequired\": [\"KHR_draco_mesh_compression\"], \"asset\": {"),
       "KHR_draco_mesh_compression"},
      {variant("\"byteOffset\": 576", "\"byteOffset\": 1000000"), ""},
      {variant("\"componentType\": 5123", "\"componentType\": 5126"), ""},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string name = "bad" + std::to_string(i) + ".gltf";
    const std::string p = write(name, cases[i].text);
    try {
      load_scene(p);
      if (!cases[i].problem.empty() || i < 3) ADD_FAILURE() << "accepted case " << i;
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(name + ":"), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
      if (!cases[i].problem.empty()) EXPECT_NE(what.find(cases[i].problem), std::string::npos) << i << ": " << what;
    }
  }
  // The helmet's GLB cut short, and with lying chunk lengths.
  const std::string glb = read_file(kHelmetGlb);
  ASSERT_GT(glb.size(), 1000u);
  int refused = 0;
  for (int k = 0; k < 97; ++k) {
    const size_t len = k < 32 ? size_t(k) : glb.size() * size_t(k - 31) / 66;
    if (len >= glb.size()) break;
    const std::string p = write("cut.glb", glb.substr(0, len));
    try {
      load_scene(p);
      ADD_FAILURE() << "a GLB cut at " << len << " bytes was accepted";
    } catch (const InputError& e) {
      ++refused;
      EXPECT_NE(std::string(e.what()).find("cut.glb"), std::string::npos) << e.what();
    }
  }
  EXPECT_GT(refused, 90);
  for (size_t off : {size_t(8), size_t(12), size_t(20)}) {  // total length, JSON chunk length, BIN chunk length
    std::string bad = glb;
    if (off == 20) off = 20 + size_t(uint8_t(glb[12])) + (size_t(uint8_t(glb[13])) << 8) + (size_t(uint8_t(glb[14])) << 16);
    bad[off] = char(0xff), bad[off + 1] = char(0xff), bad[off + 2] = char(0xff), bad[off + 3] = char(0x7f);
    luz_test::expect_load_refused(write("lying.glb", bad), "lying.glb", "");
  }
}

// The command line: the Box (no light) renders under the white sky with
// exactly one warning line saying so; a truncated GLB and a broken .gltf exit with status 2 and one
// line naming the file.
class GltfCli : public luz_test::LuzCliTest {};

TEST_F(GltfCli, NoLightWarningAndBadFiles) {
  auto lines = [](const std::string& s) {
    std::vector<std::string> v;
    std::stringstream ss(s);
    for (std::string l; std::getline(ss, l);) v.push_back(l);
    return v;
  };
  luz_test::CliResult r = run({"render", kBox, "--spp", "1", "-o", "box.png"});
  ASSERT_TRUE(r.exited);
  EXPECT_EQ(r.status, 0) << r.err;
  int warnings = 0;
  for (const std::string& l : lines(r.err)) warnings += l.find("warning") != std::string::npos;
  EXPECT_EQ(warnings, 1) << r.err;
  EXPECT_NE(r.err.find("no light"), std::string::npos) << r.err;
  const std::string glb = read_file(kHelmetGlb);
  write("cut.glb", glb.substr(0, glb.size() / 3));
  write("broken.gltf", read_file(kBox).substr(0, 700));
  for (const char* bad : {"cut.glb", "broken.gltf"}) {
    r = run({"render", bad, "-o", "x.png"});
    ASSERT_TRUE(r.exited) << bad << ": killed by signal " << r.signal;
    EXPECT_EQ(r.status, 2) << bad;
    const std::vector<std::string> err = lines(r.err);
    ASSERT_EQ(err.size(), 1u) << r.err;
    EXPECT_NE(err[0].find(bad), std::string::npos) << err[0];
  }
}
