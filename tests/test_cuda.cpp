// The CUDA backend (DESIGN.md, validation layer 3: "CPU and GPU agree within
// noise"), in three layers, so that most of it is tested without a GPU:
//
//  * CudaPassOnHost (always runs): the GPU's pass logic, render_pixel_pass
//    and accumulate_pass (device/cuda/pass.h), run on the host over Luz's BVH
//    exactly as render_cuda drives them (passes of K samples, float sums per
//    pass, double film). Checked against render_cpu: same random numbers, so
//    the one-sample images match pixel for pixel but for the rare ray the two
//    tracers round differently; independent seeds agree within noise; K does
//    not change the image beyond float rounding. Splatting's two kernels
//    (render_square_pass, gather_pixel_pass) give the CPU's splatted samples;
//    the constant environment's guide, built through Luz's BVH, agrees with
//    the CPU's within noise.
//  * CudaDevice (needs a GPU; otherwise SKIPPED with the reason): the same
//    checks on render_cuda's films, plus ray and sample counts.
//  * CudaNoDevice / CliDevice: without a GPU render_cuda throws a one-line
//    "Unavailable" CudaError, `luz render --device cuda` exits 2 with one line
//    and writes nothing, `--device auto` warns once and renders on the CPU,
//    `--device bogus` is refused.
//
// Tolerances.
//  * Agreement within noise: 8×8-pixel block means per channel, z-test with
//    var(A − B) = var(A) + var(B) from the films' own sums (independent
//    seeds), Šidák-corrected over all blocks and channels, family level 1e-3
//    (as test_integrator.cpp).
//  * First sample, same seed: a sample whose path takes the same branches on
//    both sides differs only by float rounding. One path is at most a few
//    hundred float operations (each ≤ ε/2 = 6e-8 relative; the GPU also fuses
//    multiply-adds and its sqrt/pow/exp differ from glibc's by an ulp or two),
//    so such samples agree to ~1e-5 relative: we allow 1e-3 (absolute below
//    1). A sample whose branch flips (a grazing hit, a Russian-roulette
//    decision within an ulp of its threshold) differs arbitrarily: at most 1%
//    of pixels may (on the host, where only the tracer differs, 0.2%).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "bsdf_cases.h"
#include "chi2.h"
#include "cli_helpers.h"
#include "geometry_helpers.h"
#include "luz/accel/bvh_build.h"
#include "luz/light/env_guide_build.h"
#include "luz/accel/embree_tracer.h"
#include "luz/device/cpu/render.h"
#include "luz/device/cuda/batch.h"
#include "luz/device/cuda/pass.h"
#include "luz/device/cuda/render_cuda.h"
#include "luz/device/cuda/wavefront.h"
#include "luz/io/image.h"
#include "luz/io/load.h"
#include "stat_helpers.h"

using namespace luz;
namespace fs = std::filesystem;

namespace {

constexpr double kFamilyAlpha = 1e-3;
constexpr int kBlock = 8;
const std::string kCornell = LUZ_SOURCE_DIR "/scenes/cornell-box.xml";

// Sponza's atrium under a constant sky (bench/scenes): the environment's
// guide (light/env_guide.h) is built and read.
Scene sponza_sky(int res, uint32_t spp, uint64_t seed) {
  Scene s = load_scene(LUZ_SOURCE_DIR "/bench/scenes/sponza-inside.xml", {{"res", std::to_string(res)}, {"max_depth", "6"}});
  s.settings.sampler = SamplerType::Independent;
  s.settings.spp = spp;
  s.settings.seed = seed;
  luz_test::independent_pixels(s);
  return s;
}

Scene cornell(int res, uint32_t spp, uint64_t seed) {
  Scene s = load_scene(kCornell, {{"res", std::to_string(res)}});
  // Independent samples: the per-pixel sample variance is then an unbiased
  // estimate of the variance of the mean (test_integrator.cpp).
  s.settings.sampler = SamplerType::Independent;
  s.settings.spp = spp;
  s.settings.seed = seed;
  // The block tests want independent pixels: filter sampling (splatting's
  // own tests set it back).
  luz_test::independent_pixels(s);
  return s;
}

// The Cornell box splatted (film/splat.h): its tent filter's samples shared
// between neighbouring pixels.
Scene cornell_splat(int res, uint32_t spp, uint64_t seed) {
  Scene s = cornell(res, spp, seed);
  s.settings.reconstruction = Reconstruction::Splat;
  EXPECT_TRUE(splats(s.settings.reconstruction, s.settings.filter));
  return s;
}

// The box with an analytic diffuse sphere in the middle and no vertex
// normals: every kind of uploaded array, the null ones included.
Scene cornell_with_sphere(int res, uint32_t spp, uint64_t seed) {
  Scene s = cornell(res, spp, seed);
  Vec3 c = (s.bounds_min + s.bounds_max) * 0.5f;
  uint32_t m = s.add_material(s.materials[0].bsdf);
  s.add_sphere(c, 0.15f * (s.bounds_max.x - s.bounds_min.x), m, nullptr, false);
  s.normals.clear();
  s.compile();
  EXPECT_EQ(s.spheres.size(), 1u);
  return s;
}

// Texture coordinates an affine function of the positions (wrapping around
// several times across the box).
void affine_uvs(Scene& s) {
  s.uvs.resize(s.positions.size());
  const Vec3 ext = s.bounds_max - s.bounds_min;
  for (size_t i = 0; i < s.positions.size(); ++i) {
    Vec3 p = (s.positions[i] - s.bounds_min) * (1.f / max_component(ext));
    s.uvs[i] = {2.3f * p.x + 0.4f * p.z, 1.7f * p.y - 0.6f * p.z};
  }
}

// The Cornell box with every Lambertian material textured, in turn by a 5×3
// sRGB bitmap (repeat), the same texels as a float bitmap (mirror), a 4×2
// linear bitmap (clamp, nearest) and a checkerboard times the vertex
// colours (an affine function of the position), each through its own to_uv
// (affine_uvs).
Scene textured_cornell(int res, uint32_t spp, uint64_t seed) {
  Scene s = cornell(res, spp, seed);
  std::vector<uint32_t> img;
  std::vector<float> imgf;
  for (uint32_t k = 0; k < 15; ++k) {
    img.push_back(pack_rgba8(40 + 13 * k, 200 - 9 * k, (37 * k) % 256));
    imgf.insert(imgf.end(), {(40 + 13 * k) / 255.f, (200 - 9 * k) / 255.f, float((37 * k) % 256) / 255.f});
  }
  std::vector<uint32_t> small;
  for (uint32_t k = 0; k < 8; ++k) small.push_back(pack_rgba8(30 * k, 255 - 30 * k, 128));
  BitmapTexture b;
  b.width = 5;
  b.height = 3;
  UvTransform rot{0.8f, -0.6f, 0.1f, 0.6f, 0.8f, -0.3f};
  std::vector<int32_t> tex;
  tex.push_back(int32_t(s.add_bitmap(b, {}, img)));
  b.wrap = WrapMode::Mirror;
  tex.push_back(int32_t(s.add_bitmap(b, rot, imgf)));
  b.width = 4, b.height = 2, b.wrap = WrapMode::Clamp, b.filter = TextureFilter::Nearest, b.srgb = false;
  tex.push_back(int32_t(s.add_bitmap(b, {1.5f, 0.f, -0.2f, 0.f, 1.2f, -0.1f}, small)));
  Texture checker{CheckerboardTexture{{0.7f, 0.2f, 0.1f}, {0.1f, 0.3f, 0.6f}}};
  checker.to_uv = {3.f, 0.f, 0.f, 0.f, 3.f, 0.f};
  MixTexture product;
  product.op = MixOp::Product;
  product.a = int32_t(s.add_texture(checker));
  product.b = int32_t(s.add_texture(Texture(VertexColorTexture{})));
  tex.push_back(int32_t(s.add_texture(Texture(product))));
  affine_uvs(s);
  const Vec3 ext = s.bounds_max - s.bounds_min;
  for (const Vec3& q : s.positions) {
    const Vec3 p = (q - s.bounds_min) * (1.f / max_component(ext));
    s.colors.push_back({0.2f + 0.7f * p.x, 0.9f - 0.5f * p.y, 0.3f + 0.4f * p.z});
  }
  size_t textured = 0;
  for (Material& m : s.materials)
    if (m.bsdf.type == BsdfType::Diffuse) {
      m.first_binding = uint32_t(s.texture_bindings.size());
      m.num_bindings = 1;
      s.texture_bindings.push_back({tex[textured++ % tex.size()], BsdfPart::Front, BsdfParam::Reflectance});
    }
  EXPECT_GE(textured, tex.size());
  return s;
}

// The box and sphere with every material that does not emit masked
// (material/opacity.h), in turn by a 0/1 checkerboard opacity over affine
// texture coordinates and constant opacities 0.5 and 0.8; the sphere 0.6.
Scene masked_cornell(int res, uint32_t spp, uint64_t seed) {
  Scene s = cornell_with_sphere(res, spp, seed);
  Texture checker{CheckerboardTexture{{0.f, 0.f, 0.f}, {1.f, 1.f, 1.f}}};
  checker.to_uv = {4.f, 0.f, 0.f, 0.f, 4.f, 0.f};
  const int32_t t = int32_t(s.add_texture(checker));
  affine_uvs(s);
  std::vector<bool> emits(s.materials.size(), false);
  for (uint32_t k = 0; k < s.num_triangles(); ++k)
    if (s.tri_emitter[k] >= 0) emits[s.tri_material[k]] = true;
  int masked = 0;
  for (size_t m = 0; m < s.materials.size(); ++m, ++masked) {
    if (emits[m]) continue;
    if (masked % 3 == 0) s.materials[m].opacity_texture = t;
    else s.materials[m].opacity = masked % 3 == 1 ? 0.5f : 0.8f;
  }
  Material& sphere = s.materials[s.spheres[0].material];
  sphere.opacity_texture = -1;  // the sphere keeps a constant opacity
  sphere.opacity = 0.6f;
  EXPECT_GE(masked, 3);
  EXPECT_TRUE(s.view().materials.masked);
  return s;
}

// The textured box with a normal map on every other textured material (a
// 4×4 float map of tilts in every direction, repeat) and a bump map (the
// 5×3 bitmap's luminance as the height, scale 0.05) on the rest.
Scene normal_mapped_cornell(int res, uint32_t spp, uint64_t seed) {
  Scene s = textured_cornell(res, spp, seed);
  std::vector<float> normals;
  for (int k = 0; k < 16; ++k) {
    const float a = 0.4f * float(k), tilt = 0.35f * float(k % 3);
    normals.insert(normals.end(), {0.5f + 0.5f * std::sin(tilt) * std::cos(a), 0.5f + 0.5f * std::sin(tilt) * std::sin(a),
                                   0.5f + 0.5f * std::cos(tilt)});
  }
  BitmapTexture b;
  b.width = b.height = 4;
  const int32_t nm = int32_t(s.add_bitmap(b, {}, normals));
  size_t k = 0, mapped = 0;
  for (Material& m : s.materials) {
    if (m.num_bindings == 0) continue;
    if (k++ % 2 == 0) m.normal_map = nm;
    else m.bump_map = 0, m.bump_scale = 0.05f;  // texture 0: the sRGB 5×3 bitmap
    ++mapped;
  }
  EXPECT_GE(mapped, 2u);
  return s;
}

// The box with a sphere mesh (normals, uvs) stored once and placed three
// times: scaled, stretched, mirrored. The two-level BVH and the instanced
// Interaction in the pass logic.
Scene instanced_cornell(int res, uint32_t spp, uint64_t seed) {
  Scene s = cornell(res, spp, seed);
  const Vec3 c = (s.bounds_min + s.bounds_max) * 0.5f;
  const float r = 0.12f * (s.bounds_max.x - s.bounds_min.x);
  const uint32_t obj = s.add_object();
  const TriangleMesh m = luz_test::uv_sphere(24, 12);
  s.add_mesh(m.positions, m.normals, m.indices, s.add_material(Bsdf::make_diffuse({0.6f, 0.6f, 0.3f})), nullptr,
             m.uvs);
  // to_world: diag(scale), then + t; to_object its inverse.
  const Vec3 scales[3] = {{r, r, r}, {r, 1.6f * r, 0.7f * r}, {-r, r, r}};
  const Vec3 offsets[3] = {{-2.2f * r, -r, -2.5f * r}, {0, 0.5f * r, -2.f * r}, {2.2f * r, -r, -2.5f * r}};  // before the blocks
  for (int k = 0; k < 3; ++k) {
    Affine3 to_world, to_object;
    for (int a = 0; a < 3; ++a) {
      const float t = c[a] + offsets[k][a];
      to_world.m[a][a] = scales[k][a];
      to_world.m[a][3] = t;
      to_object.m[a][a] = 1.f / scales[k][a];
      to_object.m[a][3] = -t / scales[k][a];
    }
    s.add_instance(obj, to_world, to_object);
  }
  s.compile();
  return s;
}

Film cpu(const Scene& s, RenderStats* stats_out = nullptr) {
  CpuRenderOptions opt;
  RenderStats stats;
  Film f = render_cpu(s, opt, stats);
  if (stats_out) *stats_out = stats;
  return f;
}

// A pass's parameters over host pointers, as render_cuda fills them.
PassParams host_pass_params(const Scene& scene, const SceneView& view, const Bvh& bvh) {
  const RenderSettings& rs = scene.settings;
  PassParams p;
  p.scene = view;
  p.scene.tri_normals = nullptr;  // as render_cuda: the GPU computes each hit's normal
  p.tracer = make_bvh_tracer(bvh, view);
  p.sampler = make_sampler_desc(rs.sampler, rs.spp, rs.seed);
  p.integrator = rs.integrator;
  p.filter = rs.filter;
  return p;
}

// render_cuda's pass loop, on the host: the same PassParams over host
// pointers, render_pixel_pass for every pixel, accumulate_pass per pass.
// full: the kFull variant whatever the scene (else the kernels' choice).
Film passes_on_host(const Scene& scene, uint32_t per_pass, RenderStats* stats_out = nullptr, uint32_t threads = 1,
                    bool full = false) {
  const SceneView view = scene.view();
  const Bvh bvh = build_bvh(view);
  const Camera& cam = view.camera;
  const size_t pixels = size_t(cam.width) * cam.height;
  PassParams p = host_pass_params(scene, view, bvh);
  // The environment's guide, as render_cuda builds it.
  EnvGuideData guide;
  if (wants_env_guide(view, scene.settings.env_guide)) {
    guide = build_env_guide(view, p.tracer, env_guide_options(uint64_t(pixels) * p.sampler.spp));
    if (guide.view.regions) p.scene.lights.data.guide = &guide.view;
  }
  p.threads_per_pixel = threads;
  // Splatting: T threads per square, then one per pixel for the gather.
  const bool splat = splats(scene.settings.reconstruction, scene.settings.filter);
  p.reach = splat ? filter_reach(scene.settings.filter) : 0;
  const int cw = cam.width + 2 * p.reach, ch = cam.height + 2 * p.reach;
  std::vector<Color> squares(splat ? size_t(cw) * ch * per_pass : 0);
  p.squares = squares.data();
  const uint32_t slices = splat ? 1 : threads;
  std::vector<float> sum(3 * pixels * slices), sum_sq(3 * pixels * slices);
  std::vector<uint32_t> count(pixels * slices);
  p.out = {sum.data(), sum_sq.data(), count.data()};
  Film film(cam.width, cam.height);
  std::atomic<uint64_t> rays{0};
  uint64_t discarded = 0;
  const bool plain = !full && pass_is_plain(p);  // the kernels' choice of variant (kernels.cu)
  for (uint32_t first = 0; first < p.sampler.spp; first += per_pass) {
    p.first_sample = first;
    p.num_samples = std::min(per_pass, p.sampler.spp - first);
    // Poison the outputs: the pass must overwrite every pixel.
    std::fill(sum.begin(), sum.end(), NAN);
    std::fill(count.begin(), count.end(), 0xdeadbeefu);
    if (splat) {
      std::fill(squares.begin(), squares.end(), Color{NAN, NAN, NAN});
      tbb::parallel_for(tbb::blocked_range<int>(0, ch), [&](const tbb::blocked_range<int>& r) {
        uint64_t n = 0;
        for (int y = r.begin(); y != r.end(); ++y)
          for (int x = 0; x < cw; ++x)
            for (uint32_t t = 0; t < threads; ++t)
              n += plain ? render_square_pass<false>(p, uint32_t(x), uint32_t(y), t)
                         : render_square_pass<true>(p, uint32_t(x), uint32_t(y), t);
        rays += n;
      });
      tbb::parallel_for(tbb::blocked_range<int>(0, cam.height), [&](const tbb::blocked_range<int>& r) {
        for (int y = r.begin(); y != r.end(); ++y)
          for (int x = 0; x < cam.width; ++x) gather_pixel_pass(p, uint32_t(x), uint32_t(y));
      });
    } else {
      tbb::parallel_for(tbb::blocked_range<int>(0, cam.height), [&](const tbb::blocked_range<int>& r) {
        uint64_t n = 0;
        for (int y = r.begin(); y != r.end(); ++y)
          for (int x = 0; x < cam.width; ++x)
            for (uint32_t t = 0; t < threads; ++t)
              n += plain ? render_pixel_pass<false>(p, uint32_t(x), uint32_t(y), t)
                         : render_pixel_pass<true>(p, uint32_t(x), uint32_t(y), t);
        rays += n;
      });
    }
    discarded += accumulate_pass(film, sum.data(), sum_sq.data(), count.data(), p.num_samples, 0, pixels, slices);
  }
  if (stats_out) {
    stats_out->samples = uint64_t(pixels) * p.sampler.spp;
    stats_out->rays = rays;
    stats_out->discarded = discarded;
  }
  return film;
}

// ---------------------------------------------------------------- checks

// Two independent images agree within their noise (block z-test, Šidák).
void expect_agree(const Film& a, const Film& b, const char* what, double family_alpha = kFamilyAlpha) {
  luz_test::Blocks A = luz_test::make_blocks(a, kBlock), B = luz_test::make_blocks(b, kBlock);
  double worst = 0, rel_sum = 0;
  int worst_bx = 0, worst_by = 0, worst_c = 0, n = 0;
  for (int by = 0; by < A.bh; ++by)
    for (int bx = 0; bx < A.bw; ++bx)
      for (int c = 0; c < 3; ++c) {
        double m = 0.5 * (A.m(bx, by, c) + B.m(bx, by, c));
        double floor = luz_test::rounding_floor(m);
        double sigma = std::sqrt(A.v(bx, by, c) + B.v(bx, by, c) + 2 * floor * floor);
        double z = std::fabs(A.m(bx, by, c) - B.m(bx, by, c)) / sigma;
        if (m > 0) rel_sum += sigma / m, ++n;
        if (z > worst) worst = z, worst_bx = bx, worst_by = by, worst_c = c;
      }
  const double thr = luz_test::sidak_z(family_alpha, 3.0 * A.bw * A.bh);
  std::printf("[%s] worst block z %.2f at (%d,%d) ch %d, threshold %.2f, mean block sigma %.2f%%\n", what, worst,
              worst_bx, worst_by, worst_c, thr, n ? 100 * rel_sum / n : 0.0);
  EXPECT_LE(worst, thr) << what;
}

// Same seed, one sample: pixel for pixel equal to float rounding, but for a
// fraction `max_diverged` of pixels whose path branched differently.
void expect_same_samples(const Film& a, const Film& b, double max_diverged, const char* what) {
  ASSERT_EQ(a.sum.size(), b.sum.size());
  size_t diverged = 0, pixels = a.count.size();
  double worst_rel = 0;
  for (size_t i = 0; i < pixels; ++i) {
    bool differ = a.count[i] != b.count[i];
    for (int k = 0; k < 3; ++k) {
      double x = a.sum[3 * i + k], y = b.sum[3 * i + k];
      double d = std::fabs(x - y) / std::max(1.0, std::fabs(x));
      if (d > 1e-3)
        differ = true;
      else
        worst_rel = std::max(worst_rel, d);
    }
    diverged += differ;
  }
  std::printf("[%s] %zu of %zu one-sample pixels differ (paths that branched apart); the rest within %.2g\n", what,
              diverged, pixels, worst_rel);
  EXPECT_LE(double(diverged), max_diverged * double(pixels)) << what;
}

// ---------------------------------------------------------------- on the host

// ---------------------------------------------------------------- BSDF scenes and batches

// The material scene of bench/run, one BSDF model at a time (Mitsuba's
// defaults for each plugin): spheres on a plane under an area light and a
// constant sky, so smooth and rough glass, metals and coated models all meet
// Luz's BVH, transmission and delta lobes included.
const char* const kMaterialModels[] = {"diffuse",   "phong",          "blinnphong", "ward",
                                       "conductor", "roughconductor", "dielectric", "roughdielectric",
                                       "thindielectric", "plastic", "roughplastic", "principled"};
constexpr int kNumMaterialModels = int(sizeof kMaterialModels / sizeof kMaterialModels[0]);

Scene material_scene(const char* model, uint32_t spp, uint64_t seed) {
  Scene s = load_scene(LUZ_SOURCE_DIR "/bench/scenes/material-spheres.xml", {{"material", model}, {"res", "32"}});
  luz_test::independent_pixels(s);
  s.settings.sampler = SamplerType::Independent;
  s.settings.spp = spp;
  s.settings.seed = seed;
  return s;
}

// BSDFs whose sampling the GPU must reproduce: one per sampling routine
// (cosine lobe, Phong and Blinn-Phong lobes, Ward, VNDF Beckmann and GGX,
// anisotropic, refraction from both sides, the plastic coat, a blend, the
// principled lobes with GTR1, diffuse transmission).
struct BatchCase {
  const char* name;
  Bsdf b;
  bool both_sides;  // bin over the whole sphere (transmission)
};
// glTF's thin sheet with KHR_materials_diffuse_transmission.
Bsdf gltf_translucent() {
  Bsdf b = Bsdf::make_gltf_pbr_transmission({.7f, .8f, .4f}, .1f, .35f, .2f);
  b.gltf_pbr_transmission.diffuse_transmission = .6f;
  b.gltf_pbr_transmission.diffuse_transmission_color = {.9f, .7f, .3f};
  return b;
}
std::vector<BatchCase> batch_cases() {
  Color eta, k;
  find_conductor_preset("Cu", eta, k);
  const MicrofacetType B = MicrofacetType::Beckmann, G = MicrofacetType::GGX;
  return {
      {"diffuse", Bsdf::make_diffuse({.7f, .7f, .7f}), false},
      {"phong kd .3 ks .6 n 30", Bsdf::make_phong({.3f, .3f, .3f}, {.6f, .6f, .6f}, 30.f), false},
      {"blinnphong kd .2 ks .7 n 50", Bsdf::make_blinn_phong({.2f, .2f, .2f}, {.7f, .7f, .7f}, 50.f), false},
      {"ward balanced (.1,.3)", Bsdf::make_ward(WardVariant::Balanced, {.2f, .2f, .2f}, {.7f, .7f, .7f}, .1f, .3f),
       false},
      {"roughconductor beckmann .2", Bsdf::make_rough_conductor(B, .2f, .2f, eta, k), false},
      {"roughconductor ggx (.1,.4)", Bsdf::make_rough_conductor(G, .1f, .4f, eta, k), false},
      {"roughdielectric ggx .3 η1.5", Bsdf::make_rough_dielectric(G, .3f, .3f, 1.5f, 1.f), true},
      {"plastic ρ=.5", Bsdf::make_smooth_plastic({.5f, .5f, .5f}), false},
      {"blend diffuse / ggx conductor", Bsdf::make_blend(Bsdf::make_diffuse({.8f, .8f, .8f}),
                                                         Bsdf::make_rough_conductor(G, .25f, .25f, eta, k), .5f),
       false},
      {"roughplastic ggx .2", Bsdf::make_rough_plastic(G, .2f, {.5f, .5f, .5f}), false},
      {"ward-duer (.2,.1)", Bsdf::make_ward(WardVariant::WardDuer, {.3f, .3f, .3f}, {.6f, .6f, .6f}, .2f, .1f), false},
      {"gltf metallic .3 rough .4", Bsdf::make_gltf_pbr({.8f, .5f, .2f}, .3f, .4f), false},
      {"gltf transmission .7 rough .3", Bsdf::make_gltf_pbr_transmission({.9f, .9f, .6f}, 0.f, .3f, .7f), true},
      {"gltf diffuse transmission .6", gltf_translucent(), true},
      {"principledthin (documentation example)", luz_test::principledthin_doc_example(), true},
      {"diffusetransmission R .6 T .3", Bsdf::make_diffuse_transmission({.6f, .5f, .4f}, {.3f, .3f, .2f}), true},
      {"principled (documentation example)", luz_test::principled_doc_example(0.f), false},
      {"principled (documentation example, spec_trans .4)", luz_test::principled_doc_example(.4f), true},
      // A pair answers from below with its back BSDF: sampled from both sides.
      {"twosided beckmann .3 conductor / diffuse", Bsdf::make_two_sided(Bsdf::make_rough_conductor(B, .3f, .3f, eta, k),
                                                                        Bsdf::make_diffuse({.6f, .6f, .6f})),
       true},
  };
}
const float kBatchIncidenceDeg[] = {10.f, 60.f, 85.f};
constexpr int kBatchIncidences = int(sizeof kBatchIncidenceDeg / sizeof kBatchIncidenceDeg[0]);
constexpr uint32_t kBatchSamples = 200000;

Vec3 batch_wo(float deg, bool below) {
  float t = deg * kPi / 180.f;
  return {sinf(t) * cosf(0.4f), sinf(t) * sinf(0.4f), below ? -cosf(t) : cosf(t)};
}

// χ² of one case's directions against its pdf (whole sphere, as
// test_bsdf_models.cpp does for wide lobes).
chi2::Outcome batch_chi2(const BatchCase& c, Vec3 wo, const std::vector<Vec3>& wi, const std::vector<uint8_t>& ok) {
  chi2::SphereGrid g;
  g.n_theta = c.both_sides ? 40 : 20;
  g.n_phi = 40;
  auto sample = [&](uint64_t i, Vec3& w) {
    w = wi[i];
    return ok[i] != 0;
  };
  auto pdf = [&](chi2::D3 w) { return double(c.b.pdf(wo, chi2::to_vec3(w))); };
  return chi2::run_sphere(g, wi.size(), sample, pdf);
}

// Every (case, incidence) pair, from above and, for transmissive cases, from
// below: the number of χ² tests of one family.
int batch_tests() {
  int n = 0;
  for (const BatchCase& c : batch_cases()) n += kBatchIncidences * (c.both_sides ? 2 : 1);
  return n;
}

// The recorded rays of a few Cornell-box paths (camera, bounces, shadow rays).
struct RecordingTracer {
  EmbreeTracer inner;
  std::vector<Ray>* rays;
  std::vector<uint8_t>* shadow;
  bool intersect(const Ray& r, Hit& h) const {
    rays->push_back(r), shadow->push_back(0);
    return inner.intersect(r, h);
  }
  bool occluded(const Ray& r) const {
    rays->push_back(r), shadow->push_back(1);
    return inner.occluded(r);
  }
};
void record_rays(const Scene& s, std::vector<Ray>& rays, std::vector<uint8_t>& shadow, std::vector<uint8_t>& hit) {
  EmbreeScene embree(s);
  RecordingTracer rec{embree.tracer(), &rays, &shadow};
  const SceneView view = s.view();
  const SamplerDesc desc = make_sampler_desc(s.settings.sampler, s.settings.spp, s.settings.seed);
  for (int y = 0; y < view.camera.height; ++y)
    for (int x = 0; x < view.camera.width; ++x) {
      Sampler sampler;
      sampler.start(desc, uint32_t(x), uint32_t(y), 0);
      const Ray r = camera_sample(view.camera, uint32_t(x), uint32_t(y), sampler, s.settings.filter);
      uint64_t n = 0;
      path_li(view, rec, r, sampler, s.settings.integrator, n);
    }
  const EmbreeTracer t = embree.tracer();
  hit.resize(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) {
    Hit h;
    hit[i] = (shadow[i] ? t.occluded(rays[i]) : t.intersect(rays[i], h)) ? 1 : 0;
  }
}

// ---------------------------------------------------------------- batches on the host

// The GPU's χ² items on the host: bsdf_sample_item draws exactly the numbers
// of the χ² harness (so its samples are Bsdf::sample's, bit for bit), and its
// output passes the same χ² test the device's must.
TEST(CudaBatchOnHost, BsdfItemsAreSampleAndPassChi2) {
  const BatchCase c = batch_cases()[5];  // anisotropic GGX
  const Vec3 wo = batch_wo(60.f, false);
  std::vector<Vec3> wi(kBatchSamples);
  std::vector<uint8_t> ok(kBatchSamples);
  BsdfBatchParams p;
  p.bsdf = &c.b;
  p.wo = wo;
  p.seed = 77;
  p.n = kBatchSamples;
  p.wi = wi.data();
  p.ok = ok.data();
  for (uint32_t i = 0; i < p.n; ++i) bsdf_sample_item(p, i);
  for (uint32_t i = 0; i < 1000; ++i) {
    BsdfSample s = c.b.sample(wo, chi2::rand01(77, i, 0), chi2::rand2(77, i, 1));
    ASSERT_EQ(ok[i] != 0, s.valid && !s.delta) << i;
    if (ok[i]) ASSERT_TRUE(wi[i].x == s.wi.x && wi[i].y == s.wi.y && wi[i].z == s.wi.z) << i;
  }
  chi2::Outcome o = batch_chi2(c, wo, wi, ok);
  const double thr = chi2::sidak(chi2::kAlpha, 1);
  EXPECT_TRUE(o.result.passes(thr)) << o.describe(thr);
  // And the test can fail: the pdf of another roughness is rejected.
  BatchCase wrong = c;
  wrong.b = batch_cases()[4].b;
  EXPECT_FALSE(batch_chi2(wrong, wo, wi, ok).result.passes(thr)) << "a wrong pdf must be rejected";
}

// trace_ray_item over Luz's BVH answers recorded path-tracing rays as Embree
// does (test_bvh.cpp checks the traversal itself on 10^6 rays).
TEST(CudaBatchOnHost, TraceRayItemsMatchEmbree) {
  Scene s = cornell_with_sphere(32, 1, 5);
  std::vector<Ray> rays;
  std::vector<uint8_t> shadow, expected;
  record_rays(s, rays, shadow, expected);
  ASSERT_GT(rays.size(), 2000u);
  const SceneView view = s.view();
  const Bvh bvh = build_bvh(view);
  std::vector<uint8_t> hit(rays.size());
  RayBatchParams p;
  p.tracer = make_bvh_tracer(bvh, view);
  p.rays = rays.data();
  p.shadow = shadow.data();
  p.n = uint32_t(rays.size());
  p.hit = hit.data();
  for (uint32_t i = 0; i < p.n; ++i) trace_ray_item(p, i);
  size_t differ = 0;
  for (size_t i = 0; i < rays.size(); ++i) differ += hit[i] != expected[i];
  EXPECT_LE(differ, rays.size() / 1000) << "hit/miss answers differing from Embree's";
  // The plain traversal (no instances, no masks: this scene) answers exactly alike.
  ASSERT_TRUE(p.tracer.plain());
  std::vector<uint8_t> plain_hit(rays.size());
  p.hit = plain_hit.data();
  for (uint32_t i = 0; i < p.n; ++i) trace_ray_item<false>(p, i);
  EXPECT_EQ(plain_hit, hit);
}

// The pass logic over Luz's BVH renders every BSDF model's scene as the CPU
// renderer (Embree) does, within noise: independent seeds, block z-test with
// the family level shared by all models.
TEST(CudaPassOnHost, MaterialScenesAgreeWithCpu) {
  for (const char* m : kMaterialModels) {
    Scene a = material_scene(m, 128, 61), b = material_scene(m, 128, 62);
    std::string what = std::string("host passes vs CPU, material ") + m;
    expect_agree(passes_on_host(a, 16), cpu(b), what.c_str(), kFamilyAlpha / kNumMaterialModels);
  }
}

TEST(CudaPassOnHost, SamplesPerPassDefault) {
  EXPECT_EQ(default_samples_per_pass(512 * 512, 1024), 8u);
  EXPECT_EQ(default_samples_per_pass(64 * 64, 1024), kMaxSamplesPerPass);
  EXPECT_EQ(default_samples_per_pass(64 * 64, 5), 5u);
  EXPECT_EQ(default_samples_per_pass(3840 * 2160, 1024), 1u);
  EXPECT_EQ(default_samples_per_pass(0, 16), 1u);
  EXPECT_EQ(default_threads_per_pixel(256 * 256, 32), 8u);  // 2^19 threads
  EXPECT_EQ(default_threads_per_pixel(64 * 64, 64), 64u);   // capped by the pass's samples
  EXPECT_EQ(default_threads_per_pixel(3840 * 2160, 1), 1u);
  EXPECT_EQ(default_threads_per_pixel(1000 * 1000, 8), 1u);
  EXPECT_EQ(default_threads_per_pixel(0, 16), 1u);
}

TEST(CudaPassOnHost, FirstSampleMatchesCpu) {
  Scene s = cornell(64, 1, 11);
  RenderStats hs, cs;
  Film h = passes_on_host(s, 1, &hs), c = cpu(s, &cs);
  expect_same_samples(h, c, 2e-3, "host passes vs CPU, 1 spp, same seed");
  EXPECT_EQ(h.count, c.count);
  EXPECT_EQ(hs.discarded, 0u);
  EXPECT_NEAR(double(hs.rays), double(cs.rays), 2e-3 * double(cs.rays)) << "same paths, same rays";
}

TEST(CudaPassOnHost, AgreesWithCpuWithinNoise) {
  Scene a = cornell(64, 128, 21), b = cornell(64, 128, 22);
  expect_agree(passes_on_host(a, 16), cpu(b), "host passes vs CPU, 128 spp, independent seeds");
}

TEST(CudaPassOnHost, SamplesPerPassChangesOnlyRounding) {
  Scene s = cornell(32, 24, 3);
  Film one = passes_on_host(s, 1), five = passes_on_host(s, 5), all = passes_on_host(s, 24);
  for (const Film* f : {&five, &all}) {
    EXPECT_EQ(f->count, one.count);
    for (size_t i = 0; i < one.sum.size(); ++i) {
      // Float sums of ≤ 24 samples: relative error ≤ 24 ε of the sum of magnitudes.
      ASSERT_NEAR(f->sum[i], one.sum[i], 24 * 6e-8 * std::max(1.0, one.sum[i])) << i;
      ASSERT_NEAR(f->sum_sq[i], one.sum_sq[i], 48 * 6e-8 * std::max(1.0, one.sum_sq[i])) << i;
    }
  }
  // One sample per pass: the sums are the CPU's own accumulation of the same floats.
  Film again = passes_on_host(s, 1);
  EXPECT_TRUE(again.sum == one.sum) << "deterministic";
}

// Splitting each pixel's pass among T threads changes only how the float
// sums are grouped: the same samples (counts equal), sums within float
// rounding. 20 samples in passes of 7 (the last pass 6): uneven shares, and
// with T = 7 a thread with no sample in the last pass.
TEST(CudaPassOnHost, ThreadsPerPixelChangeOnlyRounding) {
  Scene s = cornell(24, 20, 8);
  Film one = passes_on_host(s, 7, nullptr, 1);
  for (uint32_t threads : {2u, 3u, 7u}) {
    Film f = passes_on_host(s, 7, nullptr, threads);
    EXPECT_EQ(f.count, one.count) << threads;
    for (size_t i = 0; i < one.sum.size(); ++i) {
      // Float sums of ≤ 7 samples per pass, 3 passes: ≤ 7 ε relative to the sum of magnitudes each.
      ASSERT_NEAR(f.sum[i], one.sum[i], 3 * 7 * 6e-8 * std::max(1.0, one.sum[i])) << threads << " " << i;
      ASSERT_NEAR(f.sum_sq[i], one.sum_sq[i], 3 * 14 * 6e-8 * std::max(1.0, one.sum_sq[i])) << threads << " " << i;
    }
  }
  // And the split really happened: some float sums differ in their last bits.
  Film three = passes_on_host(s, 7, nullptr, 3);
  EXPECT_NE(three.sum, one.sum) << "T = 3 grouped the sums exactly as T = 1: was the split ignored?";
}

// The wavefront pass's stages run on the host as render_cuda enqueues them:
// generate, then intersect / shade / shadow over every path until none is
// alive, then accumulate. Returns the film and, in *rays, the rays traced.
Film wavefront_on_host(const Scene& scene, uint32_t per_pass, uint64_t* rays_out = nullptr) {
  const SceneView view = scene.view();
  const Bvh bvh = build_bvh(view);
  const Camera& cam = view.camera;
  const size_t pixels = size_t(cam.width) * cam.height;
  WavefrontParams w;
  w.pass = host_pass_params(scene, view, bvh);
  std::vector<float> sum(3 * pixels), sum_sq(3 * pixels);
  std::vector<uint32_t> count(pixels);
  w.pass.out = {sum.data(), sum_sq.data(), count.data()};
  std::vector<PathState> state(pixels * per_pass);
  std::vector<Sampler> samplers(pixels * per_pass);
  std::vector<Hit> hits(pixels * per_pass);
  std::vector<uint8_t> found(pixels * per_pass);
  std::vector<ShadowQuery> shadow(pixels * per_pass);
  w.state = state.data();
  w.sampler = samplers.data();
  w.hit = hits.data();
  w.found = found.data();
  w.shadow = shadow.data();
  Film film(cam.width, cam.height);
  uint64_t rays = 0;
  const bool plain = pass_is_plain(w.pass);  // the kernels' choice of variant
  for (uint32_t first = 0; first < w.pass.sampler.spp; first += per_pass) {
    w.pass.first_sample = first;
    w.pass.num_samples = std::min(per_pass, w.pass.sampler.spp - first);
    w.num_paths = uint32_t(pixels * w.pass.num_samples);
    for (uint32_t i = 0; i < w.num_paths; ++i) wf_generate(w, i);
    for (;;) {
      uint32_t alive = 0;
      for (uint32_t i = 0; i < w.num_paths; ++i) rays += plain ? wf_intersect<false>(w, i) : wf_intersect<true>(w, i);
      for (uint32_t i = 0; i < w.num_paths; ++i) alive += (plain ? wf_shade<false>(w, i) : wf_shade<true>(w, i)) ? 1 : 0;
      for (uint32_t i = 0; i < w.num_paths; ++i) rays += plain ? wf_shadow<false>(w, i) : wf_shadow<true>(w, i);
      if (alive == 0) break;
    }
    for (uint32_t px = 0; px < pixels; ++px) wf_accumulate(w, px);
    accumulate_pass(film, sum.data(), sum_sq.data(), count.data(), w.pass.num_samples, 0, pixels);
  }
  if (rays_out) *rays_out = rays;
  return film;
}

// The wavefront's stages compute what the megakernel's pass computes: the
// same path_vertex, random numbers and summation order, so on the host the
// films agree exactly (one thread per pixel), with the same ray count. Glass
// and rough plastic too (transmission, delta lobes, roulette with η²).
TEST(CudaPassOnHost, WavefrontMatchesMegakernel) {
  std::vector<Scene> scenes;
  scenes.push_back(cornell(24, 10, 13));
  scenes.push_back(material_scene("roughdielectric", 6, 14));
  scenes.push_back(material_scene("roughplastic", 6, 15));
  for (const Scene& s : scenes) {
    RenderStats ms;
    uint64_t wrays = 0;
    Film mega = passes_on_host(s, 4, &ms, 1), wave = wavefront_on_host(s, 4, &wrays);
    EXPECT_EQ(wave.count, mega.count);
    EXPECT_EQ(wave.sum, mega.sum);
    EXPECT_EQ(wave.sum_sq, mega.sum_sq);
    EXPECT_EQ(wrays, ms.rays);
  }
}

TEST(CudaPassOnHost, SpheresAndFlatShadingMatchCpu) {
  Scene s = cornell_with_sphere(64, 1, 12);
  expect_same_samples(passes_on_host(s, 1), cpu(s), 2e-3, "host passes vs CPU, sphere + flat shading, 1 spp");
}

// The box through a thin lens (the lens sample drawn by camera_sample on
// every device) and through an orthographic camera as wide as the box.
Scene cornell_camera(CameraType type, int res, uint32_t spp, uint64_t seed) {
  Scene s = cornell(res, spp, seed);
  s.camera.type = type;
  if (type == CameraType::ThinLens) {
    s.camera.lens.aperture_radius = 40.f;
    s.camera.lens.focus_distance = 900.f;
  } else if (type == CameraType::Orthographic) {
    s.camera.x_axis = s.camera.x_axis * 300.f;
    s.camera.y_axis = s.camera.y_axis * 300.f;
    s.camera.tan_half_x = s.camera.tan_half_y = 1.f;
  }
  return s;
}

TEST(CudaPassOnHost, ThinLensAndOrthographicMatchCpu) {
  for (CameraType type : {CameraType::ThinLens, CameraType::Orthographic}) {
    Scene s = cornell_camera(type, 48, 1, 17);
    expect_same_samples(passes_on_host(s, 1), cpu(s), 2e-3, ("host passes vs CPU, camera " + std::to_string(int(type))).c_str());
    Scene w = cornell_camera(type, 24, 6, 18);
    Film mega = passes_on_host(w, 3), wave = wavefront_on_host(w, 3);
    EXPECT_EQ(wave.sum, mega.sum);
  }
}

// The box also lit by a point, a spot (projecting a checkerboard, pbrt-v4's
// falloff) and a
// directional light, an environment map and a small quad of textured
// radiance (the light data array and the textures uploaded and read as on
// the CPU).
Scene cornell_lights(int res, uint32_t spp, uint64_t seed) {
  Scene s = cornell(res, spp, seed);
  const Vec3 c = (s.bounds_min + s.bounds_max) * 0.5f, ext = s.bounds_max - s.bounds_min;
  PointLight point;
  point.position = c + Vec3{0.2f * ext.x, 0.3f * ext.y, 0.f};
  point.intensity = {2e4f, 1.5e4f, 1e4f};
  SpotLight spot;
  spot.position = c - Vec3{0.3f * ext.x, -0.2f * ext.y, 0.f};
  spot.intensity = {3e4f, 3e4f, 3e4f};
  spot.inv_x = {1, 0, 0};
  spot.inv_y = {0, 0, 1};
  spot.inv_z = {0, -1, 0};  // pointing down -y
  spot.set_cone(0.5, 0.3, SpotFalloff::SmoothstepCos);  // pbrt-v4's falloff
  DirectionalLight sun;
  sun.direction = normalize(Vec3{0.2f, -0.3f, -1.f});
  sun.irradiance = {0.5f, 0.5f, 0.5f};
  EnvmapLight env;
  std::vector<float> rgb(8 * 5 * 3);
  for (size_t k = 0; k < rgb.size(); ++k) rgb[k] = 0.2f + float(k % 7) * 0.3f;
  env.to_world_x = env.to_local_x = {1, 0, 0};
  env.to_world_y = env.to_local_y = {0, 1, 0};
  env.to_world_z = env.to_local_z = {0, 0, 1};
  build_envmap(env, rgb, 8, 5, s.light_data);
  // The spot projects a checkerboard; a small quad in the box emits a second one.
  Texture checker{CheckerboardTexture{{1.f, 0.3f, 0.1f}, {0.2f, 0.6f, 1.f}}};
  checker.to_uv = {4.f, 0.f, 0.f, 0.f, 4.f, 0.f};
  spot.texture = int32_t(s.add_texture(checker));
  for (const Light& l : {Light(point), Light(spot), Light(sun), Light(env)}) s.lights.push_back(l);
  const Vec3 q = c - Vec3{0.f, 0.f, 0.3f * ext.z};
  const float hw = 0.08f * ext.x;
  const Color glow{8.f, 8.f, 8.f};
  s.add_mesh({q + Vec3{-hw, -hw, 0.f}, q + Vec3{hw, -hw, 0.f}, q + Vec3{hw, hw, 0.f}, q + Vec3{-hw, hw, 0.f}}, {},
             {0, 1, 2, 2, 3, 0}, 0, &glow, {{0.f, 0.f}, {1.f, 0.f}, {1.f, 1.f}, {0.f, 1.f}}, spot.texture);
  s.compile();
  EXPECT_GE(s.lights.size(), 7u);
  return s;
}

TEST(CudaPassOnHost, PointSpotDirectionalAndEnvmapMatchCpu) {
  Scene s = cornell_lights(48, 1, 19);
  expect_same_samples(passes_on_host(s, 1), cpu(s), 2e-3, "host passes vs CPU, delta lights and envmap, 1 spp");
}

// Splatting: the squares' samples and the gather are the CPU's, so one
// splatted sample per pixel matches it but for pixels a diverged path reaches
// (each square's sample enters the 3 × 3 pixels around it: up to 9x the
// filter-sampling fraction); passes and threads per square change only the
// float grouping of the sums.
TEST(CudaPassOnHost, SplattedMatchesCpu) {
  Scene s = cornell_splat(48, 1, 23);
  expect_same_samples(passes_on_host(s, 1), cpu(s), 2e-2, "host passes vs CPU, splatted, 1 spp");
  Scene m = cornell_splat(24, 20, 24);
  Film one = passes_on_host(m, 1, nullptr, 1);
  for (auto [per_pass, threads] : {std::pair{7u, 1u}, std::pair{7u, 3u}, std::pair{20u, 7u}}) {
    Film f = passes_on_host(m, per_pass, nullptr, threads);
    EXPECT_EQ(f.count, one.count) << per_pass << " " << threads;
    for (size_t i = 0; i < one.sum.size(); ++i)
      ASSERT_NEAR(f.sum[i], one.sum[i], 20 * 6e-8 * std::max(1.0, one.sum[i])) << per_pass << " " << threads << " " << i;
  }
}

// A constant sky seen through an opening: the environment's guide, built
// through Luz's BVH, agrees with the CPU's (built through Embree) within noise.
TEST(CudaPassOnHost, GuidedSkyAgreesWithCpu) {
  Scene a = sponza_sky(32, 64, 61), b = sponza_sky(32, 64, 62);
  {  // passes_on_host's guide, through Luz's BVH, has distributions
    const SceneView view = a.view();
    const Bvh bvh = build_bvh(view);
    const EnvGuideData g = build_env_guide(view, make_bvh_tracer(bvh, view), env_guide_options(32 * 32 * 64));
    EXPECT_GT(g.distributions(), 10u);
  }
  expect_agree(passes_on_host(a, 16), cpu(b), "host passes vs CPU, guided sky, 64 spp, independent seeds");
}

// Textures and texture coordinates reach the pass logic as they reach the
// CPU renderer: the same samples with the same seed, and agreement within
// noise with independent seeds.
TEST(CudaPassOnHost, TexturedSceneMatchesCpu) {
  Scene s = textured_cornell(64, 1, 13);
  expect_same_samples(passes_on_host(s, 1), cpu(s), 2e-3, "host passes vs CPU, textured, 1 spp");
  Scene a = textured_cornell(48, 64, 43), b = textured_cornell(48, 64, 44);
  expect_agree(passes_on_host(a, 16), cpu(b), "host passes vs CPU, textured, 64 spp, independent seeds");
}

// Masked materials: the BVH's any-hit test decides as Embree's filter
// function, for camera, continuation and shadow rays alike.
// Within noise only: the alpha test hashes the ray's bits, and the two
// tracers' hit points (Embree's and Luz's triangle tests) differ in the last
// bits, so every ray after the first bounce hashes differently and fractional
// masks decide independently (with the same seed, 13% of one-sample pixels
// differ; identical rays agree hit for hit: test_mask.cpp).
TEST(CudaPassOnHost, MaskedSceneMatchesCpu) {
  Scene a = masked_cornell(48, 64, 45), b = masked_cornell(48, 64, 46);
  expect_agree(passes_on_host(a, 16), cpu(b), "host passes vs CPU, masked, 64 spp, independent seeds");
}

// Normal and bump maps: the same frames in the pass logic as on the CPU.
TEST(CudaPassOnHost, NormalMappedSceneMatchesCpu) {
  Scene s = normal_mapped_cornell(64, 1, 15);
  expect_same_samples(passes_on_host(s, 1), cpu(s), 2e-3, "host passes vs CPU, normal-mapped, 1 spp");
}

// Instances: the two-level BVH and instanced hits in the pass logic give the
// CPU's (Embree's instances) samples.
TEST(CudaPassOnHost, InstancedSceneMatchesCpu) {
  Scene s = instanced_cornell(64, 1, 47);
  ASSERT_EQ(s.instances.size(), 3u);
  {  // the camera's central ray finds the middle instance, in both tracers
    const Bvh bvh = build_bvh(s.view());
    EmbreeScene e(s);
    const Ray ray = s.camera.generate_ray(30.3f, 33.7f);  // off the mesh's edges
    Hit he, hb;
    ASSERT_TRUE(e.tracer().intersect(ray, he));
    ASSERT_TRUE(make_bvh_tracer(bvh, s.view()).intersect(ray, hb));
    EXPECT_EQ(he.inst, 1u);
    EXPECT_EQ(hb.inst, 1u);
    EXPECT_EQ(he.prim, hb.prim);
  }
  expect_same_samples(passes_on_host(s, 1), cpu(s), 2e-3, "host passes vs CPU, instanced, 1 spp");
  Scene a = instanced_cornell(48, 64, 48), b = instanced_cornell(48, 64, 49);
  expect_agree(passes_on_host(a, 16), cpu(b), "host passes vs CPU, instanced, 64 spp, independent seeds");
}

// The plain variant (pass.h) takes the scenes without instances, masked
// materials and normal/bump maps, and renders exactly the full one's samples.
TEST(CudaPassOnHost, PlainVariantRendersAsTheFullOne) {
  auto plain = [](const Scene& s) {
    const SceneView v = s.view();
    const Bvh b = build_bvh(v);
    return pass_is_plain(host_pass_params(s, v, b));
  };
  EXPECT_TRUE(plain(cornell(16, 1, 1)));
  EXPECT_TRUE(plain(textured_cornell(16, 1, 1)));
  EXPECT_TRUE(plain(cornell_splat(16, 1, 1)));
  EXPECT_FALSE(plain(masked_cornell(16, 1, 1)));
  EXPECT_FALSE(plain(normal_mapped_cornell(16, 1, 1)));
  EXPECT_FALSE(plain(instanced_cornell(16, 1, 1)));
  for (const Scene& s : {textured_cornell(32, 4, 3), cornell_splat(24, 4, 4)}) {
    const Film a = passes_on_host(s, 2), b = passes_on_host(s, 2, nullptr, 1, true);
    EXPECT_EQ(a.sum, b.sum);
    EXPECT_EQ(a.count, b.count);
  }
}

// ---------------------------------------------------------------- on a GPU

#define REQUIRE_GPU()                                                          \
  do {                                                                         \
    std::string why_;                                                          \
    if (!cuda_available(&why_)) GTEST_SKIP() << "no usable CUDA GPU: " << why_; \
  } while (0)

Film gpu(const Scene& s, uint32_t per_pass = 0, RenderStats* stats_out = nullptr) {
  CudaRenderOptions opt;
  opt.samples_per_pass = per_pass;
  RenderStats stats;
  Film f = render_cuda(s, opt, stats);
  if (stats_out) *stats_out = stats;
  return f;
}

TEST(CudaDevice, FirstSampleMatchesCpu) {
  REQUIRE_GPU();
  std::printf("[gpu] %s\n", cuda_device_name().c_str());
  Scene s = cornell(128, 1, 11);
  RenderStats gs, cs;
  Film g = gpu(s, 0, &gs), c = cpu(s, &cs);
  expect_same_samples(g, c, 1e-2, "GPU vs CPU, 1 spp, same seed");
  EXPECT_EQ(gs.samples, cs.samples);
  EXPECT_EQ(gs.discarded, 0u);
  EXPECT_NEAR(double(gs.rays), double(cs.rays), 1e-2 * double(cs.rays)) << "same paths, same rays";
}

TEST(CudaDevice, AgreesWithCpuWithinNoise) {
  REQUIRE_GPU();
  Scene a = cornell(64, 256, 31), b = cornell(64, 256, 32);
  RenderStats gs;
  Film g = gpu(a, 0, &gs);
  EXPECT_EQ(gs.discarded, 0u);
  EXPECT_EQ(gs.samples, 64u * 64u * 256u);
  for (uint32_t n : g.count) ASSERT_EQ(n, 256u);
  expect_agree(g, cpu(b), "GPU vs CPU, 256 spp, independent seeds");
  // And against the pass logic on the host with the GPU's own seed: the same
  // samples, so the whole images match to rounding but for diverged paths.
  Film h = passes_on_host(a, 16);
  double sg = 0, sh = 0;
  for (size_t i = 0; i < g.sum.size(); ++i) sg += g.sum[i], sh += h.sum[i];
  EXPECT_NEAR(sg, sh, 1e-2 * sh) << "GPU vs host passes, same seed: image totals";
}

TEST(CudaDevice, SamplesPerPassChangesOnlyRounding) {
  REQUIRE_GPU();
  Scene s = cornell(48, 20, 4);
  Film one = gpu(s, 1), many = gpu(s, 7), again = gpu(s, 1);
  EXPECT_TRUE(again.sum == one.sum && again.sum_sq == one.sum_sq) << "the same passes give the same film";
  EXPECT_EQ(many.count, one.count);
  for (size_t i = 0; i < one.sum.size(); ++i)
    ASSERT_NEAR(many.sum[i], one.sum[i], 7 * 6e-8 * std::max(1.0, one.sum[i])) << i;
}

TEST(CudaDevice, ThreadsPerPixelChangeOnlyRounding) {
  REQUIRE_GPU();
  Scene s = cornell(48, 20, 9);
  CudaRenderOptions opt;
  opt.samples_per_pass = 7;
  RenderStats st;
  opt.threads_per_pixel = 1;
  Film one = render_cuda(s, opt, st);
  opt.threads_per_pixel = 3;
  Film three = render_cuda(s, opt, st);
  EXPECT_EQ(three.count, one.count);
  for (size_t i = 0; i < one.sum.size(); ++i)
    ASSERT_NEAR(three.sum[i], one.sum[i], 3 * 7 * 6e-8 * std::max(1.0, one.sum[i])) << i;
}

// The wavefront variant on the GPU: the megakernel's samples (same seed),
// equal but for float rounding and the rare path it flips, on the Cornell box
// and a glass scene; and the same number of rays within that rare share.
TEST(CudaDevice, WavefrontMatchesMegakernel) {
  REQUIRE_GPU();
  std::vector<Scene> scenes;
  scenes.push_back(cornell(96, 8, 21));
  scenes.push_back(material_scene("roughdielectric", 8, 22));
  for (const Scene& s : scenes) {
    CudaRenderOptions opt;
    opt.threads_per_pixel = 1;
    RenderStats ms, ws;
    Film mega = render_cuda(s, opt, ms);
    opt.wavefront = true;
    Film wave = render_cuda(s, opt, ws);
    EXPECT_EQ(ws.discarded, 0u);
    expect_same_samples(wave, mega, 1e-2, "GPU wavefront vs megakernel, same seed");
    EXPECT_NEAR(double(ws.rays), double(ms.rays), 1e-2 * double(ms.rays));
  }
}

TEST(CudaDevice, ThinLensAndOrthographicMatchCpu) {
  REQUIRE_GPU();
  for (CameraType type : {CameraType::ThinLens, CameraType::Orthographic}) {
    Scene s = cornell_camera(type, 64, 1, 17);
    expect_same_samples(gpu(s), cpu(s), 1e-2, ("GPU vs CPU, 1 spp, camera " + std::to_string(int(type))).c_str());
  }
}

TEST(CudaDevice, SpheresAndFlatShadingMatchCpu) {
  REQUIRE_GPU();
  Scene s = cornell_with_sphere(64, 1, 12);
  RenderStats gs;
  Film g = gpu(s, 0, &gs), c = cpu(s);
  EXPECT_EQ(gs.discarded, 0u);
  expect_same_samples(g, c, 1e-2, "GPU vs CPU, sphere + flat shading, 1 spp, same seed");
}

// A scene on the GPU against the CPU renderer: the same samples with the
// same seed (1 spp at res), and agreement within noise with independent
// seeds (spp at res / 2).
void gpu_matches_cpu(Scene (*make)(int, uint32_t, uint64_t), int res, uint32_t spp, uint64_t seed, const std::string& what) {
  Scene s = make(res, 1, seed);
  expect_same_samples(gpu(s), cpu(s), 1e-2, ("GPU vs CPU, " + what + ", 1 spp, same seed").c_str());
  Scene a = make(res / 2, spp, seed + 1), b = make(res / 2, spp, seed + 2);
  expect_agree(gpu(a), cpu(b), ("GPU vs CPU, " + what + ", independent seeds").c_str());
}

// The texel and uv arrays are uploaded and read on the GPU as on the CPU.
TEST(CudaDevice, TexturedSceneMatchesCpu) {
  REQUIRE_GPU();
  gpu_matches_cpu(textured_cornell, 128, 256, 14, "textured");
}

// The alpha test runs in the GPU's traversal as on the CPU (within noise, as
// CudaPassOnHost.MaskedSceneMatchesCpu).
TEST(CudaDevice, MaskedSceneMatchesCpu) {
  REQUIRE_GPU();
  Scene a = masked_cornell(64, 256, 17), b = masked_cornell(64, 256, 18);
  expect_agree(gpu(a), cpu(b), "GPU vs CPU, masked, independent seeds");
}

// Normal and bump maps perturb the frame on the GPU as on the CPU.
TEST(CudaDevice, NormalMappedSceneMatchesCpu) {
  REQUIRE_GPU();
  gpu_matches_cpu(normal_mapped_cornell, 128, 256, 16, "normal and bump maps");
}

// The objects' trees and the instances are uploaded and traversed on the GPU.
TEST(CudaDevice, InstancedSceneMatchesCpu) {
  REQUIRE_GPU();
  gpu_matches_cpu(instanced_cornell, 128, 256, 50, "instanced");
}

// So are the lights and their data array.
TEST(CudaDevice, PointSpotDirectionalAndEnvmapMatchCpu) {
  REQUIRE_GPU();
  gpu_matches_cpu(cornell_lights, 96, 128, 20, "delta lights and envmap");
}

// Splatting on the GPU: the same samples as the CPU's (one per pixel), and
// passes that change only rounding.
TEST(CudaDevice, SplattedMatchesCpu) {
  REQUIRE_GPU();
  Scene s = cornell_splat(128, 1, 25);
  expect_same_samples(gpu(s), cpu(s), 5e-2, "GPU vs CPU, splatted, 1 spp, same seed");
  Scene m = cornell_splat(64, 20, 26);
  Film one = gpu(m, 1), many = gpu(m, 7);
  EXPECT_EQ(many.count, one.count);
  for (size_t i = 0; i < one.sum.size(); ++i)
    ASSERT_NEAR(many.sum[i], one.sum[i], 7 * 6e-8 * std::max(1.0, one.sum[i])) << i;
}

// The environment's guide, built on the host through the BVH and uploaded.
TEST(CudaDevice, GuidedSkyAgreesWithCpu) {
  REQUIRE_GPU();
  Scene a = sponza_sky(64, 128, 63), b = sponza_sky(64, 128, 64);
  expect_agree(gpu(a), cpu(b), "GPU vs CPU, guided sky, independent seeds");
}

// Every BSDF model's scene on the GPU against the CPU renderer, within noise.
TEST(CudaDevice, MaterialScenesAgreeWithCpu) {
  REQUIRE_GPU();
  for (const char* m : kMaterialModels) {
    Scene a = material_scene(m, 256, 71), b = material_scene(m, 256, 72);
    RenderStats gs;
    Film g = gpu(a, 0, &gs);
    EXPECT_EQ(gs.discarded, 0u) << m;
    std::string what = std::string("GPU vs CPU, material ") + m;
    expect_agree(g, cpu(b), what.c_str(), kFamilyAlpha / kNumMaterialModels);
  }
}

// BSDF sampling on the GPU: χ² of the device's directions against pdf() for
// every case and incidence (Šidák over the family), and the device draws the
// host's samples: the same random numbers, so all but the rare direction whose
// rounding differs are equal to 1e-4.
TEST(CudaDevice, BsdfSamplingChi2) {
  REQUIRE_GPU();
  const double thr = chi2::sidak(chi2::kAlpha, batch_tests());
  double min_p = 1.0;
  uint64_t seed = 9000;
  for (const BatchCase& c : batch_cases())
    for (int side = 0; side < (c.both_sides ? 2 : 1); ++side)
      for (float deg : kBatchIncidenceDeg) {
        const Vec3 wo = batch_wo(deg, side == 1);
        ++seed;
        std::vector<Vec3> wi;
        std::vector<uint8_t> ok;
        sample_bsdf_cuda(c.b, wo, seed, kBatchSamples, wi, ok);
        ASSERT_EQ(wi.size(), size_t(kBatchSamples));
        chi2::Outcome o = batch_chi2(c, wo, wi, ok);
        EXPECT_TRUE(o.result.passes(thr)) << c.name << " at " << deg << "° side " << side << ": " << o.describe(thr);
        min_p = std::min(min_p, o.result.p_value);
        size_t differ = 0;
        for (uint32_t i = 0; i < kBatchSamples; ++i) {
          BsdfSample s = c.b.sample(wo, chi2::rand01(seed, i, 0), chi2::rand2(seed, i, 1));
          bool host_ok = s.valid && !s.delta;
          if (host_ok != (ok[i] != 0) || (host_ok && length(s.wi - wi[i]) > 1e-4f)) ++differ;
        }
        EXPECT_LE(differ, kBatchSamples / 1000) << c.name << " at " << deg << "°: samples differing from the host's";
      }
  std::printf("[gpu] BSDF sampling chi2 over %d cases: smallest p %.3g, reject below %.3g\n", batch_tests(), min_p,
              thr);
}

// Luz's BVH on the GPU answers recorded rays as Embree does on the host.
TEST(CudaDevice, TraceRaysMatchEmbree) {
  REQUIRE_GPU();
  Scene s = cornell_with_sphere(64, 1, 6);
  std::vector<Ray> rays;
  std::vector<uint8_t> shadow, expected;
  record_rays(s, rays, shadow, expected);
  uint64_t hits = 0;
  double seconds = trace_rays_cuda(s, rays, shadow, 2, &hits);
  EXPECT_GT(seconds, 0.0);
  uint64_t expected_hits = uint64_t(std::count(expected.begin(), expected.end(), uint8_t(1)));
  EXPECT_NEAR(double(hits), double(expected_hits), double(rays.size()) / 1000) << "hits among " << rays.size();
}

// ---------------------------------------------------------------- without a GPU

TEST(CudaNoDevice, RenderThrowsOneLineUnavailable) {
  std::string why;
  if (cuda_available(&why)) GTEST_SKIP() << "a GPU is present: " << cuda_device_name();
  EXPECT_FALSE(why.empty());
  EXPECT_EQ(why.find('\n'), std::string::npos);
  EXPECT_EQ(cuda_device_name(), "");
  std::printf("[no gpu] cuda_available: %s\n", why.c_str());
  Scene s = cornell(8, 1, 0);
  RenderStats stats;
  try {
    render_cuda(s, CudaRenderOptions{}, stats);
    FAIL() << "render_cuda succeeded without a GPU";
  } catch (const CudaError& e) {
    EXPECT_EQ(e.kind(), CudaError::Kind::Unavailable);
    EXPECT_EQ(std::string(e.what()), why);
  }
}

// ---------------------------------------------------------------- the CLI

class CliDevice : public luz_test::LuzCliTest {
 protected:
  static size_t lines(const std::string& s) { return size_t(std::count(s.begin(), s.end(), '\n')); }
  // A tiny render of the Cornell box.
  std::vector<std::string> tiny(const std::string& device) {
    return {"render", kCornell, "-o", "out.pfm", "-D", "res=16", "--spp", "2", "--device", device};
  }
};

TEST_F(CliDevice, CudaWithoutGpuIsOneLineExit2) {
  std::string why;
  if (cuda_available(&why)) GTEST_SKIP() << "a GPU is present: " << cuda_device_name();
  auto before = listing();
  luz_test::CliResult r = run(tiny("cuda"));
  ASSERT_TRUE(r.exited);
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_EQ(r.err.rfind("luz: error: --device cuda: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(why), std::string::npos) << "the reason: " << why << "\nstderr: " << r.err;
  EXPECT_EQ(listing(), before) << "no output file";
  std::printf("[cli] %s", r.err.c_str());
}

TEST_F(CliDevice, CudaRendersOnAGpu) {
  REQUIRE_GPU();
  luz_test::CliResult r = run(tiny("cuda"));
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find(cuda_device_name()), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("luz: "), std::string::npos) << "the stats line";
  EXPECT_NE(r.err.find("Mrays/s"), std::string::npos) << r.err;
  luz::Image img = luz::read_pfm((dir / "out.pfm").string());
  EXPECT_EQ(img.width, 16);
  EXPECT_EQ(img.height, 16);
}

TEST_F(CliDevice, AutoFallsBackToCpuWithOneWarning) {
  std::string why;
  bool gpu = cuda_available(&why);
  luz_test::CliResult r = run(tiny("auto"));
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "out.pfm"));
  EXPECT_NE(r.err.find("Mrays/s"), std::string::npos) << r.err;
  size_t warnings = 0;
  for (size_t at = r.err.find("luz: warning:"); at != std::string::npos; at = r.err.find("luz: warning:", at + 1))
    ++warnings;
  if (gpu) {
    EXPECT_EQ(warnings, 0u) << r.err;
    EXPECT_NE(r.err.find(cuda_device_name()), std::string::npos) << r.err;
  } else {
    EXPECT_EQ(warnings, 1u) << r.err;
    EXPECT_NE(r.err.find("luz: warning: --device auto: no usable GPU (" + why + "); rendering on the CPU\n"),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("on the CPU\n"), std::string::npos) << r.err;
  }
}

TEST_F(CliDevice, AutoOnBadInputIsStillOneLine) {
  auto before = listing();
  luz_test::CliResult r = run({"render", "missing.xml", "-o", "out.pfm", "--device", "auto"});
  ASSERT_TRUE(r.exited);
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_EQ(r.err.rfind("missing.xml: error: ", 0), 0u) << r.err;
  EXPECT_EQ(listing(), before);
}

TEST_F(CliDevice, BogusDeviceIsRefused) {
  auto before = listing();
  luz_test::CliResult r = run(tiny("bogus"));
  ASSERT_TRUE(r.exited);
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(lines(r.err), 1u) << r.err;
  EXPECT_NE(r.err.find("--device"), std::string::npos) << r.err;
  EXPECT_EQ(listing(), before);
}

TEST_F(CliDevice, CpuIsTheDefaultAndNeverWarns) {
  luz_test::CliResult r = run({"render", kCornell, "-o", "out.pfm", "-D", "res=16", "--spp", "2"});
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("on the CPU\n"), std::string::npos) << r.err;
  luz_test::CliResult c = run({"render", kCornell, "-o", "cpu.pfm", "-D", "res=16", "--spp", "2", "--device", "cpu"});
  ASSERT_EQ(c.status, 0) << c.err;
  EXPECT_EQ(luz::read_pfm((dir / "out.pfm").string()).rgb, luz::read_pfm((dir / "cpu.pfm").string()).rgb);
}

}  // namespace
