// Instancing's memory claim (issue 18): 10,000 instances of a
// 100,000-triangle mesh fit in well under 1 GB, Embree's two-level scene and
// Luz's two-level BVH both built, against about 48 GB for the same
// billion triangles flattened (36 bytes per triangle and 32 per vertex in
// Scene's arrays alone). Its own program, so that the process's peak
// resident memory (getrusage's ru_maxrss) is this scene's. Memory grows
// with the instances by a few hundred bytes each (measured between 1,000
// and 10,000 instances), not with their triangles. Figures in
// bench/RESULTS.md.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>

#include "luz/accel/bvh_build.h"
#include "luz/accel/embree_tracer.h"
#include "geometry_helpers.h"
#include "luz/scene/scene_builder.h"

using namespace luz;
using luz_test::uv_sphere;

namespace {

double resident_mib() {
  std::ifstream f("/proc/self/statm");
  long pages = 0, resident = 0;
  f >> pages >> resident;
  return double(resident) * double(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

double peak_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) / 1024.0;  // kilobytes on Linux
}

// n instances of a 100,000-triangle sphere on a square grid, each turned
// and scaled its own way; a camera above.
Scene grid_scene(int n) {
  SceneBuilder b("memory");
  const uint32_t obj = b.begin_object({}, "sphere");
  TriangleMesh m = uv_sphere(250, 201);
  EXPECT_EQ(m.indices.size() / 3, 100000u);
  b.add_object_mesh({}, obj, std::move(m), b.default_material());
  const int side = int(std::ceil(std::sqrt(double(n))));
  for (int k = 0; k < n; ++k) {
    const double x = 3.0 * (k % side), z = 3.0 * (k / side);
    b.add_instance({}, obj,
                   Matrix4::translate({float(x), 0, float(z)}) * Matrix4::rotate({1, 1, 0}, 7.0 * k) *
                       Matrix4::scale({1, 0.5f + 0.5f * float(k % 3), 1}));
  }
  Camera cam;
  cam.origin = {float(1.5 * side), 50, float(1.5 * side)};
  cam.z_axis = {0, -1, 0};
  cam.y_axis = {0, 0, 1};
  cam.x_axis = {1, 0, 0};
  b.set_camera({}, cam);
  return b.finish();
}

TEST(InstancingMemory, TenThousandInstancesOfA100kMeshFitWellUnder1GB) {
  const double base = resident_mib();
  double small_rss = 0;
  {
    const Scene s = grid_scene(1000);
    EmbreeScene e(s);
    const Bvh bvh = build_bvh(s.view());
    small_rss = resident_mib();
  }
  const auto t0 = std::chrono::steady_clock::now();
  const Scene s = grid_scene(10000);
  ASSERT_EQ(s.instances.size(), 10000u);
  ASSERT_EQ(s.num_instanced_triangles(), 1000000000u);
  const auto t1 = std::chrono::steady_clock::now();
  auto embree = std::make_unique<EmbreeScene>(s);
  const auto t2 = std::chrono::steady_clock::now();
  const Bvh bvh = build_bvh(s.view());
  const auto t3 = std::chrono::steady_clock::now();
  const double rss = resident_mib(), peak = peak_mib();

  // Both tracers see the instances: rays straight down the grid's rows.
  const EmbreeTracer et = embree->tracer();
  const BvhTracer bt = make_bvh_tracer(bvh, s.view());
  int hits_e = 0, hits_b = 0, same = 0;
  for (int k = 0; k < 10000; ++k) {
    Ray r;
    r.o = {3.f * float(k % 100) + 0.3f * std::sin(float(k)), 20.f, 3.f * float(k / 100) + 0.3f * std::cos(float(k))};
    r.d = {0, -1, 0};
    Hit he, hb;
    const bool e = et.intersect(r, he), b = bt.intersect(r, hb);
    hits_e += e;
    hits_b += b;
    same += e && b && he.inst == hb.inst && he.prim == hb.prim;
  }
  auto sec = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
  std::printf("10,000 instances of 100,000 triangles: resident %.1f MiB (peak %.1f MiB; %.1f MiB before), "
              "Luz BVH %.1f MiB; %.1f MiB with 1,000 instances: %.0f bytes per further instance; "
              "load %.2f s, Embree %.2f s, Luz BVH %.2f s; rays hitting: Embree %d, BVH %d, same hit %d\n",
              rss, peak, base, double(bvh.bytes()) / (1024.0 * 1024.0), small_rss,
              (rss - small_rss) * 1024.0 * 1024.0 / 9000.0, sec(t0, t1), sec(t1, t2), sec(t2, t3), hits_e, hits_b,
              same);
  EXPECT_LT(peak, 1024.0);
  EXPECT_GT(hits_e, 9000);
  EXPECT_EQ(hits_b, hits_e);
  EXPECT_GT(same, 9900);
}

}  // namespace
