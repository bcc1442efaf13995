// Alpha testing (Mitsuba's `mask`): a hit on a surface of opacity a < 1 is
// kept with probability a and otherwise does not exist, for every ray alike
// (camera, continuation and shadow rays). The tracers run the test while
// traversing (the any-hit role: an Embree filter function on the CPU,
// bvh_traverse in Luz's BVH), so a cut-away hit costs no bounce and no new
// ray. The test is stochastic, as pbrt-v4's GeometricPrimitive::Intersect:
// a hash of the ray, uniform in [0, 1), against a, so that a fractional
// opacity is unbiased; 0 always cuts, 1 never. The hash also takes the
// primitive, so that layers along one ray are tested independently (pbrt-v4
// hashes the ray alone).
// Mitsuba 3's mask is a BSDF whose transparent part is a forward delta lobe:
// its `path` counts passing a mask as a bounce toward max_depth and stops
// shadow rays at masks. Luz's estimate has the same expectation, except
// where max_depth truncates paths that pass masks.
#pragma once

#include "luz/geometry/shapes.h"
#include "luz/material/material.h"
#include "luz/math/hash.h"

namespace luz {

// Texture coordinates at a triangle hit, interpolated with the hit's own
// barycentrics ((0, 0) without uvs).
LUZ_FORCE_INLINE Vec2 triangle_uv(const Vec2* uvs, const uint32_t* indices, const Hit& hit) {
  if (!uvs) return {};
  const Vec2 t0 = uvs[indices[3 * hit.prim]], t1 = uvs[indices[3 * hit.prim + 1]], t2 = uvs[indices[3 * hit.prim + 2]];
  const float b0 = 1.f - hit.u - hit.v;
  return {t0.x * b0 + t1.x * hit.u + t2.x * hit.v, t0.y * b0 + t1.y * hit.u + t2.y * hit.v};
}

// The vertex colour at a triangle hit, interpolated as triangle_uv (white
// without colours).
LUZ_FORCE_INLINE Color triangle_color(const Color* colors, const uint32_t* indices, const Hit& hit) {
  if (!colors) return {1.f, 1.f, 1.f};
  const uint32_t* v = indices + 3 * size_t(hit.prim);
  return colors[v[0]] * (1.f - hit.u - hit.v) + colors[v[1]] * hit.u + colors[v[2]] * hit.v;
}

// The vertex colour at a hit (white on a sphere).
LUZ_FORCE_INLINE Color hit_color(const Color* colors, const uint32_t* indices, const Hit& hit) {
  if (hit.kind == PrimKind::Sphere) return {1.f, 1.f, 1.f};
  return triangle_color(colors, indices, hit);
}

// Texture coordinates at a hit: a triangle's interpolated, a sphere's at the
// hit's point p (sphere_uv).
LUZ_FORCE_INLINE Vec2 hit_uv(const Vec2* uvs, const uint32_t* indices, const Sphere* spheres, const Hit& hit, Vec3 p) {
  if (hit.kind == PrimKind::Sphere) return sphere_uv(spheres[hit.prim], p);
  return triangle_uv(uvs, indices, hit);
}

// What the alpha test reads: the SceneView's arrays (SceneView::opacity()).
// materials null: no material is masked, and the tracers skip the test.
struct OpacityView {
  const Material* materials = nullptr;
  const uint32_t* tri_material = nullptr;
  const uint32_t* indices = nullptr;
  const Vec2* uvs = nullptr;
  const Sphere* spheres = nullptr;
  TextureView textures;
  const Color* colors = nullptr;

  // Opacity at the hit of the ray (o, d), in [0, 1] (the loader refuses
  // texels above 1).
  LUZ_INLINE float opacity(Vec3 o, Vec3 d, const Hit& hit) const {
    const Material& m =
        materials[hit.kind == PrimKind::Triangle ? tri_material[hit.prim] : spheres[hit.prim].material];
    if (m.opacity_texture < 0) return m.opacity;
    const float a = luminance(textures.eval(uint32_t(m.opacity_texture), hit_uv(uvs, indices, spheres, hit, o + d * hit.t),
                                            hit_color(colors, indices, hit)));
    return m.alpha_cutoff < 0.f ? a : (a >= m.alpha_cutoff ? 1.f : 0.f);
  }

  // Does the hit of the ray (o, d) on this primitive exist?
  LUZ_INLINE bool keeps(Vec3 o, Vec3 d, const Hit& hit) const {
    const float a = opacity(o, d, hit);
    if (a >= 1.f) return true;
    if (!(a > 0.f)) return false;
    const uint64_t h = hash4((uint64_t(float_bits(o.x)) << 32) | float_bits(o.y),
                             (uint64_t(float_bits(o.z)) << 32) | float_bits(d.x),
                             (uint64_t(float_bits(d.y)) << 32) | float_bits(d.z),
                             (uint64_t(hit.kind == PrimKind::Sphere) << 32) | hit.prim);
    return to_unit_float(h) < a;
  }
};

}  // namespace luz
