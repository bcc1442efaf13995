// Builds an EnvGuide (env_guide.h) before a render, host only. A pilot of
// camera paths finds where the render's next-event estimates will be made;
// from each such vertex, rays drawn by the cosine about its surface's
// viewer-side normal find which directions reach the environment. A
// region's distribution is its count of escaping rays per bin, so
// proportional to the cosine-weighted visible solid angle.
//
// Kept only where it pays (bench/RESULTS.md, "The constant environment
// guided"): a scene where most of the pilot's rays escape (outdoors) gets no
// guide, found from the first eighth of the pilot, so it costs such a scene
// about 1% of its render; nor does a region where half its rays escape or
// too few do to shape a distribution.
//
// Deterministic: every random number is a hash of the path, vertex and ray
// indices, and the counts are integers added in a fixed order, so the guide
// (and so the image) is the same for any thread count, on every MPI rank and
// on resume.
#pragma once

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <vector>

#include "luz/geometry/shapes.h"
#include "luz/light/env_guide.h"
#include "luz/light/light.h"
#include "luz/math/hash.h"
#include "luz/sampling/sampler.h"
#include "luz/sampling/warp.h"
#include "luz/scene/scene_view.h"

namespace luz {

struct EnvGuideOptions {
  uint32_t pilot_paths = 1u << 16;
  int depth = 5;                 // vertices per pilot path, at most
  float scene_escaped = 0.3f;    // no guide where this fraction of the first eighth's rays escape, or more
  uint32_t min_escaped = 8;      // a region's distribution needs this many escaping rays
  float region_escaped = 0.5f;   // and less than this fraction escaping (else the cosine does as well)
  float mix = 0.85f;
  uint64_t seed = 0x67756964;
};

// The pilot for a render of `pixel_samples` (every pixel's spp, the whole
// render's however it is split): 1/64 of them, from 2^13 to 2^17 paths.
inline EnvGuideOptions env_guide_options(uint64_t pixel_samples) {
  EnvGuideOptions o;
  o.pilot_paths = uint32_t(std::clamp<uint64_t>(pixel_samples / 64, uint64_t(1) << 13, uint64_t(1) << 17));
  return o;
}

// Whether a render builds a guide: asked for, and the environment constant.
inline bool wants_env_guide(const SceneView& v, bool asked) {
  return asked && v.lights.environment >= 0 && v.lights[uint32_t(v.lights.environment)].type == LightType::Constant;
}

// The guide's arrays, and `view` pointing into them (a move keeps it valid).
struct EnvGuideData {
  std::vector<int32_t> regions;
  std::vector<float> cdf;
  EnvGuide view;                 // regions null: no guide
  uint64_t rays = 0;             // traced to build it
  double escaped_fraction = 0;   // of the pilot's visibility rays (of its first eighth without a guide)

  EnvGuideData() = default;
  EnvGuideData(EnvGuideData&&) = default;
  EnvGuideData& operator=(EnvGuideData&&) = default;
  EnvGuideData(const EnvGuideData&) = delete;
  uint32_t distributions() const { return uint32_t(cdf.size() / EnvGuide::kBins); }
};

namespace env_guide_detail {

inline constexpr int kRays = 16;            // visibility rays per vertex
inline constexpr uint8_t kBlocked = 0xff;   // a ray that found geometry
static_assert(EnvGuide::kBins < kBlocked);

inline float unit(uint64_t seed, uint64_t a, uint64_t b) { return to_unit_float(hash4(seed, a, b, 0x6e76)); }

struct Vertex {
  Vec3 p, pole;            // pole zero: no vertex
  uint8_t bins[kRays];     // each visibility ray's bin, or kBlocked
};

}  // namespace env_guide_detail

// For a scene whose environment is constant (wants_env_guide); runs its
// parallel loops in the caller's TBB arena. `grid`: cells along the longest
// side of the pilot vertices' bounds.
template <class Tracer>
EnvGuideData build_env_guide(const SceneView& scene, const Tracer& tracer, const EnvGuideOptions& o, int grid = 24) {
  using namespace env_guide_detail;
  EnvGuideData g;
  const uint32_t n_paths = std::max(o.pilot_paths, 8u);
  const int depth = std::max(o.depth, 1);
  std::vector<Vertex> verts(size_t(n_paths) * depth);
  std::atomic<uint64_t> rays{0};
  const Camera& cam = scene.camera;

  // Pilot paths [a, b): spread over the film, continued by BSDF
  // sampling; each vertex where the path tracer would estimate light from
  // one side sends its visibility rays.
  auto pilot = [&](uint32_t a, uint32_t b) {
    tbb::parallel_for(a, b, [&](uint32_t i) {
      uint64_t n_rays = 0;
      auto u = [&](uint32_t k) { return unit(o.seed, i, k); };
      // A (0, 2)-sequence over the film: its first eighth covers it too.
      const float fx = to_unit_float32(scrambled_sobol_dim0(i, uint32_t(o.seed))) * float(cam.width);
      const float fy = to_unit_float32(scrambled_sobol_dim1(i, uint32_t(o.seed >> 32))) * float(cam.height);
      Ray ray = cam.generate_ray(fx, fy, {u(2), u(3)});
      for (int v = 0; v < depth; ++v) {
        Hit hit;
        ++n_rays;
        if (!tracer.intersect(ray, hit)) break;
        Interaction it = scene.interaction(ray, hit);
        Bsdf textured{Uninitialized{}};
        const Bsdf& bsdf = scene.bsdf(it, hit, textured);
        const Frame frame = scene.shading_frame(it, hit);
        const Vec3 n_out = dot(ray.d, it.ng) < 0.f ? it.ng : -it.ng;
        if (bsdf.plain_diffuse() || (!bsdf.has_transmission() && !bsdf.delta_only())) {
          Vertex& vx = verts[size_t(i) * depth + v];
          vx.p = it.p;
          vx.pole = n_out;
          const Frame around = Frame::from_normal(n_out);
          Ray vis;
          vis.o = offset_ray_origin(it.p, n_out);
          for (int j = 0; j < kRays; ++j) {
            const uint64_t key = (uint64_t(i) * uint64_t(depth) + uint64_t(v)) * kRays + uint64_t(j);
            vis.d = around.to_world(square_to_cosine_hemisphere({unit(~o.seed, key, 0), unit(~o.seed, key, 1)}));
            vis.tmax = kInfinity;
            vx.bins[j] = tracer.occluded(vis) ? kBlocked : uint8_t(EnvGuide::bin_of(vis.d));
          }
          n_rays += kRays;
        }
        const uint32_t k = 4 + 3 * uint32_t(v);
        const BsdfSample bs = bsdf.sample(frame.to_local(-ray.d), u(k), {u(k + 1), u(k + 2)}, TransportMode::Radiance);
        if (!bs.valid) break;
        const Vec3 wi = frame.to_world(bs.wi);
        const float s = dot(wi, n_out);
        if (bs.transmission ? !(s < 0.f) : !(s > 0.f)) break;
        ray.o = offset_ray_origin(it.p, bs.transmission ? -n_out : n_out);
        ray.d = wi;
        ray.tmax = kInfinity;
      }
      rays += n_rays;
    });
  };
  auto has = [](const Vertex& v) { return dot(v.pole, v.pole) > 0.f; };
  auto escaped_fraction = [&](size_t vertex_end) {
    uint64_t esc = 0, all = 0;
    for (size_t k = 0; k < vertex_end; ++k)
      if (has(verts[k])) {
        all += kRays;
        for (uint8_t b : verts[k].bins) esc += b != kBlocked;
      }
    return all ? double(esc) / double(all) : 1.0;
  };

  // The first eighth decides whether the rest is worth tracing.
  const uint32_t first = std::max(n_paths / 8, 1u);
  pilot(0, first);
  g.escaped_fraction = escaped_fraction(size_t(first) * depth);
  if (g.escaped_fraction >= double(o.scene_escaped)) {
    g.rays = rays;
    return g;
  }
  pilot(first, n_paths);
  g.rays = rays;
  g.escaped_fraction = escaped_fraction(verts.size());

  // The grid over the vertices' bounds.
  Vec3 lo{kInfinity, kInfinity, kInfinity}, hi = -lo;
  for (const Vertex& v : verts)
    if (has(v)) lo = vmin(lo, v.p), hi = vmax(hi, v.p);
  const Vec3 ext = hi - lo;
  const float cell = std::max({ext.x, ext.y, ext.z, 1e-6f}) / float(grid);
  auto cells = [&](float e) { return std::clamp(int(std::ceil(e / cell)), 1, grid); };
  EnvGuide& view = g.view;
  view.nx = cells(ext.x), view.ny = cells(ext.y), view.nz = cells(ext.z);
  view.lo = lo;
  view.inv_cell = {float(view.nx) / std::max(ext.x, 1e-6f), float(view.ny) / std::max(ext.y, 1e-6f),
                   float(view.nz) / std::max(ext.z, 1e-6f)};
  view.mix = o.mix;

  // Each vertex's region by the view's own lookup (with every entry its own
  // key, find() gives the key), then its escaping rays counted there.
  g.regions.resize(size_t(view.nx) * view.ny * view.nz * EnvGuide::kSides);
  for (size_t k = 0; k < g.regions.size(); ++k) g.regions[k] = int32_t(k);
  view.regions = g.regions.data();
  std::vector<uint32_t> counts, traced;
  std::vector<int32_t> index(g.regions.size(), -1);  // key -> a counted region
  for (const Vertex& v : verts) {
    if (!has(v)) continue;
    int32_t& r = index[size_t(view.find(v.p, v.pole))];
    if (r < 0) {
      r = int32_t(traced.size());
      traced.push_back(0);
      counts.resize(counts.size() + EnvGuide::kBins, 0);
    }
    traced[size_t(r)] += kRays;
    for (uint8_t b : v.bins)
      if (b != kBlocked) ++counts[size_t(r) * EnvGuide::kBins + b];
  }

  // Distributions where they pay.
  for (size_t key = 0; key < g.regions.size(); ++key) {
    g.regions[key] = -1;
    const int32_t r = index[key];
    if (r < 0) continue;
    const uint32_t* c = &counts[size_t(r) * EnvGuide::kBins];
    uint64_t total = 0;
    for (int b = 0; b < EnvGuide::kBins; ++b) total += c[b];
    if (total < o.min_escaped || double(total) >= double(o.region_escaped) * double(traced[size_t(r)])) continue;
    g.regions[key] = int32_t(g.distributions());
    uint64_t acc = 0;
    for (int b = 0; b < EnvGuide::kBins; ++b) {
      acc += c[b];
      g.cdf.push_back(b == EnvGuide::kBins - 1 ? 1.f : float(double(acc) / double(total)));
    }
  }
  if (g.cdf.empty()) {
    g.regions.clear();
    view = {};
    return g;
  }
  view.regions = g.regions.data();
  view.cdf = g.cdf.data();
  return g;
}

}  // namespace luz
