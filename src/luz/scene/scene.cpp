#include "luz/scene/scene.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

namespace luz {

void Scene::add_mesh(const std::vector<Vec3>& pos, const std::vector<Vec3>& nrm, const std::vector<uint32_t>& idx,
                     uint32_t material, const Color* emission, const std::vector<Vec2>& uv,
                     int32_t emission_texture, bool two_sided, const std::vector<Color>& col) {
  uint32_t base = uint32_t(positions.size());
  if (!uv.empty() && uv.size() != pos.size()) throw std::invalid_argument("add_mesh: one texture coordinate per position");
  if (!col.empty() && col.size() != pos.size()) throw std::invalid_argument("add_mesh: one vertex colour per position");
  if (!objects.empty() && emission) throw std::invalid_argument("add_mesh: an object's triangles cannot emit");
  if (emission_texture >= 0 && (!emission || uv.empty()))
    throw std::invalid_argument("add_mesh: a textured emitter needs its radiance and texture coordinates");
  // Texture coordinates as normals: for all vertices or none; meshes without
  // them get (0, 0) once another mesh has some.
  if (!uv.empty() || !uvs.empty()) {
    uvs.resize(positions.size());
    if (uv.empty())
      uvs.resize(positions.size() + pos.size(), Vec2{});
    else
      uvs.insert(uvs.end(), uv.begin(), uv.end());
  }
  // Vertex colours likewise, white where a mesh has none.
  if (!col.empty() || !colors.empty()) {
    colors.resize(positions.size(), Color{1.f, 1.f, 1.f});
    if (col.empty())
      colors.resize(positions.size() + pos.size(), Color{1.f, 1.f, 1.f});
    else
      colors.insert(colors.end(), col.begin(), col.end());
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
      TriangleLight l;
      l.prim = uint32_t(tri_material.size() - 1);
      l.radiance = *emission;
      l.texture = emission_texture;
      l.two_sided = two_sided;
      tri_emitter.push_back(int32_t(lights.size()));
      lights.push_back(l);
    } else {
      tri_emitter.push_back(-1);
    }
  }
  if (!objects.empty()) {
    SceneObject& o = objects.back();
    o.num_vertices = uint32_t(positions.size()) - o.first_vertex;
    o.num_triangles = uint32_t(tri_material.size()) - o.first_triangle;
  }
}

uint32_t Scene::add_object() {
  SceneObject o;
  o.first_triangle = uint32_t(tri_material.size());
  o.first_vertex = uint32_t(positions.size());
  objects.push_back(o);
  return uint32_t(objects.size() - 1);
}

uint32_t Scene::add_instance(uint32_t object, const Affine3& to_world, const Affine3& to_object) {
  if (object >= objects.size()) throw std::invalid_argument("add_instance: no such object");
  if (instances.size() >= size_t(INT32_MAX)) throw std::length_error("more than 2^31 - 1 instances");
  Instance in;
  in.to_world = to_world;
  in.to_object = to_object;
  in.object = object;
  instances.push_back(in);
  return uint32_t(instances.size() - 1);
}

uint64_t Scene::num_instanced_triangles() const {
  uint64_t n = 0;
  for (const Instance& in : instances) n += objects[in.object].num_triangles;
  return n;
}

void Scene::flatten_instances() {
  const uint32_t nt = num_triangles();
  const size_t nv = objects.empty() ? positions.size() : objects.front().first_vertex;
  std::vector<Vec3> pos(positions.begin(), positions.begin() + std::ptrdiff_t(nv)), nrm;
  std::vector<Vec2> uv;
  std::vector<Color> col;
  if (!normals.empty()) nrm.assign(normals.begin(), normals.begin() + std::ptrdiff_t(nv));
  if (!uvs.empty()) uv.assign(uvs.begin(), uvs.begin() + std::ptrdiff_t(nv));
  if (!colors.empty()) col.assign(colors.begin(), colors.begin() + std::ptrdiff_t(nv));
  std::vector<uint32_t> idx(indices.begin(), indices.begin() + 3 * std::ptrdiff_t(nt));
  std::vector<uint32_t> mat(tri_material.begin(), tri_material.begin() + std::ptrdiff_t(nt));
  std::vector<int32_t> emit(tri_emitter.begin(), tri_emitter.begin() + std::ptrdiff_t(nt));
  for (const Instance& in : instances) {
    const SceneObject& o = objects[in.object];
    if (pos.size() + o.num_vertices >= size_t(UINT32_MAX) || mat.size() + o.num_triangles >= size_t(UINT32_MAX))
      throw std::length_error("flattened, the scene would have more than 2^32 - 1 vertices or triangles");
    const uint32_t base = uint32_t(pos.size());
    for (uint32_t k = o.first_vertex; k < o.first_vertex + o.num_vertices; ++k) {
      pos.push_back(in.to_world.point(positions[k]));
      if (!normals.empty()) nrm.push_back(in.normal(normals[k]));
      if (!uvs.empty()) uv.push_back(uvs[k]);
      if (!colors.empty()) col.push_back(colors[k]);
    }
    for (uint32_t t = o.first_triangle; t < o.first_triangle + o.num_triangles; ++t) {
      for (int j = 0; j < 3; ++j) idx.push_back(indices[3 * size_t(t) + size_t(j)] - o.first_vertex + base);
      mat.push_back(tri_material[t]);
      emit.push_back(-1);
    }
  }
  positions = std::move(pos);
  normals = std::move(nrm);
  uvs = std::move(uv);
  colors = std::move(col);
  indices = std::move(idx);
  tri_material = std::move(mat);
  tri_emitter = std::move(emit);
  flattened_instances += instances.size();
  objects.clear();
  instances.clear();
}

void Scene::add_sphere(Vec3 center, float radius, uint32_t material, const Color* emission, bool flip,
                       int32_t emission_texture, const Frame& frame) {
  if (emission_texture >= 0 && !emission) throw std::invalid_argument("add_sphere: a textured emitter needs its radiance");
  Sphere s;
  s.center = center;
  s.radius = radius;
  s.material = material;
  s.flip_normals = flip;
  s.frame = frame;
  if (emission) {
    SphereLight l;
    l.prim = uint32_t(spheres.size());
    l.radiance = *emission;
    l.texture = emission_texture;
    s.emitter = int32_t(lights.size());
    lights.push_back(l);
  }
  spheres.push_back(s);
}

uint32_t Scene::add_material(const Bsdf& b, const std::vector<TextureBinding>& bindings, float opacity,
                             int32_t opacity_texture) {
  Material m;
  m.bsdf = b;
  m.opacity = opacity;
  m.opacity_texture = opacity_texture;
  m.first_binding = uint32_t(texture_bindings.size());
  m.num_bindings = uint32_t(bindings.size());
  texture_bindings.insert(texture_bindings.end(), bindings.begin(), bindings.end());
  materials.push_back(m);
  return uint32_t(materials.size() - 1);
}

uint32_t Scene::add_texture(const Texture& t) {
  if (textures.size() >= size_t(INT32_MAX)) throw std::length_error("more than 2^31 textures");
  textures.push_back(t);
  return uint32_t(textures.size() - 1);
}

uint32_t Scene::add_bitmap(BitmapTexture bitmap, const UvTransform& to_uv, const std::vector<uint32_t>& rgba8) {
  if (srgb_table.empty())
    for (int k = 0; k < 256; ++k) srgb_table.push_back(float(srgb_to_linear(k / 255.0)));
  if (texels8.size() + rgba8.size() > size_t(UINT32_MAX)) throw std::length_error("more than 2^32 8-bit texels in all textures");
  bitmap.offset = uint32_t(texels8.size());
  bitmap.is_float = false;
  texels8.insert(texels8.end(), rgba8.begin(), rgba8.end());
  Texture t(bitmap);
  t.to_uv = to_uv;
  return add_texture(t);
}

uint32_t Scene::add_bitmap(BitmapTexture bitmap, const UvTransform& to_uv, const std::vector<float>& rgb) {
  if (texelsf.size() / 3 + rgb.size() / 3 > size_t(UINT32_MAX)) throw std::length_error("more than 2^32 float texels in all textures");
  bitmap.offset = uint32_t(texelsf.size() / 3);
  bitmap.is_float = true;
  texelsf.insert(texelsf.end(), rgb.begin(), rgb.end());
  Texture t(bitmap);
  t.to_uv = to_uv;
  return add_texture(t);
}

namespace {

// If triangles a and b (vertex positions) share one edge and their other two
// vertices mirror each other through its midpoint (to a few ulps), and face
// the same way, fills q with the parallelogram they form: corner, two edges.
bool parallelogram(const Vec3 a[3], const Vec3 b[3], ParallelogramLight& q) {
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
  q.corner = d1;
  q.e1 = s1 - d1;
  q.e2 = s2 - d1;
  q.normal = na / la;  // the emitting side, as the triangles had it
  q.area = length(cross(q.e1, q.e2));
  return q.area > 0.f;
}

}  // namespace

// Consecutive emitter triangles (as the loaders add a quad's two halves) with
// the same constant radiance that form a parallelogram become one Parallelogram
// emitter; the triangles' tri_emitter entries then both name it. Earlier
// merges are undone first, so a compile() after a change of geometry merges
// what is a parallelogram now.
void Scene::merge_parallelogram_emitters() {
  // 1. One light per emissive triangle again: split[back[e]] is light e, or
  // a parallelogram's first triangle (its second follows).
  std::vector<Light> split;
  split.reserve(lights.size());
  std::vector<size_t> back(lights.size());
  for (size_t e = 0; e < lights.size(); ++e) {
    const Light& l = lights[e];
    back[e] = split.size();
    if (l.type != LightType::Parallelogram) {
      split.push_back(l);
      continue;
    }
    for (uint32_t t : {l.parallelogram.prim, l.parallelogram.prim2}) {
      TriangleLight tri;
      tri.prim = t;
      tri.radiance = l.parallelogram.radiance;
      tri.two_sided = l.parallelogram.two_sided;
      split.push_back(tri);
    }
  }
  // 2. Merge: remap[k] is the new index of split[k].
  const SceneView v = view();
  std::vector<int32_t> remap(split.size());
  std::vector<Light> merged;
  merged.reserve(split.size());
  for (size_t k = 0; k < split.size(); ++k) {
    const Light& a = split[k];
    remap[k] = int32_t(merged.size());
    if (a.type == LightType::Triangle && k + 1 < split.size() && split[k + 1].type == LightType::Triangle) {
      const TriangleLight &ta = a.triangle, &tb = split[k + 1].triangle;
      Vec3 pa[3], pb[3];
      ParallelogramLight q;
      if (ta.texture < 0 && tb.texture < 0 && ta.two_sided == tb.two_sided && ta.radiance.x == tb.radiance.x &&
          ta.radiance.y == tb.radiance.y && ta.radiance.z == tb.radiance.z) {
        v.triangle(ta.prim, pa[0], pa[1], pa[2]);
        v.triangle(tb.prim, pb[0], pb[1], pb[2]);
        if (parallelogram(pa, pb, q)) {
          q.prim = ta.prim;
          q.prim2 = tb.prim;
          q.radiance = ta.radiance;
          q.two_sided = ta.two_sided;
          remap[++k] = int32_t(merged.size());
          merged.push_back(q);
          continue;
        }
      }
    }
    merged.push_back(a);
  }
  // 3. Triangles and spheres name their new lights.
  for (size_t t = 0; t < tri_emitter.size(); ++t) {
    if (tri_emitter[t] < 0) continue;
    const Light& old = lights[size_t(tri_emitter[t])];
    const bool second = old.type == LightType::Parallelogram && t == old.parallelogram.prim2;
    tri_emitter[t] = remap[back[size_t(tri_emitter[t])] + (second ? 1 : 0)];
  }
  for (Sphere& sp : spheres)
    if (sp.emitter >= 0) sp.emitter = remap[back[size_t(sp.emitter)]];
  lights = std::move(merged);
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
  // An instance's bounds: its object's box mapped, corner by corner.
  for (SceneObject& o : objects) {
    o.lo = Vec3{kInfinity, kInfinity, kInfinity};
    o.hi = -o.lo;
    for (uint32_t k = o.first_vertex; k < o.first_vertex + o.num_vertices; ++k) {
      o.lo = vmin(o.lo, positions[k]);
      o.hi = vmax(o.hi, positions[k]);
    }
  }
  for (const Instance& in : instances) {
    const SceneObject& o = objects[in.object];
    if (o.num_triangles == 0) continue;
    for (int c = 0; c < 8; ++c) {
      const Vec3 p = in.to_world.point({c & 1 ? o.hi.x : o.lo.x, c & 2 ? o.hi.y : o.lo.y, c & 4 ? o.hi.z : o.lo.z});
      lo = vmin(lo, p);
      hi = vmax(hi, p);
    }
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

  // Each light's derived data, then selection in proportion to power.
  v = view();
  environment = -1;
  std::vector<double> power(lights.size());
  for (size_t e = 0; e < lights.size(); ++e) {
    Light& l = lights[e];
    switch (l.type) {
      case LightType::Triangle: {
        TriangleLight& t = l.triangle;
        v.triangle(t.prim, t.v0, t.v1, t.v2);
        Vec3 c = cross(t.v1 - t.v0, t.v2 - t.v0);
        float len = length(c);
        t.area = 0.5f * len;
        t.normal = len > 0.f ? c / len : Vec3{0, 0, 1};
        if (t.texture >= 0) {
          t.uv0 = uvs[indices[3 * t.prim]];
          t.uv1 = uvs[indices[3 * t.prim + 1]];
          t.uv2 = uvs[indices[3 * t.prim + 2]];
        }
        break;
      }
      case LightType::Parallelogram: break;  // set by merge_parallelogram_emitters
      case LightType::Sphere: {
        const Sphere& sp = spheres[l.sphere.prim];
        l.sphere.center = sp.center;
        l.sphere.radius = sp.radius;
        l.sphere.flip = sp.flip_normals;
        l.sphere.frame = sp.frame;
        break;
      }
      case LightType::Constant:
      case LightType::Envmap: environment = int32_t(e); break;
      case LightType::Point:
      case LightType::Spot:
      case LightType::Directional: break;  // nothing derived
    }
    power[e] = phi(l, radius);
  }
  // With no emitting power at all, no light sampling.
  lights_emit = build_alias_table(power.data(), uint32_t(power.size()), light_alias, light_pmf);
  light_bvh = build_light_bvh(lights.data(), power.data(), uint32_t(lights.size()));
}

void fit_fov(FovAxis axis, double t, int width, int height, float& tx, float& ty) {
  const double aspect = double(width) / height;
  double x = t, y = t / aspect;  // FovAxis::X
  switch (axis) {
    case FovAxis::X: break;
    case FovAxis::Y: y = t, x = t * aspect; break;
    case FovAxis::Diagonal: x = t / std::sqrt(1 + 1 / (aspect * aspect)), y = x / aspect; break;
    case FovAxis::Smaller:
      if (aspect > 1) y = t, x = t * aspect;
      break;
    case FovAxis::Larger:
      if (aspect <= 1) y = t, x = t * aspect;
      break;
  }
  tx = float(x);
  ty = float(y);
}

void Scene::set_resolution(int width, int height) {
  const double x = camera.tan_half_x, y = camera.tan_half_y;
  const bool wide = camera.width > camera.height;
  double t = x;
  switch (fov_axis) {
    case FovAxis::X: t = x; break;
    case FovAxis::Y: t = y; break;
    case FovAxis::Diagonal: t = std::sqrt(x * x + y * y); break;
    case FovAxis::Smaller: t = wide ? y : x; break;
    case FovAxis::Larger: t = wide ? x : y; break;
  }
  fit_fov(fov_axis, t, width, height, camera.tan_half_x, camera.tan_half_y);
  camera.width = width;
  camera.height = height;
}

SceneView Scene::view() const {
  SceneView v;
  v.positions = positions.data();
  v.normals = normals.empty() ? nullptr : normals.data();
  v.indices = indices.data();
  v.tri_material = tri_material.data();
  v.tri_emitter = tri_emitter.data();
  v.uvs = uvs.empty() ? nullptr : uvs.data();
  v.colors = colors.empty() ? nullptr : colors.data();
  v.tri_normals = tri_normals.size() == num_triangles() && !tri_normals.empty() ? tri_normals.data() : nullptr;
  v.num_triangles = num_triangles();
  v.spheres = spheres.data();
  v.num_spheres = uint32_t(spheres.size());
  v.instances.list = instances.data();
  v.instances.count = uint32_t(instances.size());
  v.instances.objects = objects.data();
  v.instances.num_objects = uint32_t(objects.size());
  v.materials.list = materials.data();
  v.materials.bindings = texture_bindings.data();
  v.materials.count = uint32_t(materials.size());
  for (const Material& m : materials) {
    v.materials.masked |= m.masked();
    v.materials.mapped |= m.mapped();
  }
  v.textures.list = textures.data();
  v.textures.texels8 = texels8.data();
  v.textures.texelsf = texelsf.data();
  v.textures.srgb_table = srgb_table.data();
  v.textures.count = uint32_t(textures.size());
  v.lights.list = lights.data();
  v.lights.num_lights = uint32_t(lights.size());
  v.lights.environment = environment;
  v.lights.sampler.type = settings.light_sampler;
  v.lights.sampler.n = lights_emit ? uint32_t(lights.size()) : 0;
  v.lights.sampler.power.table = {light_alias.data(), light_pmf.data(), uint32_t(light_alias.size())};
  v.lights.sampler.bvh = light_bvh.view();
  v.lights.data.floats = light_data.data();
  v.lights.data.textures = v.textures;
  v.camera = camera;
  v.bounds_center = (bounds_min + bounds_max) * 0.5f;
  v.bounds_radius = std::max(0.5f * length(bounds_max - bounds_min), 1e-3f);
  return v;
}

}  // namespace luz
