// Bitmap textures, texture coordinates and Mitsuba 0.5 scenes:
// - the lookup (texture.h) against hand-computed bilinear and nearest values
//   on 3×3 and 2×2 textures, wrap-around at the edges, uv scale and offset;
//   the sRGB decoding table against the standard formula; a run-length TGA
//   packed as tightly as the format allows is read;
// - texture coordinates from OBJ (vt, v flipped as Mitsuba does) interpolated
//   with the hit's own barycentrics: at any hit, uv is the affine function of
//   the position that the file's vt encode; meshes with and without uvs mixed
//   in one scene keep them aligned, and diffuse, plastic and roughplastic all
//   see the texture's value through SceneView::material();
// - a textured quad facing the camera under a uniform environment: each
//   pixel shows the texel its footprint covers (found by intersecting the
//   pixel's centre ray with the plane here, not by Luz's uv code), within a
//   bound from the pixel's own variance; the upside-down texture must fail;
// - vertex colours (mesh_attribute vertex_color, from PLY files): alone and
//   in a product; a quad whose corner colours are an affine function of the
//   position shows that function under a uniform environment (mirrored, it
//   fails); integer channels normalised and sRGB-decoded; meshes with and
//   without colours mixed; colours kept through every vertex copy; face
//   colours constant over their faces; every bad use one error;
// - Mitsuba 0.5 names (camelCase, ldrfilm) load to the same scene as their
//   Mitsuba 3 spelling, and a bad name is a file:line error;
// - the Wooden Staircase (../shared/scenes/staircase, skipped without it):
//   it loads with 262,663 triangles, a tiny render is finite, and a low
//   resolution render agrees with Tungsten's reference within Luz's noise
//   plus a stated tolerance.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "sanitizer.h"
#include "temp_dir.h"
#include "luz/device/cpu/render.h"
#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "scene_helpers.h"
#include "stat_helpers.h"

namespace fs = std::filesystem;
using namespace luz;

namespace {

// The standard sRGB decoding, in double.
double srgb_decode(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

// A linear (non-sRGB) texture over the given bytes (one value per texel, the
// same in R, G and B, so a lookup's red channel is a plain number), looked up
// through a TextureView as the renderer does.
struct TinyTexture {
  Texture tex;
  std::vector<uint32_t> texels;
  std::vector<float> table;  // unused for linear texels
  TinyTexture(uint32_t w, uint32_t h, std::vector<uint32_t> bytes, TextureFilter f = TextureFilter::Bilinear,
              WrapMode wrap = WrapMode::Repeat) {
    BitmapTexture& b = tex.bitmap;
    b.width = w;
    b.height = h;
    b.filter = f;
    b.wrap = wrap;
    b.srgb = false;
    for (uint32_t v : bytes) texels.push_back(pack_rgba8(v, v, v));
    table.assign(256, 0.f);
  }
  TextureView view() const {
    TextureView v;
    v.list = &tex;
    v.texels8 = texels.data();
    v.srgb_table = table.data();
    v.count = 1;
    return v;
  }
  double at(float u, float v) const { return view().eval(0, {u, v}).x * 255.0; }
};

}  // namespace

// 3×3 texture, values v(i, j) = 10 (3 j + i) + 5 (column i, row j from the top).
TEST(TextureLookup, BilinearMatchesHandComputedValuesAndWraps) {
  TinyTexture t(3, 3, {5, 15, 25, 35, 45, 55, 65, 75, 85});
  const double eps = 1e-3;
  // Texel centres: (i + 0.5) / 3.
  EXPECT_NEAR(t.at(0.5f / 3, 0.5f / 3), 5, eps);
  EXPECT_NEAR(t.at(1.5f / 3, 2.5f / 3), 75, eps);
  // Halfway between the centres of (0,0) and (1,0): 10; a quarter of the way
  // from (1,1) to (2,2) on both axes: 0.75² 45 + 2 · 0.75 · 0.25 (55 + 75) / 2 + 0.25² 85.
  EXPECT_NEAR(t.at(1.f / 3, 0.5f / 3), 10, eps);
  EXPECT_NEAR(t.at(1.75f / 3, 1.75f / 3), 0.5625 * 45 + 0.1875 * 55 + 0.1875 * 75 + 0.0625 * 85, eps);
  // Left edge u = 0: halfway between column 2 (wrapped) and column 0.
  EXPECT_NEAR(t.at(0.f, 0.5f / 3), (25 + 5) / 2.0, eps);
  // u = 0.9 (x = 2.2 texel units): 0.8 · column 2 + 0.2 · column 0 (wrapped).
  EXPECT_NEAR(t.at(0.9f, 0.5f / 3), 0.8 * 25 + 0.2 * 5, eps);
  // Top-left corner: the four corner texels, a quarter each.
  EXPECT_NEAR(t.at(0.f, 0.f), (5 + 25 + 65 + 85) / 4.0, eps);
  // Repeat: whole periods away, in either direction, read the same.
  EXPECT_NEAR(t.at(1.9f, -0.5f / 3 + 2.f), t.at(0.9f, 2.5f / 3), eps);
  EXPECT_NEAR(t.at(-0.1f, 0.5f / 3), 0.8 * 25 + 0.2 * 5, eps);
  // A non-finite coordinate reads as 0 (no out-of-range index).
  EXPECT_EQ(t.at(NAN, INFINITY), t.at(0.f, 0.f));
}

// The taps texture_lookup reads and SceneView::prefetch_texture asks the
// caches for lie inside the texture for any uv, non-finite and huge ones
// too (a prefetch outside would be harmless on x86 but not a lookup), and
// the lookup reads exactly those four texels: a texture whose texels
// outside the taps are poisoned (255) reads the taps' own mix.
TEST(TextureLookup, BilinearTapsStayInsideTheTextureForAnyUv) {
  const float odd[] = {0.f, -0.f, 1.f, -1.f, 0.5f, 1e-30f, -1e-30f, 0.99999994f, 1.00000012f, 3e7f, -3e7f,
                       1e30f, -1e30f, INFINITY, -INFINITY, NAN};
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> any(-5.f, 5.f);
  for (uint32_t w : {1u, 2u, 3u, 7u}) {
    for (uint32_t h : {1u, 4u}) {
      for (WrapMode wrap : {WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp}) {
        TinyTexture d(w, h, std::vector<uint32_t>(size_t(w) * h, 255), TextureFilter::Bilinear, wrap);
        d.tex.to_uv = {1.5f, 0.f, 0.25f, 0.f, -2.f, 0.75f};
        std::vector<Vec2> uvs;
        for (float u : odd)
          for (float v : odd) uvs.push_back({u, v});
        for (int k = 0; k < 2000; ++k) uvs.push_back({any(rng), any(rng)});
        for (Vec2 uv : uvs) {
          const BilinearTaps t = bilinear_taps(d.tex.bitmap, d.tex.to_uv.apply(uv));
          ASSERT_LT(t.i0, w) << uv.x << " " << uv.y;
          ASSERT_LT(t.i1, w);
          ASSERT_LT(t.j0, h);
          ASSERT_LT(t.j1, h);
          ASSERT_TRUE(t.fx >= 0.f && t.fx <= 1.f && t.fy >= 0.f && t.fy <= 1.f);
          ASSERT_LT(nearest_texel(d.tex.bitmap, d.tex.to_uv.apply(uv)), w * h);
          // Poison everything but the taps (value 10 + tap number there).
          d.texels.assign(size_t(w) * h, pack_rgba8(255, 255, 255));
          d.texels[t.j0 * w + t.i0] = pack_rgba8(10, 10, 10);
          d.texels[t.j0 * w + t.i1] = pack_rgba8(11, 11, 11);
          d.texels[t.j1 * w + t.i0] = pack_rgba8(12, 12, 12);
          d.texels[t.j1 * w + t.i1] = pack_rgba8(13, 13, 13);
          const double got = d.at(uv.x, uv.y);
          ASSERT_GE(got, 10.0 - 1e-3);
          ASSERT_LE(got, 13.0 + 1e-3);
          d.view().prefetch(0, uv);
        }
      }
    }
  }
}

// Mirror and clamp against hand-computed values on a 3×1 texture (5 15 25):
// mirror reflects the texel row at each edge (…, 15, 5 | 5, 15, 25 | 25, 15, …),
// clamp repeats the edge texel.
TEST(TextureLookup, MirrorAndClampWrapModes) {
  const double eps = 1e-3;
  TinyTexture m(3, 1, {5, 15, 25}, TextureFilter::Bilinear, WrapMode::Mirror);
  EXPECT_NEAR(m.at(0.f, 0.5f), 5, eps);                 // between texel -1 (= 0) and 0
  EXPECT_NEAR(m.at(1.f, 0.5f), 25, eps);                // between texel 2 and 3 (= 2)
  EXPECT_NEAR(m.at(1.5f / 3 + 1.f, 0.5f), 15, eps);     // texel 4 = 1 (the row mirrored)
  EXPECT_NEAR(m.at(2.5f / 3 + 1.f, 0.5f), 5, eps);      // texel 5 = 0
  EXPECT_NEAR(m.at(0.5f / 3 - 2.f, 0.5f), 5, eps);      // a whole period (2) away
  EXPECT_NEAR(m.at(-0.5f / 3, 0.5f), 5, eps);           // texel -1 = 0
  EXPECT_NEAR(m.at(-1.5f / 3, 0.5f), 15, eps);          // texel -2 = 1
  EXPECT_NEAR(m.at(1.f + 1.f / 3, 0.5f), 20, eps);      // halfway between texels 3 (= 2) and 4 (= 1)
  TinyTexture c(3, 1, {5, 15, 25}, TextureFilter::Bilinear, WrapMode::Clamp);
  EXPECT_NEAR(c.at(0.f, 0.5f), 5, eps);
  EXPECT_NEAR(c.at(-7.f, 0.5f), 5, eps);
  EXPECT_NEAR(c.at(1.f, 0.5f), 25, eps);
  EXPECT_NEAR(c.at(3.f, 0.5f), 25, eps);
  EXPECT_NEAR(c.at(1.f / 3, 0.5f), 10, eps);
  EXPECT_NEAR(c.at(NAN, NAN), 5, eps);
  TinyTexture n(3, 1, {5, 15, 25}, TextureFilter::Nearest, WrapMode::Mirror);
  EXPECT_NEAR(n.at(1.1f, 0.5f), 25, eps);  // texel 3 = 2
  EXPECT_NEAR(n.at(1.5f, 0.5f), 15, eps);  // texel 4 = 1
  EXPECT_NEAR(n.at(-0.1f, 0.5f), 5, eps);  // texel -1 = 0
  n.tex.bitmap.wrap = WrapMode::Clamp;
  EXPECT_NEAR(n.at(1.5f, 0.5f), 25, eps);
  EXPECT_NEAR(n.at(-0.5f, 0.5f), 5, eps);
}

// Float texels are read as they are; a checkerboard is color0 where exactly
// one of frac(u), frac(v) exceeds 1/2 (Mitsuba 3); to_uv applies first.
TEST(TextureLookup, FloatTexelsCheckerboardAndToUv) {
  std::vector<Texture> list;
  BitmapTexture b;
  b.width = 2, b.height = 1, b.is_float = true, b.filter = TextureFilter::Nearest;
  list.emplace_back(b);
  Texture checker{CheckerboardTexture{{1.f, 2.f, 3.f}, {4.f, 5.f, 6.f}}};
  checker.to_uv = {2.f, 0.f, 0.f, 0.f, 2.f, 0.f};  // four squares per unit of uv
  list.push_back(checker);
  const std::vector<float> texelsf = {0.25f, 7.5f, 1e3f, 2.f, 0.f, 65504.f};
  TextureView v;
  v.list = list.data();
  v.texelsf = texelsf.data();
  v.count = 2;
  EXPECT_EQ(v.eval(0, {0.2f, 0.5f}).y, 7.5f);
  EXPECT_EQ(v.eval(0, {0.7f, 0.5f}).z, 65504.f);
  list[0].to_uv = {0.f, 1.f, 0.f, 1.f, 0.f, 0.f};  // u' = v
  EXPECT_EQ(v.eval(0, {0.2f, 0.7f}).x, 2.f);
  EXPECT_EQ(v.eval(1, {0.1f, 0.1f}).x, 4.f);   // (0.2, 0.2): neither > 1/2
  EXPECT_EQ(v.eval(1, {0.3f, 0.1f}).x, 1.f);   // (0.6, 0.2): one
  EXPECT_EQ(v.eval(1, {0.3f, 0.3f}).x, 4.f);   // (0.6, 0.6): both
  EXPECT_EQ(v.eval(1, {0.1f, -0.1f}).x, 1.f);  // (0.2, -0.2 -> 0.8): one
  EXPECT_NEAR(luminance({1.f, 1.f, 1.f}), 1.f, 1e-6f);
}

TEST(TextureLookup, NearestScaleAndOffset) {
  // 2×2: 10 20 / 30 40.
  TinyTexture t(2, 2, {10, 20, 30, 40}, TextureFilter::Nearest);
  EXPECT_NEAR(t.at(0.1f, 0.1f), 10, 1e-4);
  EXPECT_NEAR(t.at(0.9f, 0.1f), 20, 1e-4);
  EXPECT_NEAR(t.at(0.1f, 0.9f), 30, 1e-4);
  EXPECT_NEAR(t.at(0.6f, 0.6f), 40, 1e-4);
  EXPECT_NEAR(t.at(-0.4f, 1.1f), 20, 1e-4);  // wraps to (0.6, 0.1)
  // uv' = uv · (2, 1) + (0, 0.5): (0.3, 0.1) -> (0.6, 0.6).
  t.tex.to_uv = {2.f, 0.f, 0.f, 0.f, 1.f, 0.5f};
  EXPECT_NEAR(t.at(0.3f, 0.1f), 40, 1e-4);
}

TEST(TextureLookup, SrgbDecodingFollowsTheStandardFormula) {
  Scene s;
  BitmapTexture one_texel;
  one_texel.width = one_texel.height = 1;
  s.add_bitmap(one_texel, {}, std::vector<uint32_t>{pack_rgba8(0, 128, 255)});
  ASSERT_EQ(s.srgb_table.size(), 256u);
  for (int k = 0; k < 256; ++k) {
    EXPECT_NEAR(s.srgb_table[k], srgb_decode(k / 255.0), 1e-7) << k;
    EXPECT_NEAR(srgb_to_linear(k / 255.f), srgb_decode(k / 255.0), 2e-6) << k;
  }
  EXPECT_EQ(s.srgb_table[0], 0.f);
  EXPECT_NEAR(s.srgb_table[128], 0.2158605, 1e-6);  // a tabulated value of the standard
  EXPECT_NEAR(s.srgb_table[255], 1.0, 1e-7);
  // An sRGB texel decodes through the table; the same bytes as linear do not.
  SceneView v = s.view();
  Color c = v.textures.eval(0, {0.5f, 0.5f});
  EXPECT_NEAR(c.y, 0.2158605, 1e-6);
  s.textures[0].bitmap.srgb = false;
  EXPECT_NEAR(s.view().textures.eval(0, {0.5f, 0.5f}).y, 128.0 / 255, 1e-6);
}

// A run-length TGA as tightly packed as the format allows (runs of 128
// grey pixels in 2 bytes, 64 pixels a byte) is read, not taken for a file
// whose header claims more pixels than it holds.
TEST(ImageRead, TightestRunLengthTgaReads) {
  const int w = 2048, h = 2048;
  std::vector<uint8_t> tga = {0, 0, 11, 0, 0, 0, 0, 0, 0, 0, 0, 0, uint8_t(w), uint8_t(w >> 8), uint8_t(h), uint8_t(h >> 8), 8,
                              0x20};  // top-left origin
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; x += 128) tga.insert(tga.end(), {0xFF, uint8_t(y + x / 128)});
  const Image8 img = decode_image8("tight.tga", tga.data(), tga.size());
  ASSERT_EQ(img.width, w);
  ASSERT_EQ(img.height, h);
  for (int y : {0, 1, 700, h - 1})
    for (int x : {0, 127, 128, 1000, w - 1}) EXPECT_EQ(img.rgba[size_t(y) * w + x] & 0xff, uint8_t(y + x / 128)) << x << "," << y;
}

using ImageFiles = TempDirTest;

// PFM files of every kind the format has: RGB ("PF") and grey ("Pf", read
// into all three channels), little-endian (negative scale) and big-endian
// (positive), a scale other than 1 multiplying the values (as pbrt-v4 and
// Mitsuba 3 read them), rows stored bottom to top. Bad headers and short
// files are one-line errors.
TEST_F(ImageFiles, PfmOfEveryKind) {
  auto bytes = [](std::initializer_list<float> values, bool big_endian) {
    std::string out;
    for (float v : values) {
      char b[4];
      std::memcpy(b, &v, 4);
      if (big_endian) std::swap(b[0], b[3]), std::swap(b[1], b[2]);
      out.append(b, 4);
    }
    return out;
  };
  Image rgb = read_pfm(write("rgb.pfm", "PF\n2 1\n-1.0\n" + bytes({1, 2, 3, 4, 5, 6}, false)));
  ASSERT_EQ(rgb.width, 2);
  ASSERT_EQ(rgb.height, 1);
  EXPECT_EQ(rgb.rgb, (std::vector<float>{1, 2, 3, 4, 5, 6}));
  // Bottom row (10, 20) first.
  Image grey = read_image_linear(write("grey.pfm", "Pf\n2 2\n-1\n" + bytes({10, 20, 30, 40}, false)));
  EXPECT_EQ(grey.rgb, (std::vector<float>{30, 30, 30, 40, 40, 40, 10, 10, 10, 20, 20, 20}));
  Image big = read_pfm(write("big.pfm", "PF\n1 1\n2.0\n" + bytes({1.5f, -0.25f, 8}, true)));
  EXPECT_EQ(big.rgb, (std::vector<float>{3, -0.5f, 16}));
  auto expect_error = [&](const std::string& name, const std::string& text, const std::string& problem) {
    try {
      read_image_linear(write(name, text));
      ADD_FAILURE() << "no error for " << name;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(problem), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  };
  expect_error("p6.pfm", "P6\n1 1\n255\n" + bytes({1}, false), "not a PFM");
  expect_error("zero.pfm", "PF\n1 1\n0\n" + bytes({1, 2, 3}, false), "scale must be finite and non-zero");
  expect_error("short.pfm", "Pf\n2 2\n-1\n" + bytes({1, 2, 3}, false), "truncated PFM");
  expect_error("huge.pfm", "PF\n70000 1\n-1\n", "1 to 65536 a side");
  // A file whose extension names no image format: the message lists them all.
  expect_error("mesh.obj", "v 0 0 0\n", "supported: .exr, .hdr, .pfm, .png");
}

namespace {

// A 16×16 render of the plane z = 0 seen square-on: each pixel's mean
// against expected(px, py, channel) at the point (px, py) its centre ray
// meets the plane, within z · its standard error (Šidák over all pixels and
// channels, family level 1e-3); `other` (the image mirrored) counts the
// values that would fail.
struct PlaneCheck {
  int failures = 0, other_failures = 0;
  double worst = 0, threshold = 0;
};
template <class F, class G>
PlaneCheck check_plane_pixels(const Scene& s, F expected, G other) {
  CpuRenderOptions opt;
  opt.threads = 2;
  RenderStats stats;
  Film film = render_cpu(s, opt, stats);
  EXPECT_EQ(stats.discarded, 0u);
  std::vector<double> mean = luz_test::pixel_means(film), var = film.variance_of_mean();
  PlaneCheck r;
  r.threshold = luz_test::sidak_z(1e-3, 16.0 * 16 * 3);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      const Ray ray = s.camera.generate_ray(x + 0.5f, y + 0.5f);
      const double t = -ray.o.z / ray.d.z, px = ray.o.x + t * ray.d.x, py = ray.o.y + t * ray.d.y;
      for (int c = 0; c < 3; ++c) {
        const size_t k = 3 * (size_t(y) * 16 + size_t(x)) + size_t(c);
        const double sigma = std::sqrt(var[k]) + luz_test::rounding_floor(mean[k]);
        const double z = std::fabs(mean[k] - expected(px, py, c)) / sigma;
        r.worst = std::max(r.worst, z);
        r.failures += z > r.threshold;
        r.other_failures += std::fabs(mean[k] - other(px, py, c)) / sigma > r.threshold;
      }
    }
  return r;
}

}  // namespace

using TextureUv = TempDirTest;

// A quad of two triangles whose vt are the affine map uv = (0.2 + 0.5 x,
// 0.1 + 0.25 y) of the positions, listed in another order than the vertices
// (so the loader must pair them per face corner). At any barycentrics, uv
// must be (0.2 + 0.5 p.x, 1 - (0.1 + 0.25 p.y)) with p the hit point.
TEST_F(TextureUv, ObjCoordinatesInterpolateWithTheHitsBarycentrics) {
  write("quad.obj",
        "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\n"
        "vt 1.2 0.6\nvt 0.2 0.1\nvt 0.2 0.6\nvt 1.2 0.1\n"
        "f 1/2 2/4 3/1\nf 1/2 3/1 4/3\n");
  Image tex;  // any image: only a textured shape keeps its texture coordinates
  tex.width = tex.height = 1;
  tex.rgb = {0.5f, 0.5f, 0.5f};
  write_image((dir / "tex.png").string(), tex);
  const std::string shape = "<shape type=\"obj\"><string name=\"filename\" value=\"quad.obj\"/>";
  const std::string textured = "<bsdf type=\"diffuse\"><texture name=\"reflectance\" type=\"bitmap\">"
                               "<string name=\"filename\" value=\"tex.png\"/></texture></bsdf>";
  auto load = [&](const std::string& body) {
    return load_mitsuba(write("scene.xml", "<scene version=\"3.0.0\"><sensor type=\"perspective\"/>" + body + "</scene>"),
                        {});
  };
  // Untextured, the mesh is not split at uv seams and carries no uvs.
  Scene plain = load(shape + "</shape>");
  EXPECT_TRUE(plain.uvs.empty());
  EXPECT_EQ(plain.positions.size(), 4u);
  Scene s = load(shape + textured + "</shape>");
  ASSERT_EQ(s.num_triangles(), 2u);
  ASSERT_EQ(s.uvs.size(), s.positions.size());
  SceneView v = s.view();
  Ray ray;  // interaction() reads the ray for spheres only
  for (uint32_t tri = 0; tri < 2; ++tri)
    for (float a : {0.f, 0.1f, 0.37f, 0.8f})
      for (float b : {0.f, 0.05f, 0.2f}) {
        if (a + b > 1.f) continue;
        Hit hit;
        hit.prim = tri;
        hit.u = a;
        hit.v = b;
        Vec3 p = v.interaction(ray, hit).p;
        Vec2 uv = v.hit_uv(hit, p);
        EXPECT_NEAR(uv.x, 0.2f + 0.5f * p.x, 1e-6f) << tri << " " << a << " " << b;
        EXPECT_NEAR(uv.y, 1.f - (0.1f + 0.25f * p.y), 1e-6f) << tri << " " << a << " " << b;
      }
}

// A textured mesh without texture coordinates takes each face's
// barycentrics as uv, as Mitsuba 3 does (uv = (b1, b2) of the face's second
// and third vertices): every face gets its own three vertices at uv (0, 0),
// (1, 0), (0, 1), in the file's order, with the smooth normals the shared
// vertices had (a bent pair of faces: the shared ones' normals agree). A
// normal map there is an error (Mitsuba takes the tangents from the normal).
TEST_F(TextureUv, MeshWithoutCoordinatesTakesTheBarycentrics) {
  write("bent.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 1\nf 1 2 3\nf 1 3 4\n");
  const std::string checker =
      "<bsdf type=\"diffuse\"><texture name=\"reflectance\" type=\"checkerboard\"/></bsdf>";
  Scene s = load_mitsuba(write("scene.xml", "<scene version=\"3.0.0\"><sensor type=\"perspective\"/>"
                                            "<shape type=\"obj\"><string name=\"filename\" value=\"bent.obj\"/>" +
                                                checker + "</shape></scene>"),
                         {});
  ASSERT_EQ(s.indices.size(), 6u);
  ASSERT_EQ(s.positions.size(), 6u);
  ASSERT_EQ(s.uvs.size(), 6u);
  ASSERT_EQ(s.normals.size(), 6u);
  const Vec3 file[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 1}};
  const int faces[2][3] = {{0, 1, 2}, {0, 2, 3}};
  const Vec2 corner_uv[3] = {{0, 0}, {1, 0}, {0, 1}};
  for (int f = 0; f < 2; ++f)
    for (int c = 0; c < 3; ++c) {
      const uint32_t v = s.indices[size_t(3 * f + c)];
      EXPECT_EQ(length(s.positions[v] - file[faces[f][c]]), 0.f) << f << " " << c;
      EXPECT_EQ(s.uvs[v].x, corner_uv[c].x) << f << " " << c;
      EXPECT_EQ(s.uvs[v].y, corner_uv[c].y) << f << " " << c;
    }
  // The shared vertices 1 and 3 of the file: one smooth normal each, off both faces' own.
  for (int shared : {0, 2}) {
    const Vec3 a = s.normals[s.indices[size_t(shared)]], b = s.normals[s.indices[size_t(3 + (shared == 0 ? 0 : 1))]];
    EXPECT_LT(length(a - b), 1e-6f) << shared;
    EXPECT_LT(std::fabs(a.z), 0.999f) << shared;
  }
  try {
    load_mitsuba(write("maps.xml", "<scene version=\"3.0.0\"><sensor type=\"perspective\"/>\n"
                                   "<shape type=\"obj\"><string name=\"filename\" value=\"bent.obj\"/>"
                                   "<bsdf type=\"normalmap\"><texture name=\"normalmap\" type=\"checkerboard\"/>" +
                                       checker + "</bsdf></shape></scene>"),
                 {});
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 2) << e.what();
    EXPECT_NE(std::string(e.what()).find("a normal or bump map on a mesh without texture coordinates"), std::string::npos)
        << e.what();
  }
}

// Mitsuba 3's checkerboard whose colour is a texture: the checkerboard's
// to_uv (here ×2) chooses the square, the nested bitmap is looked up at the
// surface's own uv. color0 where exactly one of frac(u'), frac(v') exceeds
// 1/2 (u' = 2u), the constant 0.25; color1 elsewhere: a 2×1 float bitmap,
// nearest, dark left half and bright right half.
TEST_F(TextureUv, CheckerboardColoursMayBeTextures) {
  Image tex;
  tex.width = 2;
  tex.height = 1;
  tex.rgb = {0.1f, 0.2f, 0.3f, 0.8f, 0.7f, 0.6f};
  write_image((dir / "tex.pfm").string(), tex);
  Scene s = load_mitsuba(
      write("scene.xml",
            "<scene version=\"3.0.0\"><sensor type=\"perspective\"/><shape type=\"rectangle\"><bsdf type=\"diffuse\">"
            "<texture type=\"checkerboard\" name=\"reflectance\"><float name=\"color0\" value=\"0.25\"/>"
            "<texture type=\"bitmap\" name=\"color1\"><string name=\"filename\" value=\"tex.pfm\"/>"
            "<string name=\"filter_type\" value=\"nearest\"/></texture>"
            "<transform name=\"to_uv\"><scale x=\"2\" y=\"2\"/></transform></texture></bsdf></shape></scene>"),
      {});
  ASSERT_EQ(s.texture_bindings.size(), 1u);
  const uint32_t t = uint32_t(s.texture_bindings[0].texture);
  const TextureView v = s.view().textures;
  struct Probe {
    Vec2 uv;
    Color want;
  } probes[] = {
      {{0.3f, 0.1f}, {0.25f, 0.25f, 0.25f}},  // u' 0.6, v' 0.2: one above 1/2
      {{0.1f, 0.1f}, {0.1f, 0.2f, 0.3f}},     // neither: the bitmap's left texel
      {{0.8f, 0.3f}, {0.8f, 0.7f, 0.6f}},     // u' 1.6, v' 0.6: both: its right texel
      {{0.8f, 0.1f}, {0.25f, 0.25f, 0.25f}},  // u' 1.6, v' 0.2
  };
  for (const Probe& p : probes) {
    const Color c = v.eval(t, p.uv);
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(c[k], p.want[k]) << p.uv.x << "," << p.uv.y << " channel " << k;
  }
}

// Meshes with and without texture coordinates in one scene: a cube (none), a
// textured rectangle, an untextured OBJ, then a textured OBJ. uvs must stay one
// per position, each textured mesh's vertices carrying its own coordinates, and
// every model a texture may colour (diffuse, plastic, roughplastic) must see the
// texture's value at the hit through SceneView::material().
TEST_F(TextureUv, MixedMeshesKeepTheirUvsAndEveryTexturableModelSeesTheTexture) {
  write("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0.25 0.5\nvt 0.75 0.5\nvt 0.75 1\nvt 0.25 1\n"
                    "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n");
  Image tex;  // 2×1: left texel dark, right texel bright (linear values, written as sRGB PNG)
  tex.width = 2;
  tex.height = 1;
  tex.rgb = {0.1f, 0.2f, 0.3f, 0.8f, 0.7f, 0.6f};
  write_image((dir / "tex.png").string(), tex);
  auto textured = [](const std::string& type, const std::string& name) {
    return "<bsdf type=\"" + type + "\"><texture name=\"" + name +
           "\" type=\"bitmap\"><string name=\"filename\" value=\"tex.png\"/>"
           "<string name=\"filter_type\" value=\"nearest\"/></texture></bsdf>";
  };
  const std::string obj = "<shape type=\"obj\"><string name=\"filename\" value=\"quad.obj\"/>";
  Scene s = load_mitsuba(
      write("scene.xml", "<scene version=\"3.0.0\"><sensor type=\"perspective\"/>"
                         "<shape type=\"cube\"/>"
                         "<shape type=\"rectangle\">" + textured("diffuse", "reflectance") + "</shape>" +
                         obj + "</shape>" +
                         obj + textured("plastic", "diffuse_reflectance") + "</shape>" +
                         obj + textured("roughplastic", "diffuse_reflectance") + "</shape>"
                         "</scene>"),
      {});
  ASSERT_EQ(s.uvs.size(), s.positions.size());
  const uint32_t cube = 24, rect = 4, quad = 4;  // vertices per mesh (the cube: 4 per face)
  ASSERT_EQ(s.positions.size(), size_t(cube + rect + 3 * quad));
  for (uint32_t k = 0; k < cube; ++k) EXPECT_EQ(s.uvs[k].x, 0.f);
  const float rect_uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};  // Mitsuba's rectangle
  for (uint32_t k = 0; k < rect; ++k) {
    EXPECT_EQ(s.uvs[cube + k].x, rect_uv[k][0]);
    EXPECT_EQ(s.uvs[cube + k].y, rect_uv[k][1]);
  }
  for (uint32_t k = 0; k < quad; ++k) EXPECT_EQ(s.uvs[cube + rect + k].x, 0.f);  // untextured OBJ: padding
  const float quad_u[4] = {0.25f, 0.75f, 0.75f, 0.25f};
  for (int m = 0; m < 2; ++m)
    for (uint32_t k = 0; k < quad; ++k) {
      const size_t at = cube + rect + quad * uint32_t(1 + m) + k;
      EXPECT_EQ(s.uvs[at].x, quad_u[k]) << m << " " << k;
      EXPECT_EQ(s.uvs[at].y, 1.f - (k < 2 ? 0.5f : 1.f)) << m << " " << k;  // v flipped
    }
  // A hit near each textured mesh's first vertex and one near its second:
  // u = 0.25 or 0 reads the left texel, u = 0.75 or 1 - ε the right one.
  SceneView v = s.view();
  Image8 bytes = read_image8((dir / "tex.png").string());
  auto texel = [&](int i, int c) { return float(srgb_decode(((bytes.rgba[size_t(i)] >> (8 * c)) & 255) / 255.0)); };
  auto reflectance = [](const Bsdf& b) {
    switch (b.type) {
      case BsdfType::Diffuse: return b.diffuse.reflectance;
      case BsdfType::SmoothPlastic: return b.smooth_plastic.diffuse_reflectance;
      case BsdfType::RoughPlastic: return b.rough_plastic.diffuse_reflectance;
      default: return Color{-1.f, -1.f, -1.f};
    }
  };
  const uint32_t cube_tris = 12, rect_tris = 2, quad_tris = 2;
  const uint32_t first_tri[3] = {cube_tris, cube_tris + rect_tris + quad_tris, cube_tris + rect_tris + 2 * quad_tris};
  const BsdfType types[3] = {BsdfType::Diffuse, BsdfType::SmoothPlastic, BsdfType::RoughPlastic};
  Ray ray;
  for (int m = 0; m < 3; ++m)
    for (int corner = 0; corner < 2; ++corner) {
      Hit hit;
      hit.prim = first_tri[m];
      hit.u = corner == 0 ? 0.01f : 0.98f;  // near vertex 0, or near vertex 1
      hit.v = 0.f;
      Interaction it = v.interaction(ray, hit);
      Bsdf local;
      const Bsdf& b = v.bsdf(it, hit, local);
      ASSERT_EQ(b.type, types[m]);
      EXPECT_EQ(&b, &local) << "a textured material's BSDF is evaluated at the hit";
      const Color r = reflectance(b);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(r[c], texel(corner, c), 1e-6f) << m << " " << corner << " " << c;
    }
}

// A 4×4 texture on Mitsuba's rectangle, seen square-on so that the rectangle
// fills a 16×16 image exactly (a plane parallel to the image maps affinely):
// each texel covers 4×4 pixels, and with nearest filtering every pixel's
// footprint sees one texel. Under a uniform environment of radiance 1 a
// Lambertian plane reflects L = ρ, so each pixel's mean must be that texel's
// linear value, within z · its standard error (Šidák over all pixels and
// channels, family level 1e-3).
TEST_F(TextureUv, TexturedQuadShowsItsTexelsUnderUniformLight) {
  Image tex;
  tex.width = tex.height = 4;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i)
      for (float c : {0.05f + 0.25f * i, 0.1f + 0.2f * j, 0.9f - 0.05f * float(4 * j + i)}) tex.rgb.push_back(c);
  write_image((dir / "tex.png").string(), tex);
  Image8 bytes = read_image8((dir / "tex.png").string());  // what the PNG holds, 8-bit sRGB
  auto texel = [&](int i, int j, int c) { return srgb_decode(((bytes.rgba[size_t(j) * 4 + i] >> (8 * c)) & 255) / 255.0); };

  const double fov = 2.0 * std::atan(0.2) * 180.0 / M_PI;  // the camera at z = 5 sees x, y in [-1, 1]
  char fov_text[64];
  std::snprintf(fov_text, sizeof fov_text, "%.17g", fov);
  Scene s = load_mitsuba(
      write("scene.xml",
            std::string("<scene version=\"3.0.0\"><integrator type=\"path\"/>"
                        "<sensor type=\"perspective\"><float name=\"fov\" value=\"") +
                fov_text +
                "\"/><transform name=\"to_world\"><lookat origin=\"0,0,5\" target=\"0,0,0\" up=\"0,1,0\"/></transform>"
                "<sampler type=\"independent\"><integer name=\"sample_count\" value=\"128\"/></sampler>"
                "<film type=\"hdrfilm\"><integer name=\"width\" value=\"16\"/><integer name=\"height\" value=\"16\"/>"
                "<rfilter type=\"box\"/></film></sensor>"
                "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/></emitter>"
                "<shape type=\"rectangle\"><bsdf type=\"diffuse\"><texture name=\"reflectance\" type=\"bitmap\">"
                "<string name=\"filename\" value=\"tex.png\"/><string name=\"filter_type\" value=\"nearest\"/>"
                "</texture></bsdf></shape></scene>"),
      {});
  // The texel at (px, py): Mitsuba's rectangle has uv = ((x + 1) / 2, (y + 1) / 2).
  auto at = [&](double px, double py, int c, bool flipped) {
    const int i = std::clamp(int(std::floor((px + 1) / 2 * 4)), 0, 3), j = std::clamp(int(std::floor((py + 1) / 2 * 4)), 0, 3);
    return texel(i, flipped ? 3 - j : j, c);
  };
  const PlaneCheck r = check_plane_pixels(
      s, [&](double px, double py, int c) { return at(px, py, c, false); },
      [&](double px, double py, int c) { return at(px, py, c, true); });
  std::printf("[textures] quad: worst pixel z %.2f (threshold %.2f); the flipped texture fails %d of 768\n", r.worst,
              r.threshold, r.other_failures);
  EXPECT_EQ(r.failures, 0);
  EXPECT_GT(r.other_failures, 384) << "the test cannot tell the texture from its mirror image";
}

// ---- vertex colours (Mitsuba's mesh_attribute vertex_color) ----

// A vertex-colour texture (times its scale) alone and in a product with a
// checkerboard, against their definitions; which textures read uv and which
// read vertex colours.
TEST(TextureLookup, VertexColoursAloneAndInAProduct) {
  std::vector<Texture> list(3);
  list[0] = Texture(VertexColorTexture{});
  list[0].scale = {0.5f, 1.f, 2.f};
  CheckerboardTexture c;
  c.color0 = {0.2f, 0.4f, 0.6f};
  c.color1 = {1.f, 0.5f, 0.25f};
  list[1] = Texture(c);
  MixTexture m;
  m.op = MixOp::Product;
  m.a = 0, m.b = 1;
  list[2] = Texture(m);
  TextureView v;
  v.list = list.data();
  v.count = 3;
  const Color vc{0.3f, 0.6f, 0.9f};
  const Color direct = v.eval(0, {0.7f, 0.1f}, vc);
  EXPECT_FLOAT_EQ(direct.x, 0.15f);
  EXPECT_FLOAT_EQ(direct.y, 0.6f);
  EXPECT_FLOAT_EQ(direct.z, 1.8f);
  // (0.7, 0.1): frac(u) > 1/2 alone, color0; (0.2, 0.1): color1.
  const Color p0 = v.eval(2, {0.7f, 0.1f}, vc), p1 = v.eval(2, {0.2f, 0.1f}, vc);
  EXPECT_FLOAT_EQ(p0.x, 0.15f * 0.2f);
  EXPECT_FLOAT_EQ(p0.z, 1.8f * 0.6f);
  EXPECT_FLOAT_EQ(p1.y, 0.6f * 0.5f);
  // Without a vertex colour (lights' lookups) it reads white.
  EXPECT_FLOAT_EQ(v.eval(0, {0.f, 0.f}).z, 2.f);
  EXPECT_FALSE(texture_reads_uv(list.data(), 0));
  EXPECT_TRUE(texture_reads_vertex_color(list.data(), 0));
  EXPECT_TRUE(texture_reads_uv(list.data(), 1));
  EXPECT_FALSE(texture_reads_vertex_color(list.data(), 1));
  EXPECT_TRUE(texture_reads_uv(list.data(), 2));
  EXPECT_TRUE(texture_reads_vertex_color(list.data(), 2));
}

using VertexColors = TempDirTest;

namespace {

// A Mitsuba scene of one PLY shape (`ply`: its file name) whose diffuse
// reflectance is its vertex colours times `scale`, seen square-on from z = 5
// (x, y in [-1, 1] fill the 16×16 image) under a uniform environment of
// radiance 1; `extra`: more shapes.
std::string vertex_color_scene(const std::string& ply, const std::string& scale = "1", const std::string& extra = "") {
  const double fov = 2.0 * std::atan(0.2) * 180.0 / M_PI;
  char fov_text[64];
  std::snprintf(fov_text, sizeof fov_text, "%.17g", fov);
  return std::string("<scene version=\"3.0.0\"><integrator type=\"path\"/>"
                     "<sensor type=\"perspective\"><float name=\"fov\" value=\"") +
         fov_text +
         "\"/><transform name=\"to_world\"><lookat origin=\"0,0,5\" target=\"0,0,0\" up=\"0,1,0\"/></transform>"
         "<sampler type=\"independent\"><integer name=\"sample_count\" value=\"64\"/></sampler>"
         "<film type=\"hdrfilm\"><integer name=\"width\" value=\"16\"/><integer name=\"height\" value=\"16\"/>"
         "<rfilter type=\"box\"/></film></sensor>"
         "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"1\"/></emitter>"
         "<shape type=\"ply\"><string name=\"filename\" value=\"" + ply + "\"/>"
         "<bsdf type=\"diffuse\"><texture name=\"reflectance\" type=\"mesh_attribute\">"
         "<string name=\"name\" value=\"vertex_color\"/><float name=\"scale\" value=\"" + scale + "\"/>"
         "</texture></bsdf></shape>" + extra + "</scene>";
}

// The quad [-1, 1]² of z = 0 as a PLY of two triangles with `colors` (the
// property lines and each vertex's colour values, in corner order).
std::string quad_ply(const std::string& props, const std::vector<std::string>& colors) {
  std::string s = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n" + props +
                  "element face 2\nproperty list uchar int vertex_indices\nend_header\n";
  const char* corners[4] = {"-1 -1 0", "1 -1 0", "1 1 0", "-1 1 0"};
  for (int k = 0; k < 4; ++k) s += std::string(corners[k]) + " " + colors[size_t(k)] + "\n";
  return s + "3 0 1 2\n3 0 2 3\n";
}

}  // namespace

// Vertex colours interpolated with the hit's barycentrics: colours that are
// an affine function c(x, y) of the position at the corners are c(x, y)
// everywhere on both triangles. A Lambertian quad of that reflectance, seen
// square-on under a uniform environment of radiance 1, reflects L = c(x, y)
// (times the texture's scale): each pixel's mean must be c at the point its
// centre ray meets (a pixel's footprint averages an affine function to its
// centre's value), within z · its standard error (Šidák over all pixels and
// channels, family level 1e-3). The colours mirrored in y must fail.
TEST_F(VertexColors, QuadShowsItsInterpolatedColoursUnderUniformLight) {
  auto c = [](double x, double y) {
    return std::array<double, 3>{0.1 + 0.3 * (x + 1), 0.2 + 0.25 * (y + 1), 0.9 - 0.2 * (x + 1) - 0.15 * (y + 1)};
  };
  std::vector<std::string> colors;
  for (auto [x, y] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
    const auto v = c(x, y);
    colors.push_back(std::to_string(v[0]) + " " + std::to_string(v[1]) + " " + std::to_string(v[2]));
  }
  write("quad.ply", quad_ply("property float red\nproperty float green\nproperty float blue\n", colors));
  Scene s = load_mitsuba(write("scene.xml", vertex_color_scene("quad.ply", "0.8")), {});
  ASSERT_EQ(s.colors.size(), s.positions.size());
  EXPECT_TRUE(s.uvs.empty()) << "vertex colours need no texture coordinates";
  const PlaneCheck r = check_plane_pixels(
      s, [&](double px, double py, int k) { return 0.8 * c(px, py)[size_t(k)]; },
      [&](double px, double py, int k) { return 0.8 * c(px, -py)[size_t(k)]; });
  std::printf("[textures] vertex colours: worst pixel z %.2f (threshold %.2f); mirrored colours fail %d of 768\n",
              r.worst, r.threshold, r.other_failures);
  EXPECT_EQ(r.failures, 0);
  EXPECT_GT(r.other_failures, 384) << "the test cannot tell the colours from their mirror image";
}

// Integer colour channels are normalised by their type's maximum and
// sRGB-decoded, as Mitsuba 3's PLY reader does; r, g, b name them as well as
// red, green, blue. A shape whose material does not read them drops them.
TEST_F(VertexColors, IntegerChannelsAreSrgbDecoded) {
  write("bytes.ply", quad_ply("property uchar r\nproperty uchar g\nproperty uchar b\n",
                              {"0 10 128", "255 64 200", "30 90 1", "7 250 99"}));
  Scene s = load_mitsuba(write("scene.xml", vertex_color_scene("bytes.ply")), {});
  ASSERT_EQ(s.colors.size(), 4u);
  const int bytes[4][3] = {{0, 10, 128}, {255, 64, 200}, {30, 90, 1}, {7, 250, 99}};
  for (int v = 0; v < 4; ++v)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(s.colors[size_t(v)][k], srgb_decode(bytes[v][k] / 255.0), 1e-6) << v << " " << k;
  write("ushort.ply", quad_ply("property ushort red\nproperty ushort green\nproperty ushort blue\n",
                               {"65535 0 0", "0 65535 0", "0 0 65535", "32768 32768 32768"}));
  Scene u = load_mitsuba(write("u.xml", vertex_color_scene("ushort.ply")), {});
  ASSERT_EQ(u.colors.size(), 4u);
  EXPECT_NEAR(u.colors[3].x, srgb_decode(32768.0 / 65535.0), 1e-6);
  Scene plain = load_mitsuba(write("plain.xml", "<scene version=\"3.0.0\"><sensor type=\"perspective\"/>"
                                                "<shape type=\"ply\"><string name=\"filename\" value=\"bytes.ply\"/></shape></scene>"),
                             {});
  EXPECT_TRUE(plain.colors.empty());
}

// The colour the test's PLY files give the corner at p of the quad [-1, 1]²
// (kCornerColors in quad_ply's corner order), looked up by position: what
// every vertex must carry however the loader splits or copies it.
Color corner_color(Vec3 p) {
  if (p.x < 0.f) return p.y < 0.f ? Color{1, 0, 0} : Color{0.5f, 0.5f, 0.5f};
  return p.y < 0.f ? Color{0, 1, 0} : Color{0, 0, 1};
}
const std::vector<std::string> kCornerColors = {"1 0 0", "0 1 0", "0 0 1", "0.5 0.5 0.5"};

// Shapes with and without vertex colours in one scene keep them aligned
// (white where a mesh has none), and each hit interpolates its own: the
// corners' colours by their positions, weighted by the hit's barycentrics.
TEST_F(VertexColors, MixedMeshesKeepTheirColours) {
  write("c.ply", quad_ply("property float r\nproperty float g\nproperty float b\n", kCornerColors));
  const std::string other = "<shape type=\"rectangle\"><transform name=\"to_world\"><translate z=\"-1\"/></transform></shape>";
  Scene s = load_mitsuba(write("scene.xml", vertex_color_scene("c.ply", "1", other)), {});
  ASSERT_EQ(s.colors.size(), s.positions.size());
  SceneView v = s.view();
  ASSERT_NE(v.colors, nullptr);
  int colored = 0;
  for (uint32_t tri = 0; tri < s.num_triangles(); ++tri) {
    Hit hit;
    hit.prim = tri;
    hit.u = 0.25f, hit.v = 0.5f;
    const uint32_t* i = s.indices.data() + 3 * tri;
    const bool from_ply = s.positions[i[0]].z == 0.f;
    const Color want = from_ply ? corner_color(s.positions[i[0]]) * 0.25f + corner_color(s.positions[i[1]]) * 0.25f +
                                      corner_color(s.positions[i[2]]) * 0.5f
                                : Color{1.f, 1.f, 1.f};  // a mesh without colours reads white
    const Color got = v.hit_color(hit);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(got[k], want[k], 1e-6f) << tri;
    if (from_ply) {  // the material's reflectance is the colour there
      ++colored;
      const Bsdf b = v.materials.bsdf(s.tri_material[tri], v.textures, {}, got);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(b.diffuse.reflectance[k], want[k], 1e-6f);
    }
  }
  EXPECT_EQ(colored, 2);
}

// Where the loader copies vertices (Mitsuba's max_smooth_angle splitting a
// crease; a textured mesh without uvs, whose faces each get three vertices
// at their barycentrics), every copy keeps its colour; flattened instances
// too.
TEST_F(VertexColors, ColoursFollowTheirVerticesThroughEveryCopy) {
  // The quad folded along its diagonal (corner (1, 1) raised): a crease
  // sharper than 30 degrees.
  std::string ply = quad_ply("property float r\nproperty float g\nproperty float b\n", kCornerColors);
  ply.replace(ply.find("1 1 0 "), 6, "1 1 1 ");
  write("bent.ply", ply);
  const std::string mixed = "<bsdf type=\"diffuse\"><texture name=\"reflectance\" type=\"checkerboard\">"
                            "<texture name=\"color0\" type=\"mesh_attribute\"><string name=\"name\" value=\"vertex_color\"/>"
                            "</texture></texture></bsdf>";
  const std::string plain = "<bsdf type=\"diffuse\"><texture name=\"reflectance\" type=\"mesh_attribute\">"
                            "<string name=\"name\" value=\"vertex_color\"/></texture></bsdf>";
  // (max_smooth_angle splits without the uv fallback; the checkerboard reads uv: the fallback.)
  for (const std::string& shape : {"<float name=\"max_smooth_angle\" value=\"30\"/>" + plain, mixed}) {
    Scene s = load_mitsuba(write("s.xml", "<scene version=\"3.0.0\"><sensor type=\"perspective\"/>"
                                          "<shape type=\"shapegroup\" id=\"g\"><shape type=\"ply\">"
                                          "<string name=\"filename\" value=\"bent.ply\"/>" + shape +
                                          "</shape></shape><shape type=\"instance\"><ref id=\"g\"/></shape>"
                                          "<shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\">"
                                          "<translate x=\"10\"/></transform></shape></scene>"),
                           {});
    s.flatten_instances();
    ASSERT_EQ(s.colors.size(), s.positions.size());
    EXPECT_GT(s.positions.size(), 8u) << "copies made (two placements of four corners): " << shape;
    for (size_t k = 0; k < s.positions.size(); ++k) {
      Vec3 p = s.positions[k];
      if (p.x > 5.f) p.x -= 10.f;
      const Color want = corner_color(p);
      for (int c = 0; c < 3; ++c) EXPECT_EQ(s.colors[k][c], want[c]) << k << " " << shape;
    }
  }
}

// A PLY file's colour properties are read only where all three channels
// are scalars, and float colours are checked only where a material reads
// them: otherwise the file loads as before. Rendered on its own, a PLY
// whose colours leave [0, 1] is grey, with a warning.
TEST_F(VertexColors, UnusedOrPartialColoursDoNotStopALoad) {
  auto load_plain = [&](const std::string& ply) {
    return load_mitsuba(write("plain.xml", "<scene version=\"3.0.0\"><sensor type=\"perspective\"/><shape type=\"ply\">"
                                           "<string name=\"filename\" value=\"" + ply + "\"/></shape></scene>"),
                        {});
  };
  write("partial.ply", quad_ply("property uchar red\nproperty uchar green\n", {"1 2", "3 4", "5 6", "7 8"}));
  EXPECT_EQ(load_plain("partial.ply").num_triangles(), 2u);
  write("nan.ply", quad_ply("property float r\nproperty float g\nproperty float b\n", {"nan 0 0", "0 1 0", "0 0 2", "1 1 1"}));
  EXPECT_EQ(load_plain("nan.ply").num_triangles(), 2u);
  EXPECT_TRUE(load_plain("nan.ply").colors.empty());
  luz_test::expect_load_refused(write("nan.xml", vertex_color_scene("nan.ply")), "nan.xml",
                                "the colour of vertex 0 is not within [0, 1]");
  Scene alone = load_scene((dir / "nan.ply").string());
  EXPECT_TRUE(alone.colors.empty());
  EXPECT_TRUE(luz_test::has_warning(alone, "the colour of vertex 0 is not within [0, 1]: the colours are not used"));
}

// Mitsuba's face_color: a PLY file's face colours (face properties r, g, b),
// constant over each face: every triangle gets vertices of its own carrying
// its face's colour, so a hit anywhere on it reads that colour exactly. A
// material reading both kinds, or a file without face colours, is an error.
TEST_F(VertexColors, FaceColoursAreConstantOverTheirFaces) {
  write("faces.ply",
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 2\nproperty list uchar int vertex_indices\nproperty uchar red\nproperty uchar green\n"
        "property uchar blue\nend_header\n-1 -1 0\n1 -1 0\n1 1 0\n-1 1 0\n3 0 1 2 255 0 0\n3 0 2 3 0 64 255\n");
  const std::string face = "<texture name=\"reflectance\" type=\"mesh_attribute\"><string name=\"name\" value=\"face_color\"/></texture>";
  auto scene = [&](const std::string& name, const std::string& ply, const std::string& bsdf) {
    return write(name, "<scene version=\"3.0.0\"><sensor type=\"perspective\"/><shape type=\"ply\"><string name=\"filename\" "
                       "value=\"" + ply + "\"/>" + bsdf + "</shape></scene>");
  };
  Scene s = load_mitsuba(scene("f.xml", "faces.ply", "<bsdf type=\"diffuse\">" + face + "</bsdf>"), {});
  ASSERT_EQ(s.num_triangles(), 2u);
  ASSERT_EQ(s.positions.size(), 6u);
  const SceneView v = s.view();
  for (uint32_t tri = 0; tri < 2; ++tri)
    for (float a : {0.f, 0.3f, 0.9f}) {
      Hit hit;
      hit.prim = tri;
      hit.u = a, hit.v = 0.1f;
      // The triangle's face: the one with corner (1, -1) is the first (red).
      bool first = false;
      for (int j = 0; j < 3; ++j) first |= s.positions[s.indices[3 * tri + j]].y < 0.f && s.positions[s.indices[3 * tri + j]].x > 0.f;
      const Color got = v.hit_color(hit);
      EXPECT_EQ(got.x, first ? 1.f : 0.f);
      EXPECT_NEAR(got.y, first ? 0.0 : srgb_decode(64 / 255.0), 1e-6);
      EXPECT_EQ(got.z, first ? 0.f : 1.f);
    }
  write("plain.ply", quad_ply("", {"", "", "", ""}));
  luz_test::expect_load_refused(scene("none.xml", "plain.ply", "<bsdf type=\"diffuse\">" + face + "</bsdf>"), "none.xml",
                                "the material reads face colours (mesh_attribute), and 'plain.ply' has none");
  luz_test::expect_load_refused(
      scene("both.xml", "faces.ply",
            "<bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"0.5\"/><bsdf type=\"diffuse\">" + face +
                "</bsdf><bsdf type=\"diffuse\"><texture name=\"reflectance\" type=\"mesh_attribute\">"
                "<string name=\"name\" value=\"vertex_color\"/></texture></bsdf></bsdf>"),
      "both.xml", "a material reading both vertex_color and face_color is not supported");
}

// An OBJ's `v x y z r g b` feed Mitsuba's vertex_color too (Mitsuba 3's obj
// plugin reads none): sRGB-decoded, per file vertex however the faces
// de-index; a colour outside [0, 1] is then an error at its line.
TEST_F(VertexColors, ObjColoursThroughMitsuba) {
  const std::string attr = "<bsdf type=\"diffuse\"><texture name=\"reflectance\" type=\"mesh_attribute\">"
                           "<string name=\"name\" value=\"vertex_color\"/></texture></bsdf>";
  auto scene = [&](const std::string& name, const std::string& obj) {
    return write(name, "<scene version=\"3.0.0\"><sensor type=\"perspective\"/><shape type=\"obj\"><string name=\"filename\" "
                       "value=\"" + obj + "\"/>" + attr + "</shape></scene>");
  };
  // Faces listing the vertices out of order, with normals splitting vertex 3.
  write("c.obj", "v 1 1 0 0 0 1\nv -1 -1 0 1 0 0\nv 1 -1 0 0 1 0\nv -1 1 0 0.5 0.5 0.5\nvn 0 0 1\nvn 0 0.6 0.8\n"
                 "f 2//1 3//1 1//1\nf 2//2 1//2 4//2\n");
  Scene s = load_mitsuba(scene("c.xml", "c.obj"), {});
  ASSERT_EQ(s.colors.size(), s.positions.size());
  EXPECT_GT(s.positions.size(), 4u);
  for (size_t k = 0; k < s.positions.size(); ++k) {
    const Color linear = corner_color(s.positions[k]);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(s.colors[k][c], srgb_decode(linear[c]), 1e-6) << k;
  }
  write("bad.obj", "v 0 0 0 0 0 0\nv 1 0 0 2 0 0\nv 0 1 0 0 0 0\nf 1 2 3\n");
  luz_test::expect_load_refused(scene("bad.xml", "bad.obj"), "bad.obj:2", "vertex colour '2' is not within [0, 1]");
}

TEST_F(VertexColors, BadUsesAreErrors) {
  write("c.ply", quad_ply("property float r\nproperty float g\nproperty float b\n", {"1 0 0", "0 1 0", "0 0 1", "1 1 1"}));
  write("plain.ply", quad_ply("", {"", "", "", ""}));
  write("bright.ply", quad_ply("property float r\nproperty float g\nproperty float b\n",
                               {"1 0 0", "0 1.5 0", "0 0 1", "1 1 1"}));
  const std::string attr = "<texture name=\"reflectance\" type=\"mesh_attribute\"><string name=\"name\" value=\"vertex_color\"/></texture>";
  auto scene = [&](const std::string& name, const std::string& shape) {
    return write(name, "<scene version=\"3.0.0\"><sensor type=\"perspective\"/>" + shape + "</scene>");
  };
  luz_test::expect_load_refused(scene("rect.xml", "<shape type=\"rectangle\"><bsdf type=\"diffuse\">" + attr + "</bsdf></shape>"),
                                "rect.xml", "a material reading vertex colours on a mesh without them");
  luz_test::expect_load_refused(
      scene("none.xml", "<shape type=\"ply\"><string name=\"filename\" value=\"plain.ply\"/><bsdf type=\"diffuse\">" + attr +
                            "</bsdf></shape>"),
      "none.xml", "the material reads vertex colours (mesh_attribute), and 'plain.ply' has none");
  luz_test::expect_load_refused(
      scene("bright.xml", "<shape type=\"ply\"><string name=\"filename\" value=\"bright.ply\"/><bsdf type=\"diffuse\">" +
                              attr + "</bsdf></shape>"),
      "bright.xml", "the colour of vertex 1 is not within [0, 1]");
  luz_test::expect_load_refused(
      scene("face.xml", "<shape type=\"ply\"><string name=\"filename\" value=\"c.ply\"/><bsdf type=\"diffuse\">"
                        "<texture name=\"reflectance\" type=\"mesh_attribute\"><string name=\"name\" value=\"uv\"/>"
                        "</texture></bsdf></shape>"),
      "face.xml", "mesh attribute 'uv' is not supported (supported: vertex_color, face_color)");
  luz_test::expect_load_refused(
      scene("emit.xml", "<shape type=\"ply\"><string name=\"filename\" value=\"c.ply\"/><emitter type=\"area\">"
                        "<texture name=\"radiance\" type=\"mesh_attribute\"><string name=\"name\" value=\"vertex_color\"/>"
                        "</texture></emitter></shape>"),
      "emit.xml", "an emitter's radiance from vertex colours is not supported");
  luz_test::expect_load_refused(
      scene("sphere.xml", "<shape type=\"sphere\"><bsdf type=\"diffuse\">" + attr + "</bsdf></shape>"), "sphere.xml",
      "a material reading vertex colours on a sphere without them");
  luz_test::expect_load_refused(
      scene("scale.xml", "<shape type=\"ply\"><string name=\"filename\" value=\"c.ply\"/><bsdf type=\"diffuse\">"
                         "<texture name=\"reflectance\" type=\"mesh_attribute\"><string name=\"name\" value=\"vertex_color\"/>"
                         "<float name=\"scale\" value=\"2\"/></texture></bsdf></shape>"),
      "scale.xml", "'reflectance' texture reads vertex colours times a scale above 1 (a reflectance lies in [0, 1])");
  luz_test::expect_load_refused(
      scene("spot.xml", "<emitter type=\"spot\"><texture name=\"texture\" type=\"mesh_attribute\">"
                        "<string name=\"name\" value=\"vertex_color\"/></texture></emitter>"
                        "<shape type=\"ply\"><string name=\"filename\" value=\"c.ply\"/></shape>"),
      "spot.xml", "a spot light's texture must be an image or checkerboard");
}


// ---- Mitsuba 0.5 names ----

using MitsubaLegacy = TempDirTest;

namespace {

// One scene in either spelling: `legacy` picks version 0.5.0 with camelCase
// names and ldrfilm, else 3.0.0 with Mitsuba 3's names and hdrfilm.
std::string naming_scene(bool legacy) {
  auto n = [&](const char* old_name, const char* new_name) { return std::string(legacy ? old_name : new_name); };
  return "<scene version=\"" + n("0.5.0", "3.0.0") +
         "\">\n"
         "<integrator type=\"path\"><integer name=\"" + n("maxDepth", "max_depth") +
         "\" value=\"7\"/><integer name=\"" + n("rrDepth", "rr_depth") +
         "\" value=\"3\"/>" + n("<boolean name=\"strictNormals\" value=\"true\"/>", "") +
         "</integrator>\n"
         "<sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/><string name=\"" + n("fovAxis", "fov_axis") +
         "\" value=\"y\"/><float name=\"" + n("nearClip", "near_clip") + "\" value=\"0.5\"/>"
         "<transform name=\"" + n("toWorld", "to_world") + "\"><" + n("lookAt", "lookat") +
         " origin=\"1,2,3\" target=\"0,0,0\" up=\"0,1,0\"/></transform>"
         "<sampler type=\"independent\"><integer name=\"" + n("sampleCount", "sample_count") +
         "\" value=\"9\"/></sampler>"
         "<film type=\"" + n("ldrfilm", "hdrfilm") +
         "\"><integer name=\"width\" value=\"40\"/><integer name=\"height\" value=\"30\"/>" +
         n("<string name=\"fileFormat\" value=\"png\"/><string name=\"pixelFormat\" value=\"rgb\"/>"
           "<float name=\"gamma\" value=\"2.2\"/><boolean name=\"banner\" value=\"false\"/>",
           "") +
         "<rfilter type=\"tent\"/></film></sensor>\n"
         "<bsdf type=\"roughplastic\" id=\"p\"><float name=\"" + n("intIOR", "int_ior") +
         "\" value=\"1.6\"/><float name=\"" + n("extIOR", "ext_ior") +
         "\" value=\"1.1\"/><rgb name=\"" + n("diffuseReflectance", "diffuse_reflectance") +
         "\" value=\"0.3 0.4 0.5\"/><rgb name=\"" + n("specularReflectance", "specular_reflectance") +
         "\" value=\"0.7\"/><string name=\"distribution\" value=\"ggx\"/><float name=\"alpha\" value=\"0.2\"/></bsdf>\n"
         // Mitsuba 0.5's extEta divides eta and k (Mitsuba 3 has no such parameter).
         "<bsdf type=\"conductor\" id=\"c\">" +
         n("<float name=\"extEta\" value=\"1.25\"/><rgb name=\"eta\" value=\"0.25 0.375 1.75\"/>"
           "<rgb name=\"k\" value=\"4.875 3 2\"/>",
           "<rgb name=\"eta\" value=\"0.2 0.3 1.4\"/><rgb name=\"k\" value=\"3.9 2.4 1.6\"/>") +
         "</bsdf>\n"
         "<shape type=\"rectangle\"><transform name=\"" + n("toWorld", "to_world") +
         "\"><translate x=\"1\"/></transform><boolean name=\"" + n("flipNormals", "flip_normals") +
         "\" value=\"true\"/><ref id=\"p\"/></shape>\n"
         "<shape type=\"cube\"><ref id=\"c\"/></shape>\n"
         "</scene>\n";
}

}  // namespace

TEST_F(MitsubaLegacy, CamelCaseNamesLoadAsTheirMitsuba3Spelling) {
  Scene a = load_mitsuba(write("legacy.xml", naming_scene(true)), {});
  Scene b = load_mitsuba(write("modern.xml", naming_scene(false)), {});
  EXPECT_EQ(a.settings.integrator.max_depth, 7);
  EXPECT_EQ(a.settings.integrator.rr_depth, 3);
  EXPECT_EQ(a.settings.spp, 9u);
  EXPECT_EQ(a.settings.filter, FilterKind::Tent);
  EXPECT_EQ(a.camera.width, 40);
  EXPECT_EQ(a.camera.height, 30);
  // fov_axis y: tan(20°) vertically.
  EXPECT_NEAR(a.camera.tan_half_y, std::tan(20.0 * M_PI / 180), 1e-6);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(a.camera.origin[k], b.camera.origin[k]);
    EXPECT_EQ(a.camera.z_axis[k], b.camera.z_axis[k]);
  }
  EXPECT_NEAR(a.camera.origin.y, 2.f, 1e-6f);
  EXPECT_EQ(a.camera.tan_half_x, b.camera.tan_half_x);
  EXPECT_EQ(a.settings.integrator.max_depth, b.settings.integrator.max_depth);
  EXPECT_EQ(a.settings.spp, b.settings.spp);
  ASSERT_EQ(a.num_triangles(), b.num_triangles());
  for (size_t k = 0; k < a.positions.size(); ++k)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(a.positions[k][c], b.positions[k][c]);
  // The materials the shapes use, parameter by parameter.
  const Bsdf& pa = a.materials[a.tri_material[0]].bsdf;
  const Bsdf& pb = b.materials[b.tri_material[0]].bsdf;
  ASSERT_EQ(pa.type, BsdfType::RoughPlastic);
  ASSERT_EQ(pb.type, BsdfType::RoughPlastic);
  EXPECT_NEAR(pa.rough_plastic.eta, 1.6f / 1.1f, 1e-6f);
  EXPECT_EQ(pa.rough_plastic.eta, pb.rough_plastic.eta);
  EXPECT_NEAR(pa.rough_plastic.diffuse_reflectance.z, 0.5f, 1e-7f);
  EXPECT_EQ(pa.rough_plastic.diffuse_reflectance.y, pb.rough_plastic.diffuse_reflectance.y);
  EXPECT_EQ(pa.rough_plastic.specular_reflectance.x, pb.rough_plastic.specular_reflectance.x);
  EXPECT_EQ(pa.rough_plastic.alpha, pb.rough_plastic.alpha);
  const Bsdf& ca = a.materials[a.tri_material.back()].bsdf;
  const Bsdf& cb = b.materials[b.tri_material.back()].bsdf;
  ASSERT_EQ(ca.type, BsdfType::SmoothConductor);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(ca.smooth_conductor.eta[k], cb.smooth_conductor.eta[k], 1e-6f);
    EXPECT_NEAR(ca.smooth_conductor.k[k], cb.smooth_conductor.k[k], 1e-6f);
  }
  EXPECT_NEAR(ca.smooth_conductor.eta.z, 1.4f, 1e-6f);
}

// Mitsuba 0.5's <srgb> colours decode to linear RGB (hex and numbers; refused
// in a Mitsuba 3 scene), and an OBJ's flipTexCoords="false" keeps vt.v as written.
TEST_F(MitsubaLegacy, SrgbColoursAndFlipTexCoords) {
  write("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0.5 0.25\nvt 0.75 0.25\nvt 0.75 0.5\nf 1/1 2/2 3/3\n");
  Image tex;
  tex.width = tex.height = 1;
  tex.rgb = {0.5f, 0.5f, 0.5f};
  write_image((dir / "tex.png").string(), tex);
  auto scene = [](const std::string& version, const std::string& colour, const std::string& flip) {
    return "<scene version=\"" + version + "\">\n<sensor type=\"perspective\"/>\n"
           "<shape type=\"obj\"><string name=\"filename\" value=\"quad.obj\"/>" + flip +
           "<bsdf type=\"diffuse\"><texture name=\"reflectance\" type=\"bitmap\">"
           "<string name=\"filename\" value=\"tex.png\"/></texture></bsdf></shape>\n"
           "<shape type=\"rectangle\"><bsdf type=\"diffuse\">" + colour + "</bsdf></shape>\n</scene>\n";
  };
  Scene hex = load_mitsuba(write("a.xml", scene("0.5.0", "<srgb name=\"reflectance\" value=\"#ff8000\"/>",
                                                "<boolean name=\"flipTexCoords\" value=\"false\"/>")),
                           {});
  const Color r = hex.materials[hex.tri_material.back()].bsdf.diffuse.reflectance;
  EXPECT_NEAR(r.x, 1.f, 1e-6f);
  EXPECT_NEAR(r.y, srgb_decode(128 / 255.0), 1e-6);
  EXPECT_EQ(r.z, 0.f);
  EXPECT_NEAR(hex.uvs[0].y, 0.25f, 1e-6f);  // not flipped
  EXPECT_NEAR(hex.uvs[2].y, 0.5f, 1e-6f);
  Scene num = load_mitsuba(write("b.xml", scene("0.5.0", "<srgb name=\"reflectance\" value=\"0.5, 0.2, 0.9\"/>", "")),
                           {});
  const Color q = num.materials[num.tri_material.back()].bsdf.diffuse.reflectance;
  EXPECT_NEAR(q.x, srgb_decode(0.5), 1e-6);
  EXPECT_NEAR(q.y, srgb_decode(0.2), 1e-6);
  EXPECT_NEAR(q.z, srgb_decode(0.9), 1e-6);
  EXPECT_NEAR(num.uvs[0].y, 0.75f, 1e-6f);  // flipped by default
  try {
    load_mitsuba(write("c.xml", scene("3.0.0", "<srgb name=\"reflectance\" value=\"#ffffff\"/>", "")), {});
    ADD_FAILURE() << "<srgb> accepted in a Mitsuba 3 scene";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 4) << e.what();
  }
  try {
    load_mitsuba(write("d.xml", scene("0.5.0", "<srgb name=\"reflectance\" value=\"#12345\"/>", "")), {});
    ADD_FAILURE() << "a 5-digit hex colour accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 4) << e.what();
  }
}

TEST_F(MitsubaLegacy, BadNamesAreErrorsWithTheirLine) {
  auto expect_error = [&](const std::string& text, int line, const std::string& problem) {
    std::string path = write("bad.xml", text);
    try {
      load_mitsuba(path, {});
      ADD_FAILURE() << "no error for:\n" << text;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
      EXPECT_EQ(e.line(), line) << e.what();
      EXPECT_NE(e.problem().find(problem), std::string::npos) << e.what();
    }
  };
  // A misspelt camelCase name, reported as written.
  std::string legacy = naming_scene(true);
  std::string bad = legacy;
  bad.replace(bad.find("rrDepth"), 7, "rrDepht");
  expect_error(bad, 2, "unknown parameter 'rrDepht'");
  // camelCase in a Mitsuba 3 scene is not renamed.
  std::string modern = naming_scene(false);
  modern.replace(modern.find("max_depth"), 9, "maxDepth");
  expect_error(modern, 2, "unknown parameter 'maxDepth'");
  // ldrfilm's options that change the image are not accepted.
  bad = legacy;
  bad.replace(bad.find("<float name=\"gamma\""), 0, "<float name=\"exposure\" value=\"1\"/>");
  expect_error(bad, 3, "unknown parameter 'exposure'");
  // Bitmaps: a missing file, an unknown filter, a texture where only colours go.
  const std::string head =
      "<scene version=\"0.5.0\">\n<sensor type=\"perspective\"/>\n<shape type=\"rectangle\">\n<bsdf type=\"diffuse\">\n";
  expect_error(head + "<texture name=\"reflectance\" type=\"bitmap\"><string name=\"filename\" value=\"none.jpg\"/>"
                      "</texture>\n</bsdf></shape></scene>\n",
               5, "no such file");
  write("t.png", "");
  expect_error(head + "<texture name=\"reflectance\" type=\"bitmap\"><string name=\"filename\" value=\"t.png\"/>"
                      "<string name=\"filterType\" value=\"anisotropic\"/></texture>\n</bsdf></shape></scene>\n",
               5, "unknown filter_type 'anisotropic'");
  // A file that exists but is no image.
  expect_error(head + "<texture name=\"reflectance\" type=\"bitmap\"><string name=\"filename\" value=\"t.png\"/>"
                      "</texture>\n</bsdf></shape></scene>\n",
               5, "cannot read image");
  expect_error("<scene version=\"0.5.0\">\n<sensor type=\"perspective\"/>\n<shape type=\"rectangle\">\n"
               "<bsdf type=\"roughplastic\">\n<texture name=\"alpha\" type=\"bitmap\">"
               "<string name=\"filename\" value=\"t.png\"/></texture>\n</bsdf></shape></scene>\n",
               5, "'alpha' cannot take a texture");
}

// ---- the Wooden Staircase ----

namespace {

const std::string kStaircase = LUZ_SHARED_DIR "/scenes/staircase/mitsuba/scene.xml";
const std::string kStaircaseReference = LUZ_SHARED_DIR "/scenes/staircase/reference/TungstenRender.exr";

}  // namespace

class Staircase : public ::testing::Test {
 protected:
  // Loaded once for the suite, by the first test that asks (a test that
  // skips itself first loads nothing).
  static inline Scene* loaded = nullptr;
  static inline double load_seconds = 0;

  static const Scene& scene() {
    if (!loaded) {
      auto t0 = std::chrono::steady_clock::now();
      loaded = new Scene(load_scene(kStaircase, {}));
      load_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    return *loaded;
  }
  static void TearDownTestSuite() {
    delete loaded;
    loaded = nullptr;
  }
  void SetUp() override {
    if (!fs::exists(kStaircase)) GTEST_SKIP() << kStaircase << " not found";
  }
  // The scene's own view at width × height (the same field of view: 720×1280
  // scaled by an integer keeps its aspect ratio).
  static Film render(int width, int height, uint32_t spp, RenderStats& stats) {
    Scene s = scene();
    s.camera.width = width;
    s.camera.height = height;
    s.settings.spp = spp;
    s.settings.sampler = SamplerType::Independent;
    s.settings.seed = 7;
    s.settings.filter = FilterKind::Box;
    CpuRenderOptions opt;
    opt.threads = 2;
    return render_cpu(s, opt, stats);
  }
};

TEST_F(Staircase, LoadsAllMeshesAndTextures) {
  const Scene& s = scene();
  std::printf("[staircase] loaded in %.2f s: %u triangles, %zu textures (%zu texels), %zu materials\n", load_seconds,
              s.num_triangles(), s.textures.size(), s.texels8.size(), s.materials.size());
  EXPECT_EQ(s.num_triangles(), 262663u);
  EXPECT_EQ(s.textures.size(), 10u);  // ten bitmaps, the bumpmap's height among them
  EXPECT_EQ(s.uvs.size(), s.positions.size());
  EXPECT_EQ(s.settings.integrator.max_depth, 65);
  EXPECT_EQ(s.settings.spp, 64u);
  EXPECT_EQ(s.camera.width, 720);
  EXPECT_EQ(s.camera.height, 1280);
  size_t textured = 0;
  for (const Material& m : s.materials) textured += m.num_bindings > 0;
  EXPECT_GE(textured, 9u);
}

TEST_F(Staircase, TinyRenderIsFinite) {
  RenderStats stats;
  Film film = render(36, 64, 4, stats);
  EXPECT_EQ(stats.discarded, 0u);
  double sum = 0;
  for (float v : film.mean()) {
    ASSERT_TRUE(std::isfinite(v));
    sum += v;
  }
  EXPECT_GT(sum, 0.0);
  std::printf("[staircase] 36x64, 4 spp: %.3f s on 2 threads\n", stats.seconds);
}

// Luz at 36×64 (box filter, 256 spp, 1.4 s on 2 threads) against
// Tungsten's 720×1280 reference, per channel over the whole image:
//   |luz - ref| ≤ z · σ_luz + kTolerance · ref
// σ_luz from Luz's per-pixel sample variance, z Šidák over the 3 channels
// (family level 1e-3). The stated tolerance covers what is known to differ:
// the reference is Tungsten's own version of the scene (its rough plastic is
// not Mitsuba's model, which Luz implements), it filters textures
// trilinearly, and it applies the aluminium's bump map (Luz ignores it).
// A Luz image 10% too bright must fail the same test.
//
// Blocks of 4×4 Luz pixels are printed, not asserted: under the stairs the
// light arrives by rare paths (caustics through the chandelier's glass), the
// per-sample distribution is heavy-tailed, and at 256 spp the sample variance
// understates the error (measured: block (4,9) 28% dark at "9σ" with 256
// spp, within 5% of the reference with 4096 spp, where block (3,9) is then
// 13% bright). A per-block bound would need far more samples than a unit
// test can spend.
TEST_F(Staircase, AgreesWithTungstenAtLowResolution) {
  LUZ_SKIP_UNDER_SANITIZERS("a check of numbers; TinyRenderIsFinite renders the scene sanitized");
  constexpr double kTolerance = 0.05;
  constexpr int kW = 36, kH = 64, kBlock = 4;
  Image ref = read_exr(kStaircaseReference);
  ASSERT_EQ(ref.width, 720);
  ASSERT_EQ(ref.height, 1280);
  RenderStats stats;
  Film film = render(kW, kH, 256, stats);
  EXPECT_EQ(stats.discarded, 0u);
  luz_test::Blocks L = luz_test::make_blocks(film, kBlock);
  const int bpx = kBlock * (ref.width / kW);
  const luz_test::ReferenceBlocks R = luz_test::reference_blocks(ref, L.bw, L.bh, bpx);
  const double block_thr = luz_test::sidak_z(1e-3, 3.0 * L.bw * L.bh), thr = luz_test::sidak_z(1e-3, 3);
  int blocks_over = 0;
  double worst_rel = 0;
  for (int by = 0; by < L.bh; ++by)
    for (int bx = 0; bx < L.bw; ++bx)
      for (int c = 0; c < 3; ++c) {
        size_t b = 3 * (size_t(by) * L.bw + bx) + c;
        double luz = L.m(bx, by, c), r = R.mean[b], sigma = std::sqrt(L.v(bx, by, c));
        double excess = (std::fabs(luz - r) - block_thr * sigma) / r;  // beyond Luz's noise
        worst_rel = std::max(worst_rel, excess);
        if (excess > kTolerance) {
          ++blocks_over;
          std::printf("  block (%d,%d) ch %d: luz %.4f ref %.4f (%+.1f%%), sigma %.4f\n", bx, by, c, luz, r,
                      100 * (luz / r - 1), sigma);
        }
      }
  std::printf("[staircase] %dx%d, 256 spp, %.2f s; blocks: worst difference beyond z·sigma %.1f%% of the "
              "reference, %d of %d beyond %.0f%% (diagnostic)\n",
              kW, kH, stats.seconds, 100 * worst_rel, blocks_over, 3 * L.bw * L.bh, 100 * kTolerance);
  const double nb = double(L.bw) * L.bh;
  for (int c = 0; c < 3; ++c) {
    double lm = 0, lv = 0, rm = 0;
    for (size_t b = size_t(c); b < R.mean.size(); b += 3) {
      lm += L.mean[b] / nb;
      lv += L.var[b] / (nb * nb);
      rm += R.mean[b] / nb;
    }
    auto passes = [&](double luz) { return std::fabs(luz - rm) <= thr * std::sqrt(lv) + kTolerance * rm; };
    std::printf("[staircase] channel %d: image mean luz %.5f tungsten %.5f (%+.2f%%), sigma luz %.3f%%\n", c, lm, rm,
                100 * (lm / rm - 1), 100 * std::sqrt(lv) / rm);
    EXPECT_TRUE(passes(lm)) << "channel " << c;
    EXPECT_FALSE(passes(1.1 * lm)) << "test has no power, channel " << c;
  }
}
