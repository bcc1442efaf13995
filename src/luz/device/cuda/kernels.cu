// The integrator instantiated for the GPU. Until Luz's own BVH lands (the CUDA
// backend issue), the device tracer is a brute-force loop over all primitives:
// it exists so that every change to the shared integrator, BSDFs, lights,
// samplers and camera is compiled by nvcc from the first day.
#include "luz/film/filter.h"
#include "luz/integrator/path.h"

namespace luz {

// Brute-force tracer: "intersection" and "any hit" roles of OptiX, in one struct.
struct BruteForceTracer {
  const SceneView* scene;

  __device__ bool intersect(const Ray& ray, Hit& hit) const {
    bool found = false;
    float tmax = ray.tmax;
    for (uint32_t k = 0; k < scene->num_triangles; ++k) {
      Vec3 p0, p1, p2;
      scene->triangle(k, p0, p1, p2);
      // Möller-Trumbore.
      Vec3 e1 = p1 - p0, e2 = p2 - p0, pv = cross(ray.d, e2);
      float det = dot(e1, pv);
      if (det == 0.f) continue;
      float inv = 1.f / det;
      Vec3 tv = ray.o - p0;
      float u = dot(tv, pv) * inv;
      if (u < 0.f || u > 1.f) continue;
      Vec3 qv = cross(tv, e1);
      float v = dot(ray.d, qv) * inv;
      if (v < 0.f || u + v > 1.f) continue;
      float t = dot(e2, qv) * inv;
      if (t > 0.f && t < tmax) {
        tmax = t;
        hit = {t, k, PrimKind::Triangle, u, v};
        found = true;
      }
    }
    for (uint32_t k = 0; k < scene->num_spheres; ++k) {
      float t = intersect_sphere(scene->spheres[k].center, scene->spheres[k].radius, ray.o, ray.d, tmax);
      if (t > 0.f) {
        tmax = t;
        hit = {t, k, PrimKind::Sphere, 0.f, 0.f};
        found = true;
      }
    }
    return found;
  }
  __device__ bool occluded(const Ray& ray) const {
    Hit h;
    return intersect(ray, h);
  }
};

__global__ void render_kernel(SceneView scene, SamplerDesc desc, IntegratorParams params, FilterKind filter,
                              uint32_t sample_index, float* out, unsigned long long* rays) {
  int x = blockIdx.x * blockDim.x + threadIdx.x, y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= scene.camera.width || y >= scene.camera.height) return;
  Sampler sampler;
  sampler.start(desc, uint32_t(x), uint32_t(y), sample_index);
  Vec2 off = sample_filter(filter, sampler.next_2d());
  Ray ray = scene.camera.generate_ray(float(x) + 0.5f + off.x, float(y) + 0.5f + off.y);
  BruteForceTracer tracer{&scene};
  uint64_t n = 0;
  Color L = path_li(scene, tracer, ray, sampler, params, n);
  size_t i = 3 * (size_t(y) * scene.camera.width + x);
  if (is_finite(L)) {
    out[i] += L.x;
    out[i + 1] += L.y;
    out[i + 2] += L.z;
  }
  atomicAdd(rays, (unsigned long long)n);
}

}  // namespace luz
