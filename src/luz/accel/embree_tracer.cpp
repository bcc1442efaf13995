#include "luz/accel/embree_tracer.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

namespace luz {

namespace {


// A sphere geometry's user data: the spheres, or in a masked scene the
// EmbreeAlpha (whose opacity view holds them).
template <bool Masked>
const Sphere& user_sphere(void* user, unsigned prim) {
  if constexpr (Masked) return static_cast<const EmbreeAlpha*>(user)->opacity.spheres[prim];
  else return static_cast<const Sphere*>(user)[prim];
}

// The alpha test of a sphere hit at t (Masked: a scene with masked materials).
template <bool Masked>
bool sphere_kept(void* user, unsigned prim, Vec3 o, Vec3 d, float t) {
  if constexpr (Masked) {
    Hit hit;
    hit.t = t;
    hit.prim = prim;
    hit.kind = PrimKind::Sphere;
    return static_cast<const EmbreeAlpha*>(user)->opacity.keeps(o, d, hit);
  } else {
    return true;
  }
}

template <bool Masked>
void sphere_bounds(const RTCBoundsFunctionArguments* args) {
  const Sphere& s = user_sphere<Masked>(args->geometryUserPtr, args->primID);
  RTCBounds* b = args->bounds_o;
  b->lower_x = s.center.x - s.radius;
  b->lower_y = s.center.y - s.radius;
  b->lower_z = s.center.z - s.radius;
  b->upper_x = s.center.x + s.radius;
  b->upper_y = s.center.y + s.radius;
  b->upper_z = s.center.z + s.radius;
}

// Only single rays (rtcIntersect1 / rtcOccluded1) are traced, so N == 1.
template <bool Masked>
void sphere_intersect(const RTCIntersectFunctionNArguments* args) {
  if (!args->valid[0]) return;
  const Sphere& s = user_sphere<Masked>(args->geometryUserPtr, args->primID);
  RTCRayHit* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);
  Vec3 o{rh->ray.org_x, rh->ray.org_y, rh->ray.org_z}, d{rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z};
  float t = intersect_sphere(s.center, s.radius, o, d, rh->ray.tfar);
  if (!(t > rh->ray.tnear)) return;
  if (!sphere_kept<Masked>(args->geometryUserPtr, args->primID, o, d, t)) return;
  rh->ray.tfar = t;
  rh->hit.u = rh->hit.v = 0.f;
  Vec3 n = normalize(o + d * t - s.center);
  rh->hit.Ng_x = n.x;
  rh->hit.Ng_y = n.y;
  rh->hit.Ng_z = n.z;
  rh->hit.primID = args->primID;
  rh->hit.geomID = args->geomID;
  rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

template <bool Masked>
void sphere_occluded(const RTCOccludedFunctionNArguments* args) {
  if (!args->valid[0]) return;
  const Sphere& s = user_sphere<Masked>(args->geometryUserPtr, args->primID);
  RTCRay* r = reinterpret_cast<RTCRay*>(args->ray);
  Vec3 o{r->org_x, r->org_y, r->org_z}, d{r->dir_x, r->dir_y, r->dir_z};
  float t = intersect_sphere(s.center, s.radius, o, d, r->tfar);
  if (t > r->tnear && sphere_kept<Masked>(args->geometryUserPtr, args->primID, o, d, t)) r->tfar = -kInfinity;
}

// The alpha test on the quad geometry of a masked scene, as Embree's filter
// function of both queries (intersect and occluded): a hit it sets invalid
// is ignored and traversal goes on.
void quad_alpha_filter(const RTCFilterFunctionNArguments* args) {
  const auto& alpha = *static_cast<const EmbreeAlpha*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (!args->valid[i]) continue;
    Hit hit;
    hit.kind = PrimKind::Triangle;
    EmbreeTracer::quad_hit(alpha.quads[RTCHitN_primID(args->hit, args->N, i)], RTCHitN_u(args->hit, args->N, i),
                           RTCHitN_v(args->hit, args->N, i), hit);
    const Vec3 o{RTCRayN_org_x(args->ray, args->N, i), RTCRayN_org_y(args->ray, args->N, i),
                 RTCRayN_org_z(args->ray, args->N, i)};
    const Vec3 d{RTCRayN_dir_x(args->ray, args->N, i), RTCRayN_dir_y(args->ray, args->N, i),
                 RTCRayN_dir_z(args->ray, args->N, i)};
    if (!alpha.opacity.keeps(o, d, hit)) args->valid[i] = 0;
  }
}

float box_area(Vec3 lo, Vec3 hi) {
  Vec3 d = hi - lo;
  return 2.f * (d.x * d.y + d.y * d.z + d.z * d.x);
}

bool compact_pair(const Scene& scene, const uint32_t* a, const uint32_t* b) {
  Vec3 lo[2], hi[2];
  for (int h = 0; h < 2; ++h) {
    const uint32_t* t = h == 0 ? a : b;
    lo[h] = hi[h] = scene.positions[t[0]];
    for (int j = 1; j < 3; ++j) {
      lo[h] = vmin(lo[h], scene.positions[t[j]]);
      hi[h] = vmax(hi[h], scene.positions[t[j]]);
    }
  }
  float joint = box_area(vmin(lo[0], lo[1]), vmax(hi[0], hi[1]));
  return joint <= 1.5f * std::max(box_area(lo[0], hi[0]), box_area(lo[1], hi[1]));
}

// Triangles [first, end) as EmbreeQuads appended to `quads`, with their
// four vertex indices (less first_vertex) appended to `ix`.
void make_quads(const Scene& scene, uint32_t first, uint32_t end, uint32_t first_vertex, std::vector<EmbreeQuad>& quads,
                std::vector<unsigned>& ix) {
  // Pairs of consecutive triangles sharing an edge as quads, the others as degenerate ones.
  for (uint32_t k = first; k < end; ++k) {
    const uint32_t* a = &scene.indices[3 * size_t(k)];
    if (k + 1 < end) {
      const uint32_t* b = &scene.indices[3 * size_t(k) + 3];
      int ia = -1, jb = -1, shared = 0;
      for (int i = 0; i < 3; ++i) {
        bool in_b = a[i] == b[0] || a[i] == b[1] || a[i] == b[2];
        shared += in_b;
        if (!in_b) ia = i;
      }
      for (int j = 0; j < 3; ++j)
        if (b[j] != a[0] && b[j] != a[1] && b[j] != a[2]) jb = j;
      // Exactly one shared edge, no repeated vertex in either triangle, and a
      // compact pair: its joint box at most 1.5× the larger half's (by
      // surface area), so that pairs which bend or form long strips stay
      // separate (Sponza inside: as fast as with triangles only, within 3%;
      // with every pair merged and the rest in a second, triangle geometry,
      // 23% slower: Embree traverses one BVH per primitive type).
      if (shared == 2 && ia >= 0 && jb >= 0 && a[0] != a[1] && a[1] != a[2] && a[0] != a[2] && b[0] != b[1] &&
          b[1] != b[2] && b[0] != b[2] && compact_pair(scene, a, b)) {
        const uint32_t quad[4] = {a[ia], a[(ia + 1) % 3], b[jb], a[(ia + 2) % 3]};
        EmbreeQuad q;
        q.tri = k;
        for (int h = 0; h < 2; ++h) {
          const uint32_t* t = h == 0 ? a : b;
          for (int j = 0; j < 2; ++j)
            for (uint8_t s = 0; s < 4; ++s)
              if (quad[s] == t[j + 1]) q.slot[h][j] = s;
        }
        quads.push_back(q);
        for (uint32_t v : quad) ix.push_back(v - first_vertex);
        ++k;
        continue;
      }
    }
    // A lone triangle: the degenerate quad (a0, a1, a2, a2), whose first half is
    // the triangle (Embree builds one BVH per primitive type, so one type for all).
    EmbreeQuad q;
    q.tri = k;
    q.slot[0][0] = 1;
    q.slot[0][1] = 3;
    q.slot[1][0] = q.slot[1][1] = EmbreeQuad::kLone;
    quads.push_back(q);
    const uint32_t quad[4] = {a[0], a[1], a[2], a[2]};
    for (uint32_t v : quad) ix.push_back(v - first_vertex);
  }
}

// A quad geometry over vertices [first_vertex, first_vertex + nv) of the
// scene, with the alpha test when `alpha` is given.
RTCGeometry quad_geometry(RTCDevice device, const Scene& scene, uint32_t first_vertex, size_t nv,
                          const std::vector<unsigned>& ix, EmbreeAlpha* alpha) {
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_QUAD);
  // Embree reads vertices with 16-byte loads: its own buffers are padded.
  auto* v = static_cast<float*>(
      rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
  std::memcpy(v, scene.positions.data() + first_vertex, nv * 3 * sizeof(float));
  auto* q = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT4,
                                                           4 * sizeof(unsigned), ix.size() / 4));
  std::memcpy(q, ix.data(), ix.size() * sizeof(unsigned));
  if (alpha) {
    rtcSetGeometryUserData(g, alpha);
    rtcSetGeometryIntersectFilterFunction(g, quad_alpha_filter);
    rtcSetGeometryOccludedFilterFunction(g, quad_alpha_filter);
  }
  rtcCommitGeometry(g);
  return g;
}

}  // namespace

// Without instances, one scene; with them, the world's quads and spheres
// beside one instance geometry per instance (geometry ID kFirstInstanceGeom
// + its index), each over its object's own scene, built once.
EmbreeScene::EmbreeScene(const Scene& scene) {
  device_ = rtcNewDevice(nullptr);
  if (!device_) throw std::runtime_error("Embree: cannot create device");
  scene_ = rtcNewScene(device_);
  rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);

  const uint32_t nt = scene.num_triangles();
  const size_t nv = scene.objects.empty() ? scene.positions.size() : scene.objects.front().first_vertex;
  std::vector<unsigned> quad_ix;
  make_quads(scene, 0, nt, 0, quads_, quad_ix);
  std::vector<std::vector<unsigned>> object_ix(scene.objects.size());
  std::vector<uint32_t> object_quads(scene.objects.size());
  for (size_t k = 0; k < scene.objects.size(); ++k) {
    const SceneObject& o = scene.objects[k];
    object_quads[k] = uint32_t(quads_.size());
    make_quads(scene, o.first_triangle, o.first_triangle + o.num_triangles, o.first_vertex, quads_, object_ix[k]);
  }
  // Only a scene with masked materials runs the alpha test (and pays for it).
  alpha_.opacity = scene.view().opacity();
  alpha_.quads = quads_.data();
  const bool masked = alpha_.opacity.materials != nullptr;
  if (!quad_ix.empty()) {
    RTCGeometry g = quad_geometry(device_, scene, 0, nv, quad_ix, masked ? &alpha_ : nullptr);
    rtcAttachGeometryByID(scene_, g, EmbreeTracer::kQuadGeom);
    rtcReleaseGeometry(g);
  }
  if (!scene.spheres.empty()) {
    RTCGeometry sph = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(sph, unsigned(scene.spheres.size()));
    if (masked) {
      rtcSetGeometryUserData(sph, &alpha_);
      rtcSetGeometryBoundsFunction(sph, sphere_bounds<true>, nullptr);
      rtcSetGeometryIntersectFunction(sph, sphere_intersect<true>);
      rtcSetGeometryOccludedFunction(sph, sphere_occluded<true>);
    } else {
      rtcSetGeometryUserData(sph, const_cast<Sphere*>(scene.spheres.data()));
      rtcSetGeometryBoundsFunction(sph, sphere_bounds<false>, nullptr);
      rtcSetGeometryIntersectFunction(sph, sphere_intersect<false>);
      rtcSetGeometryOccludedFunction(sph, sphere_occluded<false>);
    }
    rtcCommitGeometry(sph);
    rtcAttachGeometryByID(scene_, sph, EmbreeTracer::kSphereGeom);
    rtcReleaseGeometry(sph);
  }

  object_alpha_.resize(scene.objects.size(), alpha_);
  object_scenes_.resize(scene.objects.size(), nullptr);
  for (size_t k = 0; k < scene.objects.size(); ++k) {
    if (object_ix[k].empty()) continue;
    const SceneObject& o = scene.objects[k];
    object_alpha_[k].quads = quads_.data() + object_quads[k];
    object_scenes_[k] = rtcNewScene(device_);
    rtcSetSceneBuildQuality(object_scenes_[k], RTC_BUILD_QUALITY_HIGH);
    RTCGeometry g =
        quad_geometry(device_, scene, o.first_vertex, o.num_vertices, object_ix[k], masked ? &object_alpha_[k] : nullptr);
    rtcAttachGeometryByID(object_scenes_[k], g, EmbreeTracer::kQuadGeom);
    rtcReleaseGeometry(g);
    rtcCommitScene(object_scenes_[k]);
  }
  instance_quads_.resize(scene.instances.size());
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    const Instance& in = scene.instances[k];
    instance_quads_[k] = object_quads[in.object];
    if (!object_scenes_[in.object]) continue;
    RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(g, object_scenes_[in.object]);
    rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, &in.to_world.m[0][0]);
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(scene_, g, EmbreeTracer::kFirstInstanceGeom + unsigned(k));
    rtcReleaseGeometry(g);
  }
  rtcCommitScene(scene_);
  if (rtcGetDeviceError(device_) != RTC_ERROR_NONE) throw std::runtime_error("Embree: scene build failed");
}

EmbreeTracer EmbreeScene::tracer() const { return EmbreeTracer{scene_, quads_.data(), instance_quads_.data()}; }

EmbreeScene::~EmbreeScene() {
  if (scene_) rtcReleaseScene(scene_);
  for (RTCScene o : object_scenes_)
    if (o) rtcReleaseScene(o);
  if (device_) rtcReleaseDevice(device_);
}

}  // namespace luz
