// CPU ray queries through Embree 3: triangles as Embree quad geometry (pairs
// sharing an edge as one quad, see EmbreeQuad), analytic spheres as user
// geometry running Luz's own intersect_sphere(); in a scene with masked
// materials, the alpha test as the quads' filter function and inside the
// spheres' functions. Instances as Embree instances of one scene per
// object; a scene without instances stays one flat Embree scene.
#pragma once

#include <cstddef>
#include <cstring>

#include <embree3/rtcore.h>
#if defined(__SSE__)
#include <immintrin.h>
#endif

#include <vector>

#include "luz/scene/scene.h"

namespace luz {

struct EmbreeTracer;

// Two consecutive triangles k, k+1 that share an edge, traced by Embree as
// one quad (v0, v1, v2, v3) whose diagonal v1-v3 is that edge, so Embree's
// halves (v0, v1, v3) and (v2, v3, v1) are exactly triangles k and k+1
// (a lone triangle: the degenerate quad (a0, a1, a2, a2)). Fewer primitives:
// raw Embree on the Cornell box's recorded rays 25 -> 37 Mrays/s. slot[h][j]:
// the quad vertex that is vertex j+1 of triangle k+h (for its barycentrics).
struct EmbreeQuad {
  static constexpr uint8_t kLone = 0xff;  // slot[1][0] of a lone triangle's quad
  uint32_t tri;
  uint8_t slot[2][2];
};

// The alpha test's data (material/opacity.h), Embree's user data for the
// geometry of a masked scene.
struct EmbreeAlpha {
  OpacityView opacity;
  const EmbreeQuad* quads = nullptr;  // Embree quad primID -> triangles
};

class EmbreeScene {
 public:
  explicit EmbreeScene(const Scene& scene);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  RTCScene handle() const { return scene_; }
  EmbreeTracer tracer() const;

 private:
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  std::vector<EmbreeQuad> quads_;  // Embree quad primID -> triangles: the world's, then each object's
  std::vector<uint32_t> instance_quads_;  // per instance, its object's first quad in quads_
  EmbreeAlpha alpha_;
  std::vector<EmbreeAlpha> object_alpha_;
  std::vector<RTCScene> object_scenes_;  // null for an object without triangles
};

// The Tracer the integrator is instantiated with on the CPU.
struct EmbreeTracer {
  static constexpr unsigned kQuadGeom = 0, kSphereGeom = 1, kFirstInstanceGeom = 2;
  RTCScene scene;
  const EmbreeQuad* quads = nullptr;
  const uint32_t* instance_quads = nullptr;  // EmbreeScene::instance_quads_

  // Embree's hit on a quad (u, v in the quad's parametrisation) as a hit on
  // one of its two triangles with that triangle's barycentrics.
  static void quad_hit(const EmbreeQuad& q, float u, float v, Hit& hit) {
    if (q.slot[1][0] == EmbreeQuad::kLone) {
      // (a0, a1, a2, a2): the first half is the triangle; should Embree report
      // the degenerate half (the segment a1-a2), it is the same triangle's edge.
      hit.prim = q.tri;
      hit.u = u + v <= 1.f ? u : 1.f - v;
      hit.v = v;
      return;
    }
    // Which half was hit is a coin toss per ray: no branch, no selects. Both
    // halves' weights of the quad's four vertices are computed, and the half
    // (the compare as an integer) indexes them.
    const float w[2][4] = {{1.f - u - v, u, 0.f, v}, {0.f, 1.f - v, u + v - 1.f, 1.f - u}};
    const int h = int(1.f < u + v);
    hit.prim = q.tri + uint32_t(h);
    hit.u = w[h][q.slot[h][0]];
    hit.v = w[h][q.slot[h][1]];
  }

  // Embree's ray is written as three 16-byte vectors, as its traversal
  // reads it: origin and tnear, direction and time, tfar with mask, id and
  // flags. A 16-byte load forwards from one store of those 16 bytes, but
  // not from four 4-byte ones: written float by float, each of Embree's
  // first loads waited for the four stores to reach the cache (the stall
  // took ~3.5% of the bundled box's time, cpu-clock samples).
  using F4 = float __attribute__((vector_size(16)));
  using I4 = int32_t __attribute__((vector_size(16)));
  static_assert(offsetof(RTCRay, tnear) == 12 && offsetof(RTCRay, dir_x) == 16 && offsetof(RTCRay, time) == 28 &&
                    offsetof(RTCRay, tfar) == 32 && offsetof(RTCRay, mask) == 36 && offsetof(RTCRay, id) == 40 &&
                    offsetof(RTCRay, flags) == 44,
                "Embree 3's RTCRay layout");

  // Embree's contract (RayK::valid): every origin and direction component
  // finite and at most FLT_LARGE (1.844e18) in magnitude, tmax not NaN. Its
  // debug assertions abort on anything else, so such a ray (a NaN from
  // degenerate input, or a point beyond the range) is reported as a miss.
  // Fills r and says whether it is valid.
  static bool fill_ray(RTCRay& r, const Ray& ray) {
    constexpr float kLarge = 1.844e18f;
    constexpr I4 kAbs = {0x7fffffff, 0x7fffffff, 0x7fffffff, 0x7fffffff};
    constexpr F4 kLarge4 = {kLarge, kLarge, kLarge, kLarge};
    const F4 o = {ray.o.x, ray.o.y, ray.o.z, 0.f};  // tnear 0
    const F4 d = {ray.d.x, ray.d.y, ray.d.z, 0.f};  // time 0
    const F4 tmax = {ray.tmax, 0.f, 0.f, 0.f};
    const I4 t = (I4)tmax | (I4){0, -1, 0, 0};  // tfar, mask ~0u, id, flags
    std::memcpy(&r.org_x, &o, sizeof o);
    std::memcpy(&r.dir_x, &d, sizeof d);
    std::memcpy(&r.tfar, &t, sizeof t);
    // |x| <= kLarge (false for NaN too) and tmax == tmax, in every lane.
    const I4 ok = ((F4)((I4)o & kAbs) <= kLarge4) & ((F4)((I4)d & kAbs) <= kLarge4) & (tmax == tmax);
#if defined(__SSE__)
    return _mm_movemask_ps((__m128)ok) == 0xf;  // one instruction for the four lanes
#else
    return ((ok[0] & ok[1]) & (ok[2] & ok[3])) != 0;
#endif
  }

  bool intersect(const Ray& ray, Hit& hit) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh;
    if (!fill_ray(rh.ray, ray)) return false;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
    hit.t = rh.ray.tfar;
    hit.inst = kNoInstance;
    if (rh.hit.geomID == kQuadGeom) {
      hit.kind = PrimKind::Triangle;
      uint32_t quad = rh.hit.primID;
      if (rh.hit.instID[0] != RTC_INVALID_GEOMETRY_ID) {
        hit.inst = rh.hit.instID[0] - kFirstInstanceGeom;
        quad += instance_quads[hit.inst];
      }
      quad_hit(quads[quad], rh.hit.u, rh.hit.v, hit);
      return true;
    }
    hit.kind = PrimKind::Sphere;
    hit.prim = rh.hit.primID;
    hit.u = hit.v = 0.f;
    return true;
  }

  bool occluded(const Ray& ray) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay r;
    if (!fill_ray(r, ray)) return true;  // no light along a ray that cannot be traced
    rtcOccluded1(scene, &ctx, &r);
    return r.tfar < 0.f;
  }
};

}  // namespace luz
