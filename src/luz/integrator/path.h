// The path tracer, written once for the CPU and CUDA (seed §1.2.3, §2.5).
//
// At each vertex: emission (weighted by MIS against light sampling), next-event
// estimation (one emitter chosen by power, area pdf converted to solid angle,
// shadow ray), BSDF sampling, Russian roulette. `bsdf` and `light` are the two
// single-strategy estimators, kept to verify the combined one.
//
// Depth follows Mitsuba: a path of depth k has k segments after the camera
// ray's origin, so max_depth 1 shows emitters only, 2 adds direct light.
// max_depth < 0 means unbounded (Russian roulette ends the path).
//
// The Tracer is a template parameter with two methods,
//   bool intersect(const Ray&, Hit&) const;  // closest hit
//   bool occluded(const Ray&) const;         // any hit, within ray.tmax
// Embree on the CPU, Luz's own BVH in CUDA.
#pragma once

#include "luz/sampling/sampler.h"
#include "luz/scene/scene_view.h"

namespace luz {

enum class IntegratorType : uint32_t { Path, Bsdf, Light };

struct IntegratorParams {
  IntegratorType type = IntegratorType::Path;
  int max_depth = -1;
  int rr_depth = 5;  // Russian roulette from this depth on (Mitsuba's default)
};

// Sample dimensions: 0: pixel filter (2D). Then, per vertex, a fixed block so
// that a dimension always means the same thing.
inline constexpr uint32_t kCameraDims = 1;
inline constexpr uint32_t kDimsPerVertex = 5;

template <class Tracer>
LUZ_HOST_DEVICE Color path_li(const SceneView& scene, const Tracer& tracer, Ray ray, Sampler& sampler,
                              const IntegratorParams& params, uint64_t& rays) {
  Color L{}, beta{1.f, 1.f, 1.f};
  const bool use_nee = params.type != IntegratorType::Bsdf;
  const bool use_mis = params.type == IntegratorType::Path;
  float prev_pdf = 0.f;  // solid-angle pdf of the BSDF sample that made `ray`
  Vec3 prev_p = ray.o;

  for (int depth = 1;; ++depth) {
    sampler.dim = kCameraDims + uint32_t(depth - 1) * kDimsPerVertex;
    Hit hit;
    ++rays;
    bool found = tracer.intersect(ray, hit);

    // Emission reached by the previous BSDF sample (or seen by the camera).
    Color Le{};
    float light_pdf = 0.f;
    Interaction it;
    if (!found) {
      if (scene.environment >= 0) {
        Le = scene.environment_radiance(ray.d);
        light_pdf = scene.emitter_pmf[scene.environment] * uniform_sphere_pdf();
      }
    } else {
      it = scene.interaction(ray, hit);
      if (it.emitter >= 0) {
        Le = scene.emitted(it, -ray.d);
        if (!is_black(Le) && depth > 1 && use_mis)
          light_pdf = scene.emitter_pmf[it.emitter] * scene.emitter_pdf(uint32_t(it.emitter), prev_p, it, ray.d, hit.t);
      }
    }
    if (!is_black(Le)) {
      float w = 1.f;
      if (depth > 1) {
        if (params.type == IntegratorType::Light) w = 0.f;
        else if (use_mis) w = power_heuristic(prev_pdf, light_pdf);
      }
      L += beta * Le * w;
    }
    if (!found) break;
    if (params.max_depth >= 0 && depth >= params.max_depth) break;

    const Bsdf& bsdf = scene.materials[it.material];
    Frame frame = Frame::from_normal(it.ns);
    Vec3 wo = frame.to_local(-ray.d);
    // BSDFs here reflect only: every ray leaving this vertex (shadow ray and
    // continuation) starts on the viewer's side of the geometric surface, so
    // one robust offset origin serves both.
    const Vec3 n_out = dot(ray.d, it.ng) < 0.f ? it.ng : -it.ng;
    const Vec3 origin = offset_ray_origin(it.p, n_out);

    // Next-event estimation.
    if (use_nee && scene.num_emitters > 0) {
      float u_light = sampler.next_1d();
      Vec2 u_light2 = sampler.next_2d();
      uint32_t e = scene.select_emitter(u_light);
      LightSample ls = scene.sample_emitter(e, it.p, u_light2);
      if (ls.pdf > 0.f) {
        Vec3 wi = frame.to_local(ls.wi);
        Color f = bsdf.f(wo, wi);
        // Geometric side test too: no light through the surface itself.
        if (!is_black(f) && dot(ls.wi, n_out) > 0.f) {
          Ray shadow;
          shadow.o = origin;
          shadow.d = ls.wi;
          if (ls.dist < kInfinity) {
            Vec3 target = offset_ray_origin(ls.p, dot(ls.n, ls.wi) < 0.f ? ls.n : -ls.n);
            Vec3 d = target - shadow.o;
            float dist = length(d);
            shadow.d = d / dist;
            shadow.tmax = dist * (1.f - 1e-4f);
          }
          ++rays;
          if (!tracer.occluded(shadow)) {
            float pmf = scene.emitter_pmf[e];
            float light_pdf = pmf * ls.pdf;
            float w = use_mis ? power_heuristic(light_pdf, bsdf.pdf(wo, wi)) : 1.f;
            L += beta * f * ls.radiance * (fabsf(wi.z) * w / light_pdf);
          }
        }
      }
    }

    // BSDF sampling (its dimensions are fixed whether or not NEE ran).
    sampler.dim = kCameraDims + uint32_t(depth - 1) * kDimsPerVertex + 2;
    float u_bsdf = sampler.next_1d();
    Vec2 u_bsdf2 = sampler.next_2d();
    BsdfSample bs = bsdf.sample(wo, u_bsdf, u_bsdf2);
    if (!bs.valid) break;
    Vec3 wi_world = frame.to_world(bs.wi);
    // Reject continuations that cross the geometric surface the wrong way.
    if (dot(wi_world, n_out) <= 0.f) break;
    beta *= bs.weight;
    prev_pdf = bs.pdf;
    prev_p = it.p;

    // Russian roulette on the throughput.
    if (depth >= params.rr_depth) {
      float u_rr = sampler.next_1d();
      float q = min(max_component(beta), 0.95f);
      if (!(u_rr < q)) break;
      beta = beta / q;
    }
    ray.o = origin;
    ray.d = wi_world;
    ray.tmax = kInfinity;
  }
  return L;
}

}  // namespace luz
