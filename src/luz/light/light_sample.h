// What every light answers with, and what it is asked from.
#pragma once

#include "luz/light/env_guide.h"
#include "luz/math/vec.h"
#include "luz/texture/texture.h"

namespace luz {

// The shading point a light is sampled from (pbrt-v4's LightSampleContext):
// its position, and its geometric and shading normals where known (zero
// where not: a path's previous vertex keeps only its position).
struct LightSampleContext {
  Vec3 p, n, ns;
  // The hemisphere light can reach the point from, as its (unit) pole:
  // the viewer's side of a surface that only reflects. Zero: every
  // direction (a transmitting surface, or unknown).
  Vec3 hemisphere{};
};

// What lights read besides their own fields: the lights' shared float array
// (images and distributions, by offset), the scene's textures (textured
// emission) and the constant environment's guide. Made from a bare float
// array where no light is textured.
struct LightData {
  const float* floats = nullptr;
  TextureView textures;
  const EnvGuide* guide = nullptr;  // null: none
  LightData() = default;
  LUZ_INLINE LightData(const float* f) : floats(f) {}
};

// A sampled direction toward a light, as seen from a reference point.
struct LightSample {
  Vec3 wi;             // unit direction from the reference point toward the light
  float dist = 0;      // distance to the light point (infinite for infinite lights)
  Vec3 p, n;           // the light point and its normal (n zero for point lights)
  Color radiance;      // radiance arriving at the reference point (delta lights: its irradiance-like I / d²)
  float pdf = 0.f;     // solid-angle density at the reference point (selection excluded);
                       // delta lights: 1 (a discrete choice); 0: no sample
  bool delta = false;  // a delta light: no ray can hit it, so no MIS with BSDF sampling
};

// An emitted ray (pbrt-v4's LightLeSample): where light tracing and BDPT
// start a light path. A zero pdf_pos or pdf_dir: no sample.
struct LightLeSample {
  Vec3 p;          // ray origin: on the light, or for lights at infinity on the disk the rays enter through
  Vec3 d;          // unit direction of travel
  Vec3 n;          // the light point's emitting normal (zero for point lights and lights at infinity)
  Color radiance;  // along the ray; point and spot: intensity (W/sr); directional: irradiance (W/m²)
  float pdf_pos = 0.f;  // area density of p; 1 for a delta position (a discrete choice)
  float pdf_dir = 0.f;  // solid-angle density of d given p; 1 for a delta direction
  bool delta_pos = false, delta_dir = false;
};

// The densities with which sample_le emits a given ray (same measures and
// delta conventions as LightLeSample).
struct LightLePdf {
  float pdf_pos = 0.f, pdf_dir = 0.f;
};

// Where a ray reached a light's surface: what pdf_li needs besides the
// direction (the light point's normal and its distance from the reference).
struct LightHit {
  Vec3 n;
  float dist = 0.f;
};

}  // namespace luz
