// SceneView: the scene as plain arrays and indices, valid on the CPU or copied
// to the GPU as is. Everything the integrator asks of the scene besides ray
// queries lives here.
#pragma once

#include <new>
#include <type_traits>

#include "luz/bsdf/bsdf.h"
#include "luz/camera/camera.h"
#include "luz/light/emitter.h"
#include "luz/texture/texture.h"

namespace luz {

// Room for a textured material's resolved copy (SceneView::material). A
// union with an empty constructor: declaring one on every path vertex costs
// nothing (a Bsdf's default constructor would store its defaults each time);
// the copy is placement-new'ed into it when used, which starts the member's
// lifetime (Bsdf's default member initialisers make it non-trivial to default
// construct, so a plain assignment would not).
union BsdfScratch {
  Bsdf bsdf;
  LUZ_INLINE BsdfScratch() {}
};
static_assert(std::is_trivially_copyable_v<Bsdf> && std::is_trivially_destructible_v<Bsdf>,
              "BsdfScratch neither destroys its Bsdf nor copies it member-wise");

struct SceneView {
  // Triangles: all meshes merged; triangle k uses indices[3k..3k+2].
  const Vec3* positions = nullptr;
  const Vec3* normals = nullptr;  // per vertex, or null: flat shading
  const uint32_t* indices = nullptr;
  const uint32_t* tri_material = nullptr;
  const int32_t* tri_emitter = nullptr;  // -1: not emissive
  const Vec2* uvs = nullptr;             // texture coordinates per vertex, or null: none
  // Unit geometric normal per triangle, or null: computed at each hit. The
  // CPU keeps them (the normalisation's square root and division leave the
  // start of every vertex: 1-3% less time on the Cornell box, 12 bytes per
  // triangle); the GPU computes them.
  const Vec3* tri_normals = nullptr;
  uint32_t num_triangles = 0;

  const Sphere* spheres = nullptr;
  uint32_t num_spheres = 0;

  const Bsdf* materials = nullptr;
  uint32_t num_materials = 0;

  // Bitmap textures (texture.h), referenced by Bsdf::texture.
  const TextureDesc* textures = nullptr;
  const uint32_t* texels = nullptr;
  const float* srgb_table = nullptr;  // 256 entries
  uint32_t num_textures = 0;

  // Emitters, chosen for next-event estimation in proportion to their power:
  // emitter_cdf[k] = P(choose one of 0..k); emitter_pmf[k] = P(choose k).
  const Emitter* emitters = nullptr;
  const float* emitter_cdf = nullptr;
  const float* emitter_pmf = nullptr;
  uint32_t num_emitters = 0;
  int32_t environment = -1;  // index of the constant environment emitter, or -1

  Camera camera;
  Vec3 bounds_center;
  float bounds_radius = 1.f;

  LUZ_INLINE void triangle(uint32_t k, Vec3& p0, Vec3& p1, Vec3& p2) const {
    p0 = positions[indices[3 * k]];
    p1 = positions[indices[3 * k + 1]];
    p2 = positions[indices[3 * k + 2]];
  }

  LUZ_INLINE Vec3 triangle_normal(uint32_t k) const {
    Vec3 p0, p1, p2;
    triangle(k, p0, p1, p2);
    return normalize(cross(p1 - p0, p2 - p0));
  }

  LUZ_FORCE_INLINE Interaction interaction(const Ray& ray, const Hit& hit) const {
    Interaction it;
    if (hit.kind == PrimKind::Triangle) {
      Vec3 p0, p1, p2;
      triangle(hit.prim, p0, p1, p2);
      float b0 = 1.f - hit.u - hit.v;
      it.p = p0 * b0 + p1 * hit.u + p2 * hit.v;
      it.ng = tri_normals ? tri_normals[hit.prim] : normalize(cross(p1 - p0, p2 - p0));
      it.ns = it.ng;
      if (normals) {
        Vec3 n = normals[indices[3 * hit.prim]] * b0 + normals[indices[3 * hit.prim + 1]] * hit.u +
                 normals[indices[3 * hit.prim + 2]] * hit.v;
        float len = length(n);
        if (len > 0.f) {
          n = n / len;
          it.ns = dot(n, it.ng) < 0.f ? -n : n;
        }
      }
      it.material = tri_material[hit.prim];
      it.emitter = tri_emitter[hit.prim];
    } else {
      const Sphere& s = spheres[hit.prim];
      Vec3 d = normalize(ray.o + ray.d * hit.t - s.center);
      it.p = s.center + d * s.radius;  // re-projected onto the sphere
      it.ng = s.flip_normals ? -d : d;
      it.ns = it.ng;
      it.material = s.material;
      it.emitter = s.emitter;
    }
    return it;
  }

  // Texture coordinates at a triangle hit, interpolated with the hit's own
  // barycentrics ((0, 0) without uvs, or on a sphere: the loader refuses
  // textures there).
  LUZ_INLINE Vec2 hit_uv(const Hit& hit) const {
    if (!uvs || hit.kind != PrimKind::Triangle) return {};
    const Vec2 t0 = uvs[indices[3 * hit.prim]], t1 = uvs[indices[3 * hit.prim + 1]],
               t2 = uvs[indices[3 * hit.prim + 2]];
    const float b0 = 1.f - hit.u - hit.v;
    return {t0.x * b0 + t1.x * hit.u + t2.x * hit.v, t0.y * b0 + t1.y * hit.u + t2.y * hit.v};
  }

  LUZ_INLINE Color texture_value(uint32_t t, Vec2 uv) const {
    return texture_lookup(textures[t], texels, srgb_table, uv);
  }

  // Starts fetching the texels a textured material will read at this hit
  // (texture_prefetch), so that their cache miss overlaps the previous
  // vertex's shadow ray, which path_li traces before shading this hit. No
  // effect on any result; nothing on the GPU. Forced inline: GCC 12 finds a
  // function whose only effect is a prefetch free of side effects and drops
  // calls to it.
  LUZ_FORCE_INLINE void prefetch_texture(const Hit& hit) const {
#if !defined(__CUDA_ARCH__)
    if (hit.kind != PrimKind::Triangle) return;
    const int32_t t = materials[tri_material[hit.prim]].texture;
    if (t >= 0) texture_prefetch(textures[t], texels, hit_uv(hit));
#else
    (void)hit;
#endif
  }

  // The BSDF at a hit: the material as stored, or, for a textured one, a copy
  // in `scratch` with the texture's value at the hit filled in. Untextured
  // materials cost one test here and are never copied.
  LUZ_FORCE_INLINE const Bsdf& material(const Interaction& it, const Hit& hit, BsdfScratch& scratch) const {
    const Bsdf& m = materials[it.material];
    if (m.texture < 0) return m;
    ::new (static_cast<void*>(&scratch.bsdf)) Bsdf(m);
    scratch.bsdf.set_textured_reflectance(texture_value(uint32_t(m.texture), hit_uv(hit)));
    return scratch.bsdf;
  }

  // Radiance an emitter sends from point `it` toward direction w (away from it).
  LUZ_INLINE Color emitted(const Interaction& it, Vec3 w) const {
    if (it.emitter < 0 || dot(it.ng, w) <= 0.f) return {};
    return emitters[it.emitter].radiance;
  }

  LUZ_INLINE Color environment_radiance(Vec3) const {
    return environment >= 0 ? emitters[environment].radiance : Color{};
  }

  // Index of the emitter selected by u: the first k with u < emitter_cdf[k],
  // by a branch-free binary search (the answer stays in [base, base + len);
  // the loop runs ceil(log2 n) times whatever u is, and the comparison, a coin
  // flip for the branch predictor, becomes a conditional move).
  LUZ_INLINE uint32_t select_emitter(float u) const {
    uint32_t base = 0, len = num_emitters;
    while (len > 1) {
      uint32_t half = len / 2;
      base += emitter_cdf[base + half - 1] <= u ? half : 0u;
      len -= half;
    }
    return base;
  }

  // Sample reuse (as Mitsuba 3's DiscreteDistribution::sample_reuse): selects
  // the emitter by u and rescales u to [0,1) within the chosen interval, so one
  // 2D draw both picks the light and places the point on it.
  LUZ_INLINE uint32_t select_emitter_reuse(float& u) const {
    uint32_t e = select_emitter(u);
    float lo = e > 0 ? emitter_cdf[e - 1] : 0.f, width = emitter_cdf[e] - lo;
    u = width > 0.f ? min(max((u - lo) / width, 0.f), kOneMinusEpsilon) : 0.f;
    return e;
  }

  // Samples a point on emitter e as seen from `ref`. pdf is per solid angle.
  LUZ_FORCE_INLINE LightSample sample_emitter(uint32_t e, Vec3 ref, Vec2 u) const {
    LightSample ls;
    const Emitter& em = emitters[e];
    switch (em.type) {
      case EmitterType::Triangle:
      case EmitterType::Parallelogram: {
        if (em.type == EmitterType::Triangle) {
          Vec2 b = square_to_triangle_barycentrics(u);
          ls.p = em.v0 * (1.f - b.x - b.y) + em.v1 * b.x + em.v2 * b.y;
        } else {
          ls.p = em.v0 + em.v1 * u.x + em.v2 * u.y;
        }
        ls.n = em.normal;
        Vec3 d = ls.p - ref;
        float d2 = length_squared(d);
        ls.dist = sqrtf(d2);
        ls.wi = d / ls.dist;
        // cos θ_l · dist, from d itself: the pdf d² / (cos θ_l · area) =
        // d² · dist / (cos_dist · area) then waits for one square root, not
        // for the normalised direction too.
        float cos_dist = -dot(ls.n, d);
        if (cos_dist <= 0.f || em.area <= 0.f) return ls;  // back of a one-sided emitter
        ls.pdf = d2 * ls.dist / (cos_dist * em.area);
        ls.radiance = em.radiance;
        return ls;
      }
      case EmitterType::Sphere: {
        const Sphere& s = spheres[em.prim];
        Vec3 to_c = s.center - ref;
        float dc2 = length_squared(to_c);
        float r2 = s.radius * s.radius;
        if (dc2 <= r2 * 1.00001f) {
          // Inside (or on) the sphere: uniform area sampling.
          Vec3 d = square_to_uniform_sphere(u);
          ls.p = s.center + d * s.radius;
          ls.n = s.flip_normals ? -d : d;
          Vec3 w = ls.p - ref;
          float l2 = length_squared(w);
          ls.dist = sqrtf(l2);
          if (ls.dist <= 0.f) return ls;
          ls.wi = w / ls.dist;
          float cos_l = -dot(ls.n, ls.wi);
          if (cos_l <= 0.f) return ls;
          ls.pdf = l2 / (cos_l * 4.f * kPi * r2);
          ls.radiance = em.radiance;
          return ls;
        }
        // Outside: uniform in the cone the sphere subtends (pbrt-v4's Sphere::Sample).
        float dc = sqrtf(dc2);
        float sin2_max = r2 / dc2;
        float omc = cone_one_minus_cos(sin2_max);
        Frame fr = Frame::from_normal(to_c / dc);
        Vec3 local = square_to_uniform_cone(u, omc);
        ls.wi = normalize(fr.to_world(local));
        float t = intersect_sphere(s.center, s.radius, ref, ls.wi, kInfinity);
        if (t <= 0.f) {
          // Grazing direction lost to rounding: take the tangent point.
          t = dot(to_c, ls.wi);
        }
        Vec3 nrm = normalize(ref + ls.wi * t - s.center);
        ls.p = s.center + nrm * s.radius;
        ls.dist = length(ls.p - ref);
        ls.n = s.flip_normals ? -nrm : nrm;
        if (dot(ls.n, ls.wi) >= 0.f) return ls;  // flipped sphere seen from outside
        ls.pdf = uniform_cone_pdf(omc);
        ls.radiance = em.radiance;
        return ls;
      }
      default: {
        ls.wi = square_to_uniform_sphere(u);
        ls.dist = kInfinity;
        ls.pdf = uniform_sphere_pdf();
        ls.radiance = em.radiance;
        return ls;
      }
    }
  }

  // Solid-angle density with which sample_emitter(e, ref, ·) produces the
  // direction toward light point `it` (at distance dist along unit wi).
  LUZ_INLINE float emitter_pdf(uint32_t e, Vec3 ref, const Interaction& it, Vec3 wi, float dist) const {
    const Emitter& em = emitters[e];
    switch (em.type) {
      case EmitterType::Triangle:
      case EmitterType::Parallelogram: {
        float cos_l = -dot(it.ng, wi);
        if (cos_l <= 0.f || em.area <= 0.f) return 0.f;
        return dist * dist / (cos_l * em.area);
      }
      case EmitterType::Sphere: {
        const Sphere& s = spheres[em.prim];
        float dc2 = length_squared(s.center - ref);
        float r2 = s.radius * s.radius;
        if (dc2 <= r2 * 1.00001f) {
          float cos_l = -dot(it.ng, wi);
          if (cos_l <= 0.f) return 0.f;
          return dist * dist / (cos_l * 4.f * kPi * r2);
        }
        if (dot(it.ng, wi) >= 0.f) return 0.f;
        return uniform_cone_pdf(cone_one_minus_cos(r2 / dc2));
      }
      default:
        return uniform_sphere_pdf();
    }
  }
};

}  // namespace luz
