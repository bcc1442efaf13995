// The path tracer, written once for the CPU and CUDA (seed §1.2.3, §2.5).
//
// At each vertex: emission (weighted by MIS against light sampling), next-event
// estimation (a light chosen by the LightSampler, a direction by its
// sample_li, a shadow ray), BSDF sampling, Russian roulette. Lights are
// reached only through light/light.h and light/light_sampler.h. `bsdf` and
// `light` are the two single-strategy estimators, kept to verify the
// combined one.
//
// Delta lights (point, spot, directional): found by next-event estimation
// only, their samples weighted 1 (no ray can find them, so no MIS density);
// the `bsdf` estimator does not see them.
//
// Depth follows Mitsuba: a path of depth k has k segments after the camera
// ray's origin, so max_depth 1 shows emitters only, 2 adds direct light.
// max_depth < 0 means unbounded (Russian roulette ends the path).
//
// Delta lobes (BsdfSample::delta: smooth mirrors, glass, the coat of smooth
// plastic). No light sample can find their one direction, so an emitter hit
// through a delta sample gets MIS weight 1 (the discrete probability in
// s.pdf never enters the power heuristic), and at a vertex whose BSDF is
// delta_only() next-event estimation is skipped (f and pdf are 0 there); its
// sampler dimensions stay reserved, so dimension d still means the same
// thing at every vertex. The `light` estimator (NEE only) counts an emitter
// hit with weight 0 after a non-delta sample (NEE at that vertex already
// counted it) and with weight 1 after a delta sample (Mitsuba's convention):
// every path is then counted exactly once, so it stays unbiased with
// mirrors and glass, caustics seen through delta chains included. On scenes
// without delta lobes it is NEE only, as before.
//
// Transmission (BsdfSample::transmission): the continuation starts on the
// far side of the geometric surface (its own robust offset) and must cross
// it; a reflected one must stay on the viewer's side. NEE at a surface with
// a transmissive BSDF sends shadow rays to either side, each offset to its
// side, and accepts a light direction only if the geometric and shading
// normals agree on whether it is reflection or transmission.
//
// Russian roulette, as Mitsuba 3: the survival probability is
// q = min(max(β) · η_acc², 0.95), η_acc the product of BsdfSample::eta
// (η on wi's side / η on wo's side) along the path. Radiance-mode BTDF
// weights carry 1/η² (dielectric.h), so β · η_acc² is the throughput without
// the solid-angle compression: a path entering glass is not killed more
// often merely because its radiance weight dropped by 1/η².
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

// The longest max_depth a scene or flag may ask (-1, unbounded, aside).
inline constexpr int kMaxDepthLimit = 1 << 20;

struct IntegratorParams {
  IntegratorType type = IntegratorType::Path;
  int max_depth = -1;
  int rr_depth = 5;  // Russian roulette from this depth on (Mitsuba's default)
  // Mitsuba's hide_emitters: emitters (the environment too) seen by the
  // camera directly count for nothing; seen through a bounce they do.
  bool hide_emitters = false;
};

// Counters for bench/efficiency's profile: rays by kind, what became of each
// next-event sample, Russian roulette and path ends by depth, and radiance by
// path length. A probe is a type of static hooks (its state its own, e.g.
// thread-local), so a call passes nothing more. The default, NoPathProbe,
// compiles every hook away: each call sits under `if constexpr
// (Probe::kEnabled)`, so a normal render runs the same instructions.
enum class RayKind : uint32_t { Camera, Continuation, Shadow };
enum class NeeOutcome : uint32_t {
  NoSample,      // pdf 0: an emitter facing away, or none to sample
  BelowSurface,  // the direction is below the geometric surface
  BsdfZero,      // f = 0 (below the shading hemisphere, for a diffuse BSDF)
  Occluded,      // the shadow ray hit something
  Contributed,
};
enum class PathEnd : uint32_t { Escaped, MaxDepth, BsdfInvalid, WrongSide, Roulette };
struct NoPathProbe {
  static constexpr bool kEnabled = false;
  static void ray(RayKind) {}
  static void nee(NeeOutcome) {}
  static void roulette(int, bool) {}
  static void end(int, PathEnd) {}
  static void radiance(int, const Color&) {}
};

// Sample dimensions: 0: the camera (camera_sample: the filter's 2D, and a
// lens's 2D as that dimension's second stream). Then, per vertex, a fixed block so
// that a dimension always means the same thing: light choice and point (2D),
// BSDF lobe (1D), BSDF direction (2D), Russian roulette (1D).
inline constexpr uint32_t kCameraDims = 1;
inline constexpr uint32_t kDimsPerVertex = 4;
// Sample reuse for the emitter choice only when the chosen emitter's pmf
// leaves its reused coordinate at least 2^16 distinct values.
inline constexpr float kMinReusePmf = 1.f / 256.f;

// What a path carries from one vertex to the next: all a wavefront keeps per
// path between its kernels (device/cuda/wavefront.h), besides its Sampler.
struct PathState {
  Ray ray;                     // the ray to trace next
  Color L{}, beta{1.f, 1.f, 1.f};
  float prev_pdf = 0.f;        // solid-angle pdf of the BSDF sample that made `ray`
  bool prev_delta = false;     // that sample came from a delta lobe
  float eta_acc = 1.f;         // product of BsdfSample::eta (Russian roulette)
  Vec3 prev_p;                 // where `ray` started
  Vec3 prev_ns;                // the shading normal there (zero at the camera): the light sampler's context
  Vec3 prev_hemisphere;        // and the hemisphere light reaches it from (LightSampleContext)
  float prev_light_sum = 0.f;  // its light sample's SampledLight::sum (the sky's pmf there)
  int depth = 1;               // the vertex `ray` will find
  bool alive = true;
};

// The shadow ray of one vertex's next-event estimate; `contrib` joins L when
// the segment is unoccluded (the OptiX any-hit query).
struct ShadowQuery {
  Ray ray;
  Color contrib;
  bool active = false;
};

// A vertex's random numbers that do not depend on what the ray hits: light
// 2D, BSDF direction 2D and Russian roulette 1D (the lobe choice is drawn
// only at a non-Lambertian vertex). path_li draws them before the
// closest-hit query of the ray that finds the vertex, so on the CPU their
// hash chains run while the traversal waits on memory.
struct VertexRandom {
  Vec2 light, dir;
  float rr = 0.f;
};

LUZ_FORCE_INLINE VertexRandom draw_vertex_random(const Sampler& sampler, int depth, const IntegratorParams& params) {
  const uint32_t base_dim = kCameraDims + uint32_t(depth - 1) * kDimsPerVertex;
  VertexRandom r;
  sampler.draw_2d_pair(base_dim, base_dim + 2, r.light, r.dir);
  if (depth >= params.rr_depth) r.rr = sampler.draw_1d(base_dim + 3, 0);
  return r;
}

// The ray is copied member by member: its caller wrote it so (the camera's
// floats), and a whole-struct copy's 16-byte loads would wait for those
// narrower stores to reach the cache instead of forwarding from them.
LUZ_INLINE PathState path_start(const Ray& ray) {
  PathState st;
  st.ray.o = ray.o;
  st.ray.d = ray.d;
  st.ray.tmax = ray.tmax;
  st.prev_p = ray.o;
  return st;
}

// One vertex, after the closest-hit query of st.ray gave (found, hit):
// emission (MIS-weighted), next-event estimation (its shadow ray left in sq),
// BSDF sampling for the next ray, Russian roulette. st.alive turns false
// when the path ends. The same code runs in path_li and in the wavefront's
// shade kernel.
// `u`: this vertex's draw_vertex_random.
// `Probe`: bench/efficiency's counters (none in a normal render).
// `kMaps`: false where no material has a normal or bump map
// (MaterialsView::mapped): the map's test and frame code leave the path
// loop, whose registers they crowd (the bundled box: 3% of its instructions).
template <class Probe = NoPathProbe, bool kMaps = true>
LUZ_FORCE_INLINE void path_vertex(const SceneView& scene, PathState& st, bool found, const Hit& hit, Sampler& sampler,
                                  const IntegratorParams& params, const VertexRandom& u, ShadowQuery& sq) {
  sq.active = false;
  const bool use_nee = params.type != IntegratorType::Bsdf;
  const bool use_mis = params.type == IntegratorType::Path;
  const int depth = st.depth;
  Ray& ray = st.ray;
  Color& L = st.L;
  Color& beta = st.beta;
  float& prev_pdf = st.prev_pdf;
  bool& prev_delta = st.prev_delta;
  float& eta_acc = st.eta_acc;
  Vec3& prev_p = st.prev_p;
  {
    const uint32_t base_dim = kCameraDims + uint32_t(depth - 1) * kDimsPerVertex;

    // Emission reached by the previous BSDF sample (or seen by the camera).
    // Its weight: 1 for the camera ray, for the bsdf estimator and after a
    // delta sample; otherwise 0 for the light estimator (NEE counted it) and
    // the power heuristic for path.
    const bool weigh = (depth > 1) & !prev_delta & (params.type != IntegratorType::Bsdf);  // no branches
    Color Le{};
    float light_pdf = 0.f;
    Interaction it;
    const LightsView& lights = scene.lights;
    // The context the previous vertex's light sample had (its p and ns, all
    // a light sampler reads), so that MIS weighs this hit by the same pmf.
    // Made only where a light was hit: most vertices never need it.
    if (!found) {
      if (lights.environment >= 0) {
        const Light& env = lights[uint32_t(lights.environment)];
        Le = le(env, ray.d, lights.data);
        if (!is_black(Le) && weigh && use_mis) {  // (weighed: the previous vertex sampled a light)
          const LightSampleContext prev_ctx{prev_p, {}, st.prev_ns, st.prev_hemisphere};
          light_pdf = lights.sampler.pmf_infinite(uint32_t(lights.environment), st.prev_light_sum) *
                      pdf_li(env, prev_ctx, ray.d, {}, lights.data);
        }
      }
    } else {
      it = scene.interaction(ray, hit);
      if (it.emitter >= 0) {
        const Light& light = lights[uint32_t(it.emitter)];
        Le = eval(light, it.ng, -ray.d, scene.hit_uv(hit, it.p), lights.data);
        if (!is_black(Le) && weigh && use_mis) {
          const LightSampleContext prev_ctx{prev_p, {}, st.prev_ns, st.prev_hemisphere};
          light_pdf = lights.sampler.pmf(prev_ctx, uint32_t(it.emitter)) * pdf_li(light, prev_ctx, ray.d, {it.ng, hit.t}, lights.data);
        }
      }
    }
    if (!is_black(Le) && ((depth > 1) | !params.hide_emitters)) {  // no branch for the flag
      float w = 1.f;
      if (weigh) {
        if (params.type == IntegratorType::Light) w = 0.f;
        else w = power_heuristic(prev_pdf, light_pdf);
      }
      L += beta * Le * w;
      if constexpr (Probe::kEnabled) Probe::radiance(depth, beta * Le * w);
    }
    if (!found || (params.max_depth >= 0 && depth >= params.max_depth)) {
      if constexpr (Probe::kEnabled) Probe::end(depth, found ? PathEnd::MaxDepth : PathEnd::Escaped);
      st.alive = false;
      return;
    }

    Bsdf textured{Uninitialized{}};  // written only for a textured material
    const Bsdf& bsdf = scene.bsdf(it, hit, textured);
    const Frame frame = scene.shading_frame<kMaps>(it, hit);  // a normal or bump map perturbs it and it.ns
    Vec3 wo = frame.to_local(-ray.d);
    // Rays leaving this vertex start on the side of the geometric surface
    // they go to: the viewer's side (n_out) for reflection, the other for
    // transmission, each with its own robust offset.
    const Vec3 n_out = dot(ray.d, it.ng) < 0.f ? it.ng : -it.ng;
    const Vec3 origin = offset_ray_origin(it.p, n_out);
    // Asked once: the Lambertian case (every Cornell box wall) then skips the
    // general model's dispatch and queries in f, pdf and sample.
    const bool plain = bsdf.plain_diffuse();
    const bool transmissive = !plain && bsdf.has_transmission();
    // Where light can come from: the viewer's side, unless the BSDF transmits.
    const Vec3 hemisphere = transmissive ? Vec3{} : n_out;

    // This vertex's random numbers at fixed dimensions (base_dim + 0: light
    // 2D, + 1: lobe 1D, + 2: direction 2D, + 3: Russian roulette 1D).
    const bool nee = use_nee && lights.sampler.n > 0 && (plain || !bsdf.delta_only());
    Vec2 u_light2 = u.light;  // its x may be replaced (sample reuse, below)
    float light_sum = 0.f;
    const float u_bsdf = plain ? 0.f : sampler.draw_1d(base_dim + 1, 0);  // Lambert: no lobe choice

    // Next-event estimation (not at delta-only vertices: f is 0 there).
    if (nee) {
      // One 2D draw: its first coordinate picks the emitter and is then
      // reused for the point on it (sample reuse, as Mitsuba 3 does). The
      // reused coordinate keeps about 2^24 · pmf distinct values: for an
      // emitter chosen with pmf < 2^-8 it would be too coarse (a bias from
      // quantised points), so that case takes a fresh value instead.
      const LightSampleContext ctx{it.p, it.ng, it.ns, hemisphere};
      const SampledLight sl = lights.sampler.sample(ctx, u_light2.x);
      light_sum = sl.sum;
      if (sl.pmf < kMinReusePmf) u_light2.x = sampler.aux_1d(base_dim);
      const LightSample ls = sample_li(lights[sl.light], ctx, u_light2, lights.data);
      if (ls.pdf > 0.f && sl.pmf > 0.f) {
        Vec3 wi = frame.to_local(ls.wi);
        const Color f = plain ? bsdf.f_diffuse(wo, wi) : bsdf.f_general(wo, wi, TransportMode::Radiance);
        // Geometric side test too: no light through a reflecting surface, and
        // for transmissive ones the geometric and shading sides must agree.
        const float side = dot(ls.wi, n_out);
        const bool geo_ok = transmissive ? (side > 0.f) == (wo.z * wi.z > 0.f) && side != 0.f : side > 0.f;
        if constexpr (Probe::kEnabled)
          if (!geo_ok || is_black(f)) Probe::nee(!geo_ok ? NeeOutcome::BelowSurface : NeeOutcome::BsdfZero);
        if (!is_black(f) && geo_ok) {
          Ray shadow;
          shadow.o = side > 0.f ? origin : offset_ray_origin(it.p, -n_out);
          shadow.d = ls.wi;
          if (ls.dist < kInfinity) {
            // The segment between the two offset ends (Wächter–Binder: no
            // shrink needed; a point light's end is the point itself),
            // unnormalised: t in (0, 1), no square root or division before
            // the query can start.
            Vec3 target = ls.delta ? ls.p : offset_ray_origin(ls.p, dot(ls.n, ls.wi) < 0.f ? ls.n : -ls.n);
            shadow.d = target - shadow.o;
            shadow.tmax = 1.f;
          }
          // Joins L if the segment is unoccluded (ShadowQuery).
          const float light_pdf = sl.pmf * ls.pdf;
          const float bsdf_pdf = plain ? bsdf.pdf_diffuse(wo, wi) : bsdf.pdf_general(wo, wi);
          const float w_over_pdf =
              use_mis && !ls.delta ? power_heuristic_over_a(light_pdf, bsdf_pdf) : 1.f / light_pdf;
          sq.ray = shadow;
          sq.contrib = beta * f * ls.radiance * (fabsf(wi.z) * w_over_pdf);
          sq.active = true;
        }
      } else if constexpr (Probe::kEnabled) {
        Probe::nee(NeeOutcome::NoSample);
      }
    }

    // BSDF sampling.
    BsdfSample bs = plain ? bsdf.sample_diffuse(wo, u_bsdf, u.dir)
                          : bsdf.sample_general(wo, u_bsdf, u.dir, TransportMode::Radiance);
    if (!bs.valid) {
      if constexpr (Probe::kEnabled) Probe::end(depth, PathEnd::BsdfInvalid);
      st.alive = false;
      return;
    }
    Vec3 wi_world = frame.to_world(bs.wi);
    // Reject continuations that cross the geometric surface the wrong way:
    // reflection stays on the viewer's side, transmission crosses.
    const float side = dot(wi_world, n_out);
    if (bs.transmission ? !(side < 0.f) : !(side > 0.f)) {
      if constexpr (Probe::kEnabled) Probe::end(depth, PathEnd::WrongSide);
      st.alive = false;
      return;
    }
    beta *= bs.weight;
    prev_pdf = bs.pdf;
    prev_delta = bs.delta;
    prev_p = it.p;
    st.prev_ns = it.ns;
    st.prev_hemisphere = hemisphere;
    st.prev_light_sum = light_sum;
    if (bs.transmission) eta_acc *= bs.eta;

    // Russian roulette on the throughput without the η² of refraction.
    if (depth >= params.rr_depth) {
      float q = min(max_component(beta) * eta_acc * eta_acc, 0.95f);
      if constexpr (Probe::kEnabled) Probe::roulette(depth, u.rr < q);
      if (!(u.rr < q)) {
        if constexpr (Probe::kEnabled) Probe::end(depth, PathEnd::Roulette);
        st.alive = false;
        return;
      }
      beta = beta / q;
    }
    ray.o = bs.transmission ? offset_ray_origin(it.p, -n_out) : origin;
    ray.d = wi_world;
    ray.tmax = kInfinity;
    st.depth = depth + 1;
  }
}

// The path tracer: one path, vertex by vertex. A vertex's shadow ray is
// traced after the next vertex's closest-hit query, not before it: the next
// ray needs only the BSDF sample, so the query starts while next-event
// estimation's longer chain (square roots, divisions, the MIS weight) is
// still completing (luz_bench, bundled box, 1 thread: paired ratio 0.52 ->
// 0.55). Returns the radiance; `rays` counts every query. `Probe` and
// `kMaps`: as path_vertex's.
template <class Tracer, class Probe = NoPathProbe, bool kMaps = true>
LUZ_DEVICE_FORCE_INLINE Color path_li(const SceneView& scene, const Tracer& tracer, const Ray& ray, Sampler& sampler,
                              const IntegratorParams& params, uint64_t& rays) {
  PathState st = path_start(ray);
  ShadowQuery sq;  // the previous vertex's
  [[maybe_unused]] int sq_length = 0;  // its path's length (the probe's)
  auto trace_shadow = [&] {
    if (!sq.active) return;
    ++rays;
    const bool blocked = tracer.occluded(sq.ray);
    if (!blocked) st.L += sq.contrib;
    if constexpr (Probe::kEnabled) {
      Probe::ray(RayKind::Shadow);
      Probe::nee(blocked ? NeeOutcome::Occluded : NeeOutcome::Contributed);
      if (!blocked) Probe::radiance(sq_length, sq.contrib);
    }
  };
  while (st.alive) {
    Hit hit;
    ++rays;
    if constexpr (Probe::kEnabled) Probe::ray(st.depth == 1 ? RayKind::Camera : RayKind::Continuation);
    const VertexRandom u = draw_vertex_random(sampler, st.depth, params);
    bool found = tracer.intersect(st.ray, hit);
    // A textured hit's texels are fetched while the shadow query runs
    // (staircase, 2 threads: 0.523 -> 0.566 Msamples/s; untextured: no change).
    if (found) scene.prefetch_texture(st.ray, hit);
    trace_shadow();
    if constexpr (Probe::kEnabled) sq_length = st.depth + 1;
    path_vertex<Probe, kMaps>(scene, st, found, hit, sampler, params, u, sq);
  }
  trace_shadow();
  return st.L;
}

}  // namespace luz
