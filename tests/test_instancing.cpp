// Instancing (geometry/instance.h): a scene whose objects are placed by
// rotations, non-uniform scales, shears and mirrors answers every ray as the
// same scene flattened (Scene::flatten_instances) does, and renders the same
// image within noise.
//
//  * Hits: the same primitive (an instance's triangle mapped to its
//    flattened copy), t and the hit point to 1e-5 of the magnitudes
//    involved over the cosine of incidence; at the same barycentrics the
//    Interaction (position, normals, material), texture coordinates and the
//    bump-mapped shading frame bit for bit (both come from the same
//    world-space vertices and normals). Occlusion the same. Disagreements
//    are allowed only for rays within 1e-4 (barycentric) of a hit
//    triangle's edge, at equal t on two triangles or grazing (cos θ < 1e-2),
//    and bounded.
//    A masked (opacity 0) quad inside the object must stay invisible through
//    the instances too (the alpha test inside them).
//  * The same for Luz's two-level BVH (bvh.h) against its one-level
//    traversal of the flattened scene and against Embree's.
//  * Image: the instanced and flattened scenes rendered with the same
//    samples agree per 4×4 block within a Šidák-corrected z bound.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "luz/accel/bvh_build.h"
#include "luz/accel/embree_tracer.h"
#include "luz/device/cpu/render.h"
#include "luz/light/light.h"
#include "luz/scene/scene_builder.h"
#include "luz/scene/scene_info.h"
#include "geometry_helpers.h"
#include "stat_helpers.h"

using namespace luz;
using luz_test::Rng;
using luz_test::uv_sphere;

namespace {

const SourceLoc kAt{"test", 1};

TriangleMesh quad(Vec3 o, Vec3 e1, Vec3 e2) {
  TriangleMesh m;
  m.positions = {o, o + e1, o + e1 + e2, o + e2};
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

// World geometry (a floor, a light, a sphere) and two objects: a bump-mapped
// sphere on a rough metal base behind a cut-away (opacity 0) quad, placed six
// times; a tetrahedron placed twice.
Scene instanced_scene() {
  SceneBuilder b("instancing");
  std::vector<uint32_t> bump(16 * 16);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      const uint32_t g = uint32_t(128 + 100 * std::sin(0.9 * x) * std::cos(0.7 * y));
      bump[size_t(y) * 16 + size_t(x)] = g | g << 8 | g << 16 | 0xffu << 24;
    }
  BitmapTexture bm;
  bm.width = bm.height = 16;
  bm.srgb = false;
  MaterialDesc bumpy;
  bumpy.bsdf = Bsdf::make_diffuse({0.7f, 0.5f, 0.3f});
  bumpy.bump_map = b.add_image8(kAt, bm, {}, bump);
  bumpy.bump_scale = 0.05f;
  const uint32_t m_bump = b.add_material(kAt, bumpy);
  MaterialDesc metal;
  metal.bsdf = Bsdf::make_rough_conductor(MicrofacetType::GGX, 0.3f, 0.3f, {0.2f, 0.9f, 1.1f}, {3.9f, 2.4f, 2.2f});
  const uint32_t m_metal = b.add_material(kAt, metal);
  MaterialDesc cut;
  cut.opacity = 0.f;
  const uint32_t m_cut = b.add_material(kAt, cut);
  const uint32_t m_white = b.default_material();

  b.add_mesh(kAt, quad({-10, -3, -10}, {0, 0, 20}, {20, 0, 0}), m_white);
  AreaEmission e;
  e.radiance = {8.f, 8.f, 8.f};
  b.add_mesh(kAt, quad({-2, 6, -2}, {4, 0, 0}, {0, 0, 4}), m_white, &e);
  b.add_sphere(kAt, {0, -2, 4}, 1.f, m_metal);
  ConstantLight sky;
  sky.radiance = {0.2f, 0.2f, 0.3f};
  b.add_light(kAt, sky);

  const uint32_t obj = b.begin_object(kAt, "ball");
  b.add_object_mesh(kAt, obj, uv_sphere(16, 8), m_bump);
  b.add_object_mesh(kAt, obj, quad({-1.5f, -1, -1.5f}, {0, 0, 3}, {3, 0, 0}), m_metal);
  b.add_object_mesh(kAt, obj, quad({-1, -1, 1.2f}, {2, 0, 0}, {0, 2, 0}), m_cut);
  using M = Matrix4;
  const M placements[] = {
      M::translate({-4, 0, 0}),
      M::rotate({1, 1, 0}, 40) * M::scale({1, 0.5f, 1.5f}),
      M::translate({4, 0, 0}) * M::scale({-1, 1, 1}),  // a mirror
      M::translate({0, 3, -2}) * M::rotate({0, 0, 1}, 90) * M::scale({0.5f, 0.5f, 0.5f}),
      M::translate({-3, -1, 3}) * M::rotate({0, 1, 0}, 25) * M::scale({1, -2, 1}) * M::rotate({1, 0, 1}, 35),
      M::translate({3, 2, 2}) * M::rotate({0, 1, 1}, 60) * M::scale({2, 1, 0.7f}) * M::rotate({1, 0, 0}, 30),  // a shear
  };
  for (const M& t : placements) b.add_instance(kAt, obj, t);
  const uint32_t tet = b.begin_object(kAt, "tetrahedron");
  TriangleMesh t;
  t.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  t.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  b.add_object_mesh(kAt, tet, t, m_metal);
  b.add_instance(kAt, tet, M::translate({-6, -2, -1}));
  b.add_instance(kAt, tet, M::translate({6, -2, -1}) * M::scale({2, 2, -2}));
  b.frame_bounds(48, 48);
  b.settings().spp = 16;
  b.settings().integrator.max_depth = 6;
  return b.finish();
}

Scene flattened(const Scene& s) {
  Scene f = s;
  f.flatten_instances();
  f.compile();
  return f;
}

// Rays over the flattened scene `f`: half from random origins in its bounds
// in uniform directions, half aimed at a random point of a random placed
// (flattened instance) triangle; a third of all with a finite tmax.
std::vector<Ray> test_rays(const Scene& f, uint32_t world_triangles, size_t n, uint64_t seed) {
  Rng rng(seed);
  const Vec3 lo = f.bounds_min, ext = f.bounds_max - f.bounds_min;
  std::vector<Ray> rays(n);
  for (size_t i = 0; i < n; ++i) {
    Ray& r = rays[i];
    r.o = {lo.x + ext.x * rng.uniform(), lo.y + ext.y * rng.uniform(), lo.z + ext.z * rng.uniform()};
    if (i % 2 == 0) {
      const float z = 1.f - 2.f * rng.uniform(), ph = 2.f * kPi * rng.uniform(), s = std::sqrt(std::max(0.f, 1 - z * z));
      r.d = {s * std::cos(ph), s * std::sin(ph), z};
    } else {
      const uint32_t t = world_triangles + uint32_t(rng.next() % (f.num_triangles() - world_triangles));
      float u = rng.uniform(), v = rng.uniform();
      if (u + v > 1.f) u = 1.f - u, v = 1.f - v;
      const Vec3 p0 = f.positions[f.indices[3 * t]], p1 = f.positions[f.indices[3 * t + 1]],
                 p2 = f.positions[f.indices[3 * t + 2]];
      r.d = normalize(p0 * (1.f - u - v) + p1 * u + p2 * v - r.o);
    }
    if (i % 3 == 0) r.tmax = length(ext) * rng.uniform();
  }
  return rays;
}

float min_barycentric(const Hit& h) { return std::min(std::min(h.u, h.v), 1.f - h.u - h.v); }

struct Tally {
  size_t rays = 0, hits = 0, instance_hits = 0, grazing = 0, explained = 0, unexplained = 0;
  double max_t = 0, max_p = 0, max_ns = 0;  // |Δt| and |Δp| relative to their bound
};

// Compares tracer `ti` over the instanced scene `si` with `tf` over its
// flattening `sf`, ray by ray.
template <class TracerI, class TracerF>
Tally compare(const char* name, const Scene& si, const TracerI& ti, const Scene& sf, const TracerF& tf,
              const std::vector<Ray>& rays) {
  // An instance's triangles in the flattened scene: after the world's, in
  // instance order.
  std::vector<uint32_t> flat_first(si.instances.size());
  uint32_t next = si.num_triangles();
  for (size_t k = 0; k < si.instances.size(); ++k) {
    flat_first[k] = next;
    next += si.objects[si.instances[k].object].num_triangles;
  }
  auto flat_prim = [&](const Hit& h) {
    if (h.inst == kNoInstance) return h.prim;
    return flat_first[h.inst] + h.prim - si.objects[si.instances[h.inst].object].first_triangle;
  };
  const SceneView vi = si.view(), vf = sf.view();
  Tally c;
  int printed = 0;
  auto fail = [&](size_t i, const std::string& what) {
    ++c.unexplained;
    if (printed++ < 8) {
      const Ray& r = rays[i];
      ADD_FAILURE() << name << " ray " << i << ": " << what << "\n  o = " << r.o.x << " " << r.o.y << " " << r.o.z
                    << "  d = " << r.d.x << " " << r.d.y << " " << r.d.z << "  tmax = " << r.tmax;
    }
  };
  for (size_t i = 0; i < rays.size(); ++i) {
    const Ray& ray = rays[i];
    ++c.rays;
    Hit hi, hf;
    const bool bi = ti.intersect(ray, hi), bf = tf.intersect(ray, hf);
    const bool oi = ti.occluded(ray), of = tf.occluded(ray);
    const bool edge = (bi && hi.kind == PrimKind::Triangle && min_barycentric(hi) < 1e-4f) ||
                      (bf && hf.kind == PrimKind::Triangle && min_barycentric(hf) < 1e-4f);
    if (oi != of) {
      if (edge) ++c.explained;
      else fail(i, "occlusion differs");
      continue;
    }
    if (!bi && !bf) continue;
    if (bi != bf) {
      if (edge) ++c.explained;
      else fail(i, "hit/miss differs");
      continue;
    }
    const double scale = std::max({double(hf.t), double(max_abs(ray.o)), 1.0});
    const double dt = std::fabs(double(hi.t) - double(hf.t));
    if (hi.kind != hf.kind || flat_prim(hi) != hf.prim) {
      if (edge || dt <= 1e-5 * scale) ++c.explained;
      else fail(i, "different primitives");
      continue;
    }
    // A plane displaced by δ moves the ray's crossing by δ / cos θ along
    // the ray: grazing hits get a wider bound, and the most grazing
    // (cos θ < 1e-2) count as explained, like edges.
    const Interaction ii = vi.interaction(ray, hi);
    const float cosine = std::fabs(dot(ii.ng, ray.d)) / length(ray.d);
    const double tol = 1e-5 * scale / std::max(cosine, 1e-2f);
    if (cosine < 1e-2f) {
      ++c.grazing;
      continue;
    }
    ++c.hits;
    c.instance_hits += hi.inst != kNoInstance;
    if (hi.kind == PrimKind::Sphere && hi.inst != kNoInstance) fail(i, "a sphere hit inside an instance");
    c.max_t = std::max(c.max_t, dt / tol);
    if (dt > tol) fail(i, "t differs: " + std::to_string(hi.t) + " vs " + std::to_string(hf.t));
    const Interaction jf = vf.interaction(ray, hf);
    c.max_p = std::max(c.max_p, double(length(ii.p - jf.p)) / tol);
    if (length(ii.p - jf.p) > tol) fail(i, "position differs");
    // At the same barycentrics, the flattened triangle's surface is the
    // instance's bit for bit: the same world vertices and vertex normals.
    Hit same = hf;
    same.u = hi.u;
    same.v = hi.v;
    Interaction jf2 = vf.interaction(ray, same), ii2 = ii;
    auto eq = [](Vec3 a, Vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; };
    if (!eq(ii.p, jf2.p) || !eq(ii.ng, jf2.ng) || !eq(ii.ns, jf2.ns))
      fail(i, "the Interaction differs from the flattened one at the same barycentrics");
    if (ii.material != jf2.material || ii.emitter != jf2.emitter) fail(i, "material or emitter differs");
    const Vec2 ui = vi.hit_uv(hi, ii.p), uf = vf.hit_uv(same, jf2.p);
    if (ui.x != uf.x || ui.y != uf.y) fail(i, "texture coordinates differ");
    const Frame fi = vi.shading_frame(ii2, hi), ff = vf.shading_frame(jf2, same);
    if (!eq(fi.s, ff.s) || !eq(fi.t, ff.t) || !eq(fi.n, ff.n)) fail(i, "shading frame differs");
    c.max_ns = std::max(c.max_ns, double(length(ii.ns - jf.ns)));
  }
  std::printf("[%s] %zu rays, %zu hits agree (%zu on instances), %zu grazing, %zu explained disagreements (edges, ties), "
              "%zu unexplained; max |Δt| %.2f and |Δp| %.2f of their bounds, |Δns| %.2e\n",
              name, c.rays, c.hits, c.instance_hits, c.grazing, c.explained, c.unexplained, c.max_t, c.max_p, c.max_ns);
  EXPECT_EQ(c.unexplained, 0u) << name;
  EXPECT_LE(double(c.explained), 1e-3 * double(c.rays)) << name;
  EXPECT_LE(double(c.grazing), 0.02 * double(c.hits)) << name;  // about cos θ < 1e-2's share, 1%
  EXPECT_GT(c.instance_hits, c.rays / 4) << name << ": too few rays hit instances to test them";
  return c;
}

// Closest-hit queries per second (millions, one thread, best of 3): a figure
// for bench/RESULTS.md, not a check.
template <class Tracer>
double mrays(const Tracer& t, const std::vector<Ray>& rays) {
  double best = 0;
  for (int round = 0; round < 3; ++round) {
    const auto t0 = std::chrono::steady_clock::now();
    size_t hits = 0;
    for (const Ray& r : rays) {
      Hit h;
      hits += t.intersect(r, h);
    }
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    volatile size_t sink = hits;  // keeps the queries
    (void)sink;
    best = std::max(best, double(rays.size()) / s * 1e-6);
  }
  return best;
}

struct Fixture {
  Scene inst = instanced_scene();
  Scene flat = flattened(inst);
  std::vector<Ray> rays = test_rays(flat, inst.num_triangles(), 200000, 7);
};

const Fixture& fixture() {
  static const Fixture f;
  return f;
}

TEST(Instancing, SceneKeepsOneCopyPerObject) {
  const Scene& s = fixture().inst;
  ASSERT_EQ(s.objects.size(), 2u);
  EXPECT_EQ(s.instances.size(), 8u);
  EXPECT_EQ(s.num_triangles(), 4u);  // the floor and the light
  const uint32_t ball = s.objects[0].num_triangles, tet = s.objects[1].num_triangles;
  EXPECT_EQ(tet, 4u);
  EXPECT_EQ(s.num_instanced_triangles(), 6u * ball + 2u * 4u);
  EXPECT_EQ(fixture().flat.num_triangles(), 4u + 6u * ball + 2u * 4u);
  EXPECT_EQ(s.tri_material.size(), 4u + ball + tet);
  const std::string info = describe_scene(s);
  const std::string want = "instancing: 2 objects (" + std::to_string(ball + tet) + " triangles) placed by 8 instances (" +
                           std::to_string(6 * ball + 8) + " triangles placed); 0 placements flattened";
  EXPECT_NE(info.find(want), std::string::npos) << info;
  EXPECT_NE(info.find("shapes: 4 triangles, 1 sphere, 8 instances"), std::string::npos) << info;
  // The bounds hold the flattened scene's.
  const Scene& f = fixture().flat;
  EXPECT_LE(s.bounds_min.x, f.bounds_min.x);
  EXPECT_LE(s.bounds_min.y, f.bounds_min.y);
  EXPECT_GE(s.bounds_max.z, f.bounds_max.z);
}

TEST(Instancing, EmbreeInstancesHitAsTheFlattenedScene) {
  const Fixture& fx = fixture();
  EmbreeScene ei(fx.inst), ef(fx.flat);
  compare("embree", fx.inst, ei.tracer(), fx.flat, ef.tracer(), fx.rays);
  std::printf("embree: %.2f Mrays/s instanced, %.2f flattened (one thread)\n", mrays(ei.tracer(), fx.rays),
              mrays(ef.tracer(), fx.rays));
}

// Luz's BVH (two levels: bvh.h) against its own single-level traversal of
// the flattened scene, and against Embree's.
TEST(Instancing, TwoLevelBvhHitsAsTheFlattenedScene) {
  const Fixture& fx = fixture();
  const Bvh bi = build_bvh(fx.inst.view()), bf = build_bvh(fx.flat.view());
  ASSERT_EQ(bi.objects.size(), 2u);
  EXPECT_TRUE(bf.objects.empty());
  EXPECT_LT(bi.bytes(), bf.bytes());
  const BvhTracer ti = make_bvh_tracer(bi, fx.inst.view()), tf = make_bvh_tracer(bf, fx.flat.view());
  compare("bvh", fx.inst, ti, fx.flat, tf, fx.rays);
  EmbreeScene ef(fx.flat);
  compare("bvh, embree", fx.inst, ti, fx.flat, ef.tracer(), fx.rays);
  std::printf("bvh: %.2f Mrays/s instanced, %.2f flattened (one thread, host); %.1f KiB against %.1f KiB\n",
              mrays(ti, fx.rays), mrays(tf, fx.rays), double(bi.bytes()) / 1024, double(bf.bytes()) / 1024);
}

// Rays aimed through the cut-away quads at the spheres behind them: every
// hit is on a sphere, never on the quad (its opacity is 0).
template <class Tracer>
void expect_cut_quads_invisible(const Scene& s, const Tracer& t) {
  const SceneObject& o = s.objects[0];
  const uint32_t cut_first = o.first_triangle + o.num_triangles - 2;  // the object's last mesh
  int hits = 0;
  for (const Instance& in : s.instances) {
    if (in.object != 0) continue;
    for (int k = 0; k < 50; ++k) {
      const Vec3 target = in.to_world.point({-0.5f + 0.02f * float(k), 0.1f, 1.2f});
      const Vec3 behind = in.to_world.point({-0.5f + 0.02f * float(k), 0.1f, 0.f});
      Ray r;
      r.o = target + (target - behind) * 2.f;
      r.d = normalize(behind - r.o);
      Hit h;
      if (!t.intersect(r, h)) continue;
      EXPECT_FALSE(h.inst != kNoInstance && h.prim >= cut_first && h.prim < cut_first + 2) << "the cut quad was hit";
      ++hits;
    }
  }
  EXPECT_GT(hits, 200);
}

TEST(Instancing, MaskedTrianglesStayCutInsideInstances) {
  const Scene& s = fixture().inst;
  EmbreeScene es(s);
  expect_cut_quads_invisible(s, es.tracer());
  const Bvh bvh = build_bvh(s.view());
  expect_cut_quads_invisible(s, make_bvh_tracer(bvh, s.view()));
}

TEST(Instancing, RendersAsTheFlattenedScene) {
  const Fixture& fx = fixture();
  CpuRenderOptions opt;
  opt.threads = 2;
  RenderStats si, sf;
  Scene inst = fx.inst, flat = fx.flat;
  luz_test::independent_pixels(inst);
  luz_test::independent_pixels(flat);
  const Film a = render_cpu(inst, opt, si), b = render_cpu(flat, opt, sf);
  EXPECT_EQ(si.discarded, 0u);
  EXPECT_EQ(sf.discarded, 0u);
  const luz_test::Blocks ba = luz_test::make_blocks(a, 4), bb = luz_test::make_blocks(b, 4);
  const double zmax = luz_test::sidak_z(1e-3, double(ba.mean.size()));
  double worst = 0, sum_a = 0, sum_b = 0;
  for (size_t k = 0; k < ba.mean.size(); ++k) {
    const double sd = std::sqrt(ba.var[k] + bb.var[k]) + luz_test::rounding_floor(ba.mean[k]);
    worst = std::max(worst, std::fabs(ba.mean[k] - bb.mean[k]) / sd);
    sum_a += ba.mean[k];
    sum_b += bb.mean[k];
  }
  std::printf("image: %zu block values, worst |z| %.2f (bound %.2f), mean %.5f vs %.5f\n", ba.mean.size(), worst, zmax,
              sum_a / double(ba.mean.size()), sum_b / double(bb.mean.size()));
  EXPECT_LE(worst, zmax);
  EXPECT_GT(sum_a, 0.0);
}

}  // namespace
