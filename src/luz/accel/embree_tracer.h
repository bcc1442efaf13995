// CPU ray queries through Embree 3: triangles as Embree triangle geometry,
// analytic spheres as user geometry running Luz's own intersect_sphere().
#pragma once

#include <embree3/rtcore.h>

#include "luz/scene/scene.h"

namespace luz {

struct EmbreeTracer;

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
};

// The Tracer the integrator is instantiated with on the CPU.
struct EmbreeTracer {
  static constexpr unsigned kTriangleGeom = 0, kSphereGeom = 1;
  RTCScene scene;

  bool intersect(const Ray& ray, Hit& hit) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh;
    rh.ray.org_x = ray.o.x;
    rh.ray.org_y = ray.o.y;
    rh.ray.org_z = ray.o.z;
    rh.ray.dir_x = ray.d.x;
    rh.ray.dir_y = ray.d.y;
    rh.ray.dir_z = ray.d.z;
    rh.ray.tnear = 0.f;
    rh.ray.tfar = ray.tmax;
    rh.ray.mask = ~0u;
    rh.ray.flags = 0;
    rh.ray.time = 0.f;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
    hit.t = rh.ray.tfar;
    hit.prim = rh.hit.primID;
    hit.kind = rh.hit.geomID == kSphereGeom ? PrimKind::Sphere : PrimKind::Triangle;
    hit.u = rh.hit.u;
    hit.v = rh.hit.v;
    return true;
  }

  bool occluded(const Ray& ray) const {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay r;
    r.org_x = ray.o.x;
    r.org_y = ray.o.y;
    r.org_z = ray.o.z;
    r.dir_x = ray.d.x;
    r.dir_y = ray.d.y;
    r.dir_z = ray.d.z;
    r.tnear = 0.f;
    r.tfar = ray.tmax;
    r.mask = ~0u;
    r.flags = 0;
    r.time = 0.f;
    rtcOccluded1(scene, &ctx, &r);
    return r.tfar < 0.f;
  }
};

}  // namespace luz
