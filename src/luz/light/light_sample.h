// What every light answers with, and what it is asked from.
#pragma once

#include "luz/math/vec.h"

namespace luz {

// The shading point a light is sampled from (pbrt-v4's LightSampleContext):
// its position, and its geometric and shading normals where known (zero
// where not: a path's previous vertex keeps only its position).
struct LightSampleContext {
  Vec3 p, n, ns;
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

// Where a ray reached a light's surface: what pdf_li needs besides the
// direction (the light point's normal and its distance from the reference).
struct LightHit {
  Vec3 n;
  float dist = 0.f;
};

}  // namespace luz
