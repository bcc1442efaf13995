// The wavefront variant of a CUDA pass (Laine, Karras & Aila 2013, "Megakernels
// considered harmful"), written once for the device and the host: instead of
// one thread running a whole path (pass.h), each stage is its own kernel over
// all the pass's paths, with the path state in memory between them:
//
//   generate    camera ray and Sampler of path i          (RAY GENERATION)
//   intersect   closest hit of every live path's ray      (CLOSEST HIT)
//   shade       path_vertex: emission, NEE's shadow ray,
//               BSDF sample, Russian roulette               (the shading)
//   shadow      occlusion of every pending shadow ray     (ANY HIT)
//   accumulate  per pixel, the pass's samples in order into the output
//
// intersect / shade / shadow repeat until no path is alive. Path i of a pass
// is pixel i mod P (P pixels) at sample first_sample + i / P, so a warp
// holds neighbouring pixels. The same path_vertex as path_li and the same
// random numbers: the output equals render_pixel_pass's with one thread per
// pixel, but for float rounding. No compaction and no sorting by material:
// dead paths return at once (the figures in bench/RESULTS.md say what this
// costs against the megakernel).
#pragma once

#include "luz/device/cuda/pass.h"

namespace luz {

struct WavefrontParams {
  PassParams pass;  // threads_per_pixel must be 1: the output has one slice
  uint32_t num_paths = 0;  // pixels × pass.num_samples
  PathState* state = nullptr;
  Sampler* sampler = nullptr;
  Hit* hit = nullptr;
  uint8_t* found = nullptr;
  ShadowQuery* shadow = nullptr;
};

LUZ_INLINE void wf_generate(const WavefrontParams& p, uint32_t i) {
  const Camera& cam = p.pass.scene.camera;
  const uint32_t pixels = uint32_t(cam.width) * uint32_t(cam.height);
  const uint32_t pixel = i % pixels, k = i / pixels;
  const uint32_t x = pixel % uint32_t(cam.width), y = pixel / uint32_t(cam.width);
  Sampler s;
  s.start(p.pass.sampler, x, y, p.pass.first_sample + k);
  p.state[i] = path_start(camera_sample(cam, x, y, s, p.pass.filter));
  p.sampler[i] = s;
  p.shadow[i].active = false;
}

// The stages below come in pass.h's two variants (kFull), chosen as the
// megakernel's, so both run the same vertex code.

// Returns the rays traced (0 or 1).
template <bool kFull = true>
LUZ_INLINE uint32_t wf_intersect(const WavefrontParams& p, uint32_t i) {
  if (!p.state[i].alive) return 0;
  Hit h;
  p.found[i] = BvhQueries<kFull>{p.pass.tracer}.intersect(p.state[i].ray, h) ? 1 : 0;
  p.hit[i] = h;
  return 1;
}

// Returns whether path i lives on.
template <bool kFull = true>
LUZ_INLINE bool wf_shade(const WavefrontParams& p, uint32_t i) {
  PathState& st = p.state[i];
  if (!st.alive) return false;
  path_vertex<NoPathProbe, kFull>(p.pass.scene, st, p.found[i] != 0, p.hit[i], p.sampler[i], p.pass.integrator,
                                  draw_vertex_random(p.sampler[i], st.depth, p.pass.integrator), p.shadow[i]);
  return st.alive;
}

// Returns the rays traced (0 or 1).
template <bool kFull = true>
LUZ_INLINE uint32_t wf_shadow(const WavefrontParams& p, uint32_t i) {
  ShadowQuery& sq = p.shadow[i];
  if (!sq.active) return 0;
  if (!BvhQueries<kFull>{p.pass.tracer}.occluded(sq.ray)) p.state[i].L += sq.contrib;
  sq.active = false;
  return 1;
}

// Pixel `pixel`'s samples of the pass, in order, as render_pixel_pass sums them.
LUZ_INLINE void wf_accumulate(const WavefrontParams& p, uint32_t pixel) {
  const Camera& cam = p.pass.scene.camera;
  const uint32_t pixels = uint32_t(cam.width) * uint32_t(cam.height);
  PassSums sums;
  for (uint32_t k = 0; k < p.pass.num_samples; ++k) sums.add(p.state[size_t(k) * pixels + pixel].L);
  sums.write(p.pass.out, pixel);
}

}  // namespace luz
