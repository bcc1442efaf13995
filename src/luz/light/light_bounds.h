// What a light BVH knows of a light or a group of lights (Conty Estevez and
// Kulla 2018, "Importance Sampling of Many Lights with Adaptive Tree
// Splitting"; pbrt-v4's LightBounds): where they are (a box), how strongly
// they emit (phi), and toward where (a cone of normals of axis w and half
// angle θo, each normal's emission spread θe around it). The BVH weighs them
// at a shading point by BvhLightSampler::importances (light_bvh.h).
#pragma once

#include <cmath>

#include "luz/math/vec.h"

namespace luz {

struct LightBounds {
  Vec3 lo, hi;  // world-space box
  Vec3 w;       // unit axis of the normals' cone
  // A bound on the radiant intensity (W/sr) toward any direction the lights
  // emit into: I for point and spot lights, L·A for planar ones (their
  // intensity along the normal), L·πr² for spheres. Sums over a group.
  float phi = 0.f;
  float cos_theta_o = 1.f;  // the normals' cone
  float cos_theta_e = 0.f;  // emission around each normal (0: a hemisphere)
  bool two_sided = false;
};

// The smallest cone pbrt-v4's DirectionCone Union finds around two cones
// (axes unit, cos θ = -1: every direction).
inline void cone_union(Vec3 wa, float cos_a, Vec3 wb, float cos_b, Vec3& w, float& cos_o) {
  const double theta_a = std::acos(std::fmin(std::fmax(double(cos_a), -1.0), 1.0));
  const double theta_b = std::acos(std::fmin(std::fmax(double(cos_b), -1.0), 1.0));
  const double theta_d = std::acos(std::fmin(std::fmax(double(dot(wa, wb)), -1.0), 1.0));
  if (std::fmin(theta_d + theta_b, M_PI) <= theta_a) {
    w = wa;
    cos_o = cos_a;
    return;
  }
  if (std::fmin(theta_d + theta_a, M_PI) <= theta_b) {
    w = wb;
    cos_o = cos_b;
    return;
  }
  const double theta_o = 0.5 * (theta_a + theta_d + theta_b);
  const Vec3 k = cross(wa, wb);
  const float lk = length(k);
  if (theta_o >= M_PI || !(lk > 0.f)) {
    w = wa;
    cos_o = -1.f;
    return;
  }
  // wa rotated by θo - θa toward wb, about k (Rodrigues; k ⟂ wa).
  const double theta_r = theta_o - theta_a;
  const Vec3 axis = k / lk;
  w = normalize(wa * float(std::cos(theta_r)) + cross(axis, wa) * float(std::sin(theta_r)));
  cos_o = float(std::cos(theta_o));
}

// The bounds of two groups together (pbrt-v4's Union of LightBounds). A group
// with no power adds nothing.
inline LightBounds bounds_union(const LightBounds& a, const LightBounds& b) {
  if (!(a.phi > 0.f)) return b;
  if (!(b.phi > 0.f)) return a;
  LightBounds u;
  u.lo = vmin(a.lo, b.lo);
  u.hi = vmax(a.hi, b.hi);
  u.phi = a.phi + b.phi;
  cone_union(a.w, a.cos_theta_o, b.w, b.cos_theta_o, u.w, u.cos_theta_o);
  u.cos_theta_e = std::fmin(a.cos_theta_e, b.cos_theta_e);
  u.two_sided = a.two_sided || b.two_sided;
  return u;
}

}  // namespace luz
