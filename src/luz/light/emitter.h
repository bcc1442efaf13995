// Emitters: diffuse area lights on triangles and spheres (one-sided, emitting
// on the side of the geometric normal), and the constant environment.
#pragma once

#include "luz/geometry/shapes.h"
#include "luz/sampling/warp.h"

namespace luz {

// Parallelogram: two emitter triangles of one mesh that form a parallelogram
// (a quad light: an OBJ quad, Mitsuba's rectangle), merged by Scene::compile
// and sampled as one (a single 2D point, no square-root warp, no choice
// between the halves).
enum class EmitterType : uint32_t { Triangle, Sphere, Constant, Parallelogram };

struct Emitter {
  EmitterType type = EmitterType::Triangle;
  uint32_t prim = 0;   // triangle or sphere index (a parallelogram: its first triangle)
  uint32_t prim2 = 0;  // a parallelogram's second triangle
  Color radiance;
  // Triangles: unit normal (the emitting side) and area, set by Scene::compile()
  // so that light sampling does not recompute them at every vertex.
  Vec3 normal;
  float area = 0.f;
  Vec3 v0, v1, v2;  // the triangle's vertices, copied: no index look-ups when sampling;
                    // a parallelogram's corner v0 and its edges v1, v2 (points v0 + u v1 + v v2)
};

// A sampled point on an emitter as seen from a reference point.
struct LightSample {
  Vec3 wi;          // unit direction from the reference point toward the light
  float dist = 0;   // distance to the light point (infinite for the environment)
  Vec3 p, n;        // the light point and its normal (area lights)
  Color radiance;   // emitted radiance toward the reference point
  float pdf = 0.f;  // solid-angle density at the reference point (selection excluded)
};

}  // namespace luz
