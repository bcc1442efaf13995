#include "luz/scene/scene.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

namespace luz {

void Scene::add_mesh(const std::vector<Vec3>& pos, const std::vector<Vec3>& nrm, const std::vector<uint32_t>& idx,
                     uint32_t material, const Color* emission, const std::vector<Vec2>& uv) {
  uint32_t base = uint32_t(positions.size());
  if (!uv.empty() && uv.size() != pos.size()) throw std::invalid_argument("add_mesh: one texture coordinate per position");
  // Texture coordinates as normals: for all vertices or none; meshes without
  // them get (0, 0) once another mesh has some.
  if (!uv.empty() || !uvs.empty()) {
    uvs.resize(positions.size());
    if (uv.empty())
      uvs.resize(positions.size() + pos.size(), Vec2{});
    else
      uvs.insert(uvs.end(), uv.begin(), uv.end());
  }
  // Keep normals either absent for all vertices or present for all.
  if (!nrm.empty() && normals.empty() && !positions.empty()) {
    normals.resize(positions.size());
    // Earlier flat meshes get zero normals, which interaction() treats as flat.
  }
  positions.insert(positions.end(), pos.begin(), pos.end());
  if (!nrm.empty() || !normals.empty()) {
    if (nrm.empty())
      normals.resize(positions.size(), Vec3{});
    else
      normals.insert(normals.end(), nrm.begin(), nrm.end());
  }
  for (size_t k = 0; k + 2 < idx.size(); k += 3) {
    indices.push_back(base + idx[k]);
    indices.push_back(base + idx[k + 1]);
    indices.push_back(base + idx[k + 2]);
    tri_material.push_back(material);
    if (emission) {
      Emitter e;
      e.type = EmitterType::Triangle;
      e.prim = uint32_t(tri_material.size() - 1);
      e.radiance = *emission;
      tri_emitter.push_back(int32_t(emitters.size()));
      emitters.push_back(e);
    } else {
      tri_emitter.push_back(-1);
    }
  }
}

void Scene::add_sphere(Vec3 center, float radius, uint32_t material, const Color* emission, bool flip) {
  Sphere s;
  s.center = center;
  s.radius = radius;
  s.material = material;
  s.flip_normals = flip;
  if (emission) {
    Emitter e;
    e.type = EmitterType::Sphere;
    e.prim = uint32_t(spheres.size());
    e.radiance = *emission;
    s.emitter = int32_t(emitters.size());
    emitters.push_back(e);
  }
  spheres.push_back(s);
}

uint32_t Scene::add_material(const Bsdf& b) {
  materials.push_back(b);
  return uint32_t(materials.size() - 1);
}

uint32_t Scene::add_texture(TextureDesc desc, const std::vector<uint32_t>& image) {
  if (srgb_table.empty())
    for (int k = 0; k < 256; ++k) srgb_table.push_back(float(srgb_to_linear(k / 255.0)));
  if (textures.size() >= 32767) throw std::length_error("more than 32767 bitmap textures");
  if (texels.size() + image.size() > size_t(UINT32_MAX)) throw std::length_error("more than 2^32 texels in all textures");
  desc.offset = uint32_t(texels.size());
  texels.insert(texels.end(), image.begin(), image.end());
  textures.push_back(desc);
  return uint32_t(textures.size() - 1);
}

namespace {

// If triangles a and b (vertex positions) share one edge and their other two
// vertices mirror each other through its midpoint (to a few ulps), and face
// the same way, fills q with the parallelogram they form: corner, two edges.
bool parallelogram(const Vec3 a[3], const Vec3 b[3], Emitter& q) {
  auto same = [](Vec3 p, Vec3 r) { return p.x == r.x && p.y == r.y && p.z == r.z; };
  // A triangle with a repeated position is degenerate: never part of a quad
  // (and the shared-vertex count below needs distinct positions).
  for (const Vec3* t : {a, b})
    if (same(t[0], t[1]) || same(t[1], t[2]) || same(t[0], t[2])) return false;
  int shared_a[3] = {-1, -1, -1}, n_shared = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (same(a[i], b[j])) {
        shared_a[i] = j;
        ++n_shared;
      }
  if (n_shared != 2) return false;
  int ia = shared_a[0] < 0 ? 0 : shared_a[1] < 0 ? 1 : 2;  // a's vertex off the shared edge
  int jb = 3 - shared_a[(ia + 1) % 3] - shared_a[(ia + 2) % 3];  // b's
  const Vec3 d1 = a[ia], s1 = a[(ia + 1) % 3], s2 = a[(ia + 2) % 3], d2 = b[jb];
  double scale = 0.0, gap = 0.0;
  for (int k = 0; k < 3; ++k) {
    scale = std::max({scale, std::fabs(double(d1[k])), std::fabs(double(d2[k])), std::fabs(double(s1[k])),
                      std::fabs(double(s2[k]))});
    gap = std::max(gap, std::fabs((double(d1[k]) + d2[k]) - (double(s1[k]) + s2[k])));
  }
  if (!(gap <= 4.0 * 0x1p-24 * scale)) return false;
  Vec3 na = cross(a[1] - a[0], a[2] - a[0]), nb = cross(b[1] - b[0], b[2] - b[0]);
  float la = length(na);
  if (!(la > 0.f) || !(dot(na, nb) > 0.f)) return false;
  q.type = EmitterType::Parallelogram;
  q.v0 = d1;
  q.v1 = s1 - d1;
  q.v2 = s2 - d1;
  q.normal = na / la;  // the emitting side, as the triangles had it
  q.area = length(cross(q.v1, q.v2));
  return q.area > 0.f;
}

}  // namespace

// Consecutive emitter triangles (as the loaders add a quad's two halves) with
// the same radiance that form a parallelogram become one Parallelogram
// emitter; the triangles' tri_emitter entries then both name it. Earlier
// merges are undone first, so a compile() after a change of geometry merges
// what is a parallelogram now.
void Scene::merge_parallelogram_emitters() {
  // 1. One emitter per emissive triangle again: split[back[e]] is emitter e,
  // or a parallelogram's first triangle (its second follows).
  std::vector<Emitter> split;
  split.reserve(emitters.size());
  std::vector<size_t> back(emitters.size());
  for (size_t e = 0; e < emitters.size(); ++e) {
    const Emitter& em = emitters[e];
    back[e] = split.size();
    if (em.type != EmitterType::Parallelogram) {
      split.push_back(em);
      continue;
    }
    for (uint32_t t : {em.prim, em.prim2}) {
      Emitter tri;
      tri.prim = t;
      tri.radiance = em.radiance;
      split.push_back(tri);
    }
  }
  // 2. Merge: remap[k] is the new index of split[k].
  const SceneView v = view();
  std::vector<int32_t> remap(split.size());
  std::vector<Emitter> merged;
  merged.reserve(split.size());
  for (size_t k = 0; k < split.size(); ++k) {
    const Emitter& a = split[k];
    remap[k] = int32_t(merged.size());
    if (a.type == EmitterType::Triangle && k + 1 < split.size()) {
      const Emitter& b = split[k + 1];
      Vec3 pa[3], pb[3];
      Emitter q;
      if (b.type == EmitterType::Triangle && a.radiance.x == b.radiance.x && a.radiance.y == b.radiance.y &&
          a.radiance.z == b.radiance.z) {
        v.triangle(a.prim, pa[0], pa[1], pa[2]);
        v.triangle(b.prim, pb[0], pb[1], pb[2]);
        if (parallelogram(pa, pb, q)) {
          q.prim = a.prim;
          q.prim2 = b.prim;
          q.radiance = a.radiance;
          remap[++k] = int32_t(merged.size());
          merged.push_back(q);
          continue;
        }
      }
    }
    merged.push_back(a);
  }
  // 3. Triangles and spheres name their new emitters.
  for (size_t t = 0; t < tri_emitter.size(); ++t) {
    if (tri_emitter[t] < 0) continue;
    const Emitter& old = emitters[size_t(tri_emitter[t])];
    const bool second = old.type == EmitterType::Parallelogram && t == old.prim2;
    tri_emitter[t] = remap[back[size_t(tri_emitter[t])] + (second ? 1 : 0)];
  }
  for (Sphere& sp : spheres)
    if (sp.emitter >= 0) sp.emitter = remap[back[size_t(sp.emitter)]];
  emitters = std::move(merged);
}

void Scene::compile() {
  Vec3 lo{kInfinity, kInfinity, kInfinity}, hi = -lo;
  for (uint32_t k = 0; k < num_triangles(); ++k)
    for (int j = 0; j < 3; ++j) {
      Vec3 p = positions[indices[3 * k + j]];
      lo = vmin(lo, p);
      hi = vmax(hi, p);
    }
  for (const Sphere& s : spheres) {
    Vec3 r{s.radius, s.radius, s.radius};
    lo = vmin(lo, s.center - r);
    hi = vmax(hi, s.center + r);
  }
  if (!(lo.x <= hi.x)) lo = hi = Vec3{};
  bounds_min = lo;
  bounds_max = hi;
  float radius = std::max(0.5f * length(hi - lo), 1e-3f);

  // Unit geometric normals, by the formula SceneView::interaction uses when
  // it has none (so both give the same bits).
  tri_normals.clear();
  SceneView v = view();
  tri_normals.resize(num_triangles());
  for (uint32_t k = 0; k < num_triangles(); ++k) tri_normals[k] = v.triangle_normal(k);

  merge_parallelogram_emitters();

  // Emitter selection in proportion to power: π · area · mean radiance.
  v = view();
  environment = -1;
  std::vector<double> power(emitters.size());
  for (size_t e = 0; e < emitters.size(); ++e) {
    const Emitter& em = emitters[e];
    double area = 0;
    switch (em.type) {
      case EmitterType::Triangle: {
        Vec3 p0, p1, p2;
        v.triangle(em.prim, p0, p1, p2);
        Vec3 c = cross(p1 - p0, p2 - p0);
        float len = length(c);
        emitters[e].area = 0.5f * len;
        emitters[e].normal = len > 0.f ? c / len : Vec3{0, 0, 1};
        emitters[e].v0 = p0;
        emitters[e].v1 = p1;
        emitters[e].v2 = p2;
        area = emitters[e].area;
        break;
      }
      case EmitterType::Parallelogram: area = em.area; break;  // set by merge_parallelogram_emitters
      case EmitterType::Sphere: area = 4.0 * M_PI * double(spheres[em.prim].radius) * spheres[em.prim].radius; break;
      case EmitterType::Constant:
        area = M_PI * double(radius) * radius;  // flux through the scene's bounding disk
        environment = int32_t(e);
        break;
    }
    power[e] = M_PI * area * std::max(0.0, double(average(em.radiance)));
  }
  double total = 0;
  for (double p : power) total += p;
  // With no emitting power at all, the CDF stays empty: no light sampling.
  emitter_cdf.clear();
  emitter_pmf.assign(emitters.size(), 0.f);
  if (total > 0) {
    emitter_cdf.assign(emitters.size(), 1.f);
    double acc = 0;
    for (size_t e = 0; e < emitters.size(); ++e) {
      acc += power[e];
      emitter_cdf[e] = float(acc / total);
      emitter_pmf[e] = float(power[e] / total);
    }
    if (!emitters.empty()) emitter_cdf.back() = 1.f;
    // A zero-power emitter must never be selected: its CDF step is empty and
    // binary search skips it; that holds even for the last one.
  }
}

SceneView Scene::view() const {
  SceneView v;
  v.positions = positions.data();
  v.normals = normals.empty() ? nullptr : normals.data();
  v.indices = indices.data();
  v.tri_material = tri_material.data();
  v.tri_emitter = tri_emitter.data();
  v.uvs = uvs.empty() ? nullptr : uvs.data();
  v.tri_normals = tri_normals.size() == num_triangles() && !tri_normals.empty() ? tri_normals.data() : nullptr;
  v.num_triangles = num_triangles();
  v.spheres = spheres.data();
  v.num_spheres = uint32_t(spheres.size());
  v.materials = materials.data();
  v.num_materials = uint32_t(materials.size());
  v.textures = textures.data();
  v.texels = texels.data();
  v.srgb_table = srgb_table.data();
  v.num_textures = uint32_t(textures.size());
  v.emitters = emitters.data();
  v.emitter_cdf = emitter_cdf.data();
  v.emitter_pmf = emitter_pmf.data();
  v.num_emitters = emitter_cdf.empty() ? 0 : uint32_t(emitters.size());
  v.environment = environment;
  v.camera = camera;
  v.bounds_center = (bounds_min + bounds_max) * 0.5f;
  v.bounds_radius = std::max(0.5f * length(bounds_max - bounds_min), 1e-3f);
  return v;
}

}  // namespace luz
