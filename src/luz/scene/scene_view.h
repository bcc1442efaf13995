// SceneView: the scene as plain arrays and indices, valid on the CPU or copied
// to the GPU as is. Everything the integrator asks of the scene besides ray
// queries lives here.
#pragma once

#include "luz/camera/camera.h"
#include "luz/light/light_sampler.h"
#include "luz/material/material.h"
#include "luz/material/opacity.h"

namespace luz {

// The lights, as the integrator reaches them: by index (a surface's
// Interaction::emitter names its area light), the environment, and the
// light sampler.
struct LightsView {
  const Light* list = nullptr;
  uint32_t num_lights = 0;
  int32_t environment = -1;  // the infinite light rays that leave the scene find, or -1
  LightSampler sampler;      // sampler.n = 0: nothing to sample (no light, or none with power)
  LightData data;  // images and distributions the lights address by offset; textures

  LUZ_INLINE const Light& operator[](uint32_t k) const { return list[k]; }
};

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

  MaterialsView materials;
  TextureView textures;

  LightsView lights;

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

  LUZ_INLINE Vec2 hit_uv(const Hit& hit) const { return luz::hit_uv(uvs, indices, hit); }

  // Starts fetching the texels the material at this hit will read first
  // (TextureView::prefetch), so that their cache miss overlaps the previous
  // vertex's shadow ray, which path_li traces before shading this hit. No
  // effect on any result; nothing on the GPU. Forced inline: GCC 12 finds a
  // function whose only effect is a prefetch free of side effects and drops
  // calls to it.
  LUZ_FORCE_INLINE void prefetch_texture(const Hit& hit) const {
#if !defined(__CUDA_ARCH__)
    if (hit.kind != PrimKind::Triangle) return;
    const int32_t t = materials.first_texture(tri_material[hit.prim]);
    if (t >= 0) textures.prefetch(uint32_t(t), hit_uv(hit));
#else
    (void)hit;
#endif
  }

  // The BSDF at a hit: the material's own when no texture drives it (no
  // copy), else `local`, set to the material's with every textured parameter
  // evaluated at the hit's texture coordinates.
  LUZ_FORCE_INLINE const Bsdf& bsdf(const Interaction& it, const Hit& hit, Bsdf& local) const {
    const Material& m = materials.list[it.material];
    if (m.num_bindings == 0) return m.bsdf;
    local = Bsdf::copy_of(m.bsdf);
    materials.apply_textures(local, m, textures, hit_uv(hit));
    return local;
  }

  // What the tracers' alpha test reads: empty (no test) unless a material is masked.
  LUZ_INLINE OpacityView opacity() const {
    if (!materials.masked) return {};
    return {materials.list, tri_material, indices, uvs, spheres, textures};
  }
};

}  // namespace luz
