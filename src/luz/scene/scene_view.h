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
  // Triangles: all meshes merged; triangle k uses indices[3k..3k+2]. The
  // first num_triangles are the world's; the objects' follow (instances).
  const Vec3* positions = nullptr;
  const Vec3* normals = nullptr;  // per vertex, or null: flat shading
  const uint32_t* indices = nullptr;
  const uint32_t* tri_material = nullptr;
  const int32_t* tri_emitter = nullptr;  // -1: not emissive
  const Vec2* uvs = nullptr;             // texture coordinates per vertex, or null: none
  const Color* colors = nullptr;         // vertex colours, or null: none (white)
  // Unit geometric normal per triangle, or null: computed at each hit. The
  // CPU keeps them (the normalisation's square root and division leave the
  // start of every vertex: 1-3% less time on the Cornell box, 12 bytes per
  // triangle); the GPU computes them.
  const Vec3* tri_normals = nullptr;
  uint32_t num_triangles = 0;

  const Sphere* spheres = nullptr;
  uint32_t num_spheres = 0;

  // Objects (their triangles stored after the num_triangles above, in
  // object space) and the instances placing them.
  InstancesView instances;

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

  // The vertices of a hit's triangle in world space: an instance's mapped
  // by its to_world, as Scene::flatten_instances maps them.
  LUZ_INLINE void world_triangle(const Hit& hit, Vec3& p0, Vec3& p1, Vec3& p2) const {
    triangle(hit.prim, p0, p1, p2);
    if (hit.inst != kNoInstance) {
      const Affine3& m = instances.list[hit.inst].to_world;
      p0 = m.point(p0);
      p1 = m.point(p1);
      p2 = m.point(p2);
    }
  }

  LUZ_INLINE Vec3 triangle_normal(uint32_t k) const {
    Vec3 p0, p1, p2;
    triangle(k, p0, p1, p2);
    return normalize(cross(p1 - p0, p2 - p0));
  }

  LUZ_FORCE_INLINE Interaction interaction(const Ray& ray, const Hit& hit) const {
    if (hit.kind == PrimKind::Triangle) {
      if (hit.inst != kNoInstance) return instance_interaction(hit);
      Vec3 p0, p1, p2;
      triangle(hit.prim, p0, p1, p2);
      return triangle_interaction(hit, p0, p1, p2, tri_normals ? tri_normals[hit.prim] : normalize(cross(p1 - p0, p2 - p0)),
                                  nullptr);
    }
    Interaction it;
    const Sphere& s = spheres[hit.prim];
    Vec3 d = normalize(ray.o + ray.d * hit.t - s.center);
    it.p = s.center + d * s.radius;  // re-projected onto the sphere
    it.ng = s.flip_normals ? -d : d;
    it.ns = it.ng;
    it.material = s.material;
    it.emitter = s.emitter;
    return it;
  }

  // An instance's triangle hit, computed as interaction() computes the
  // flattened triangle's: its vertices and vertex normals mapped to world
  // space first, as Scene::flatten_instances maps them. Out of line on the
  // CPU: the path loop of a scene without instances pays one branch.
  LUZ_CPU_NOINLINE Interaction instance_interaction(const Hit& hit) const {
    Vec3 p0, p1, p2;
    world_triangle(hit, p0, p1, p2);
    return triangle_interaction(hit, p0, p1, p2, normalize(cross(p1 - p0, p2 - p0)), &instances.list[hit.inst]);
  }

  // The surface at a triangle hit from its (world-space) vertices and unit
  // geometric normal; `in`: the instance whose vertex normals are mapped, or
  // null.
  LUZ_FORCE_INLINE Interaction triangle_interaction(const Hit& hit, Vec3 p0, Vec3 p1, Vec3 p2, Vec3 ng,
                                                    const Instance* in) const {
    Interaction it;
    float b0 = 1.f - hit.u - hit.v;
    it.p = p0 * b0 + p1 * hit.u + p2 * hit.v;
    it.ng = ng;
    it.ns = it.ng;
    if (normals) {
      const uint32_t* v = indices + 3 * size_t(hit.prim);
      Vec3 n0 = normals[v[0]], n1 = normals[v[1]], n2 = normals[v[2]];
      if (in) {
        n0 = in->normal(n0);
        n1 = in->normal(n1);
        n2 = in->normal(n2);
      }
      Vec3 n = n0 * b0 + n1 * hit.u + n2 * hit.v;
      float len = length(n);
      if (len > 0.f) {
        n = n / len;
        it.ns = dot(n, it.ng) < 0.f ? -n : n;
      }
    }
    it.material = tri_material[hit.prim];
    it.emitter = tri_emitter[hit.prim];
    return it;
  }

  // Texture coordinates at a hit whose point is p (spheres read it).
  LUZ_INLINE Vec2 hit_uv(const Hit& hit, Vec3 p) const { return luz::hit_uv(uvs, indices, spheres, hit, p); }
  // The vertex colour at a hit (white without).
  LUZ_INLINE Color hit_color(const Hit& hit) const { return luz::hit_color(colors, indices, hit); }

  // The shading frame at a hit: around it.ns, or, for a material with a
  // normal or bump map, the perturbed frame (it.ns set to its normal), in
  // which the integrator then evaluates the BSDF as Mitsuba's normalmap and
  // bumpmap do. Other materials pay one load and one branch. Inlined: the
  // path loop's values live across an out-of-line call would spill.
  // kMaps false: the scene has no map (MaterialsView::mapped), no test.
  template <bool kMaps = true>
  LUZ_FORCE_INLINE Frame shading_frame(Interaction& it, const Hit& hit) const {
    if constexpr (!kMaps) return Frame::from_normal(it.ns);
    const Material& m = materials.list[it.material];
    if (__builtin_expect((m.normal_map & m.bump_map) < 0, 1)) return Frame::from_normal(it.ns);  // neither map (both -1)
    const Frame f = perturbed_frame(it.p, it.ng, it.ns, hit, m);
    it.ns = f.n;
    return f;
  }

  // The frame of a normal or bump map (Mitsuba 3's normalmap.cpp and
  // bumpmap.cpp) at a hit of point p, from the surface's dp/du and dp/dv (a
  // triangle's from its vertices' uvs, a sphere's from sphere_uv's angles):
  //   normalmap: n = normalize(2 rgb - 1) in the tangent frame (s along
  //     dp/du made orthogonal to ns, t = ns × s, ns), Mitsuba's shading frame
  //     (glTF's: x and y scaled, y along -dp/dv: Material::normal_y_by_uv);
  //   bumpmap: the height h's uv gradient g (scaled) displaces the surface
  //     along ns: dp'/du = dp/du + ns (g.u - ns·dp/du), likewise v, and
  //     n = normalize(dp'/du × dp'/dv) (dn/du neglected, as Mitsuba).
  // The new normal is turned to ng's side, as an interpolated normal is, so
  // the integrator's side tests (against ng) apply unchanged; a degenerate
  // one (a (0.5, 0.5, 0.5) texel) leaves the frame unperturbed. The tangent
  // is dp/du made orthogonal to the new normal (any, at a sphere's pole,
  // where dp/du vanishes).
  LUZ_FORCE_INLINE Frame perturbed_frame(Vec3 p, Vec3 ng, Vec3 ns, const Hit& hit, const Material& m) const {
    Vec3 dpdu, dpdv;
    Vec2 uv;
    if (hit.kind == PrimKind::Sphere) {
      const Sphere& s = spheres[hit.prim];
      const Vec3 l = s.frame.to_local(p - s.center);
      uv = sphere_uv(l);
      sphere_dp_duv(s.frame, s.radius, l * (1.f / s.radius), dpdu, dpdv);
    } else {
      if (!uvs) return Frame::from_normal(ns);  // the loader refuses these
      const float bu = hit.u, bv = hit.v;
      Vec3 p0, p1, p2;
      world_triangle(hit, p0, p1, p2);
      const uint32_t* v = indices + 3 * size_t(hit.prim);
      const Vec2 t0 = uvs[v[0]], t1 = uvs[v[1]], t2 = uvs[v[2]];
      triangle_dp_duv(p0, p1, p2, t0, t1, t2, ng, dpdu, dpdv);
      const float b0 = 1.f - bu - bv;
      uv = {t0.x * b0 + t1.x * bu + t2.x * bv, t0.y * b0 + t1.y * bu + t2.y * bv};  // as triangle_uv
    }
    Vec3 n;
    if (m.normal_map >= 0) {
      const Color c = textures.eval(uint32_t(m.normal_map), uv);
      const float x = (2.f * c.x - 1.f) * m.normal_scale, y = (2.f * c.y - 1.f) * m.normal_scale;
      const bool flip = m.normal_y_by_uv && dot(cross(ns, dpdu), dpdv) > 0.f;  // glTF: y along -dp/dv
      n = Frame::from_normal_tangent(ns, dpdu).to_world({x, flip ? -y : y, 2.f * c.z - 1.f});
    } else {
      const Vec2 g = textures.eval_1_grad(uint32_t(m.bump_map), uv);
      const Vec3 du = dpdu + ns * (m.bump_scale * g.x - dot(ns, dpdu));
      const Vec3 dv = dpdv + ns * (m.bump_scale * g.y - dot(ns, dpdv));
      n = cross(du, dv);
    }
    const float len = length(n);
    if (!(len > 0.f && len < kInfinity)) return Frame::from_normal(ns);
    n = n / len;
    if (dot(n, ng) < 0.f) n = -n;
    return Frame::from_normal_tangent(n, dpdu);
  }

  // Starts fetching the texels the material at this hit will read first
  // (TextureView::prefetch), so that their cache miss overlaps the previous
  // vertex's shadow ray, which path_li traces before shading this hit. No
  // effect on any result; nothing on the GPU. Forced inline: GCC 12 finds a
  // function whose only effect is a prefetch free of side effects and drops
  // calls to it.
  LUZ_FORCE_INLINE void prefetch_texture(const Ray& ray, const Hit& hit) const {
#if !defined(__CUDA_ARCH__)
    const bool sphere = hit.kind == PrimKind::Sphere;
    const int32_t t = materials.first_texture(sphere ? spheres[hit.prim].material : tri_material[hit.prim]);
    if (t >= 0) textures.prefetch(uint32_t(t), sphere ? sphere_uv(spheres[hit.prim], ray.o + ray.d * hit.t)
                                                       : triangle_uv(uvs, indices, hit));
#else
    (void)ray, (void)hit;
#endif
  }

  // The BSDF at a hit: the material's own when no texture drives it (no
  // copy), else `local`, set to the material's with every textured parameter
  // evaluated at the hit's texture coordinates.
  LUZ_FORCE_INLINE const Bsdf& bsdf(const Interaction& it, const Hit& hit, Bsdf& local) const {
    const Material& m = materials.list[it.material];
    if (m.num_bindings == 0) return m.bsdf;
    local.copy_live(m.bsdf);
    materials.apply_textures(local, m, textures, hit_uv(hit, it.p), hit_color(hit));
    return local;
  }

  // What the tracers' alpha test reads: empty (no test) unless a material is masked.
  LUZ_INLINE OpacityView opacity() const {
    if (!materials.masked) return {};
    return {materials.list, tri_material, indices, uvs, spheres, textures, colors};
  }
};

}  // namespace luz
