#include "luz/render/aov.h"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <limits>

#include "luz/accel/embree_tracer.h"
#include "luz/camera/camera.h"
#include "luz/math/hash.h"
#include "luz/sampling/sampler.h"

namespace luz {

AovImages render_aovs(const Scene& scene, uint32_t samples, uint32_t bsdf_samples, int threads) {
  const SceneView view = scene.view();
  const EmbreeScene embree(scene);
  const EmbreeTracer tracer = embree.tracer();
  const RenderSettings& rs = scene.settings;
  const SamplerDesc desc = make_sampler_desc(rs.sampler, rs.spp, rs.seed);
  const Camera& cam = view.camera;
  const Vec3 axis = normalize(cam.z_axis);
  samples = std::max<uint32_t>(1, std::min(samples, rs.spp));
  bsdf_samples = std::max<uint32_t>(1, bsdf_samples);

  AovImages out;
  out.width = cam.width;
  out.height = cam.height;
  const size_t pixels = size_t(cam.width) * size_t(cam.height);
  out.albedo.assign(3 * pixels, 0.f);
  out.normal.assign(3 * pixels, 0.f);
  out.depth.assign(pixels, std::numeric_limits<float>::infinity());

  auto pixel = [&](uint32_t x, uint32_t y) {
    const size_t i = size_t(y) * size_t(cam.width) + x;
    double albedo[3] = {0, 0, 0}, normal[3] = {0, 0, 0}, depth = 0;
    uint32_t hits = 0;
    Sampler sampler;
    sampler.start(desc, x, y, 0);
    for (uint32_t s = 0; s < samples; ++s) {
      sampler.set_sample(s);
      const Ray ray = camera_sample(cam, x, y, sampler, rs.filter);
      Hit hit;
      if (!tracer.intersect(ray, hit)) continue;
      ++hits;
      Interaction it = view.interaction(ray, hit);
      Bsdf textured{Uninitialized{}};
      const Bsdf& bsdf = view.bsdf(it, hit, textured);
      const Frame frame = view.shading_frame(it, hit);
      const Vec3 wo = frame.to_local(-ray.d);
      Color a{};
      for (uint32_t k = 0; k < bsdf_samples; ++k) {
        const uint64_t h = hash4(rs.seed, i, s, k);
        const BsdfSample b = bsdf.sample(wo, to_unit_float(mix64(h ^ 1)), {to_unit_float(mix64(h ^ 2)), to_unit_float(mix64(h ^ 3))});
        if (b.valid && std::isfinite(b.weight.x + b.weight.y + b.weight.z)) a += b.weight;
      }
      const Vec3 n = dot(it.ns, ray.d) > 0.f ? -it.ns : it.ns;
      for (int c = 0; c < 3; ++c) {
        albedo[c] += a[c] / float(bsdf_samples);
        normal[c] += n[c];
      }
      depth += dot(it.p - cam.origin, axis);
    }
    for (int c = 0; c < 3; ++c) {
      out.albedo[3 * i + size_t(c)] = float(albedo[c] / samples);
      out.normal[3 * i + size_t(c)] = float(normal[c] / samples);
    }
    if (hits) out.depth[i] = float(depth / hits);
  };
  tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range2d<int>(0, cam.height, 0, cam.width), [&](const tbb::blocked_range2d<int>& r) {
      for (int y = r.rows().begin(); y < r.rows().end(); ++y)
        for (int x = r.cols().begin(); x < r.cols().end(); ++x) pixel(uint32_t(x), uint32_t(y));
    });
  });
  return out;
}

}  // namespace luz
