#include "luz/accel/embree_tracer.h"

#include <cstring>
#include <stdexcept>
#include <string>

namespace luz {

namespace {


void sphere_bounds(const RTCBoundsFunctionArguments* args) {
  const Sphere& s = static_cast<const Sphere*>(args->geometryUserPtr)[args->primID];
  RTCBounds* b = args->bounds_o;
  b->lower_x = s.center.x - s.radius;
  b->lower_y = s.center.y - s.radius;
  b->lower_z = s.center.z - s.radius;
  b->upper_x = s.center.x + s.radius;
  b->upper_y = s.center.y + s.radius;
  b->upper_z = s.center.z + s.radius;
}

// Only single rays (rtcIntersect1 / rtcOccluded1) are traced, so N == 1.
void sphere_intersect(const RTCIntersectFunctionNArguments* args) {
  if (!args->valid[0]) return;
  const Sphere& s = static_cast<const Sphere*>(args->geometryUserPtr)[args->primID];
  RTCRayHit* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);
  Vec3 o{rh->ray.org_x, rh->ray.org_y, rh->ray.org_z}, d{rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z};
  float t = intersect_sphere(s.center, s.radius, o, d, rh->ray.tfar);
  if (!(t > rh->ray.tnear)) return;
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

void sphere_occluded(const RTCOccludedFunctionNArguments* args) {
  if (!args->valid[0]) return;
  const Sphere& s = static_cast<const Sphere*>(args->geometryUserPtr)[args->primID];
  RTCRay* r = reinterpret_cast<RTCRay*>(args->ray);
  Vec3 o{r->org_x, r->org_y, r->org_z}, d{r->dir_x, r->dir_y, r->dir_z};
  float t = intersect_sphere(s.center, s.radius, o, d, r->tfar);
  if (t > r->tnear) r->tfar = -kInfinity;
}

}  // namespace

EmbreeScene::EmbreeScene(const Scene& scene) {
  device_ = rtcNewDevice(nullptr);
  if (!device_) throw std::runtime_error("Embree: cannot create device");
  scene_ = rtcNewScene(device_);
  rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);

  size_t nv = scene.positions.size(), nt = scene.num_triangles();
  if (nt > 0) {
  RTCGeometry tri = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
  // Embree reads vertices with 16-byte loads: its own buffers are padded.
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(tri, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                        3 * sizeof(float), nv));
  std::memcpy(v, scene.positions.data(), nv * 3 * sizeof(float));
  auto* ix = static_cast<unsigned*>(rtcSetNewGeometryBuffer(tri, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                            3 * sizeof(unsigned), nt));
  std::memcpy(ix, scene.indices.data(), nt * 3 * sizeof(unsigned));
  rtcCommitGeometry(tri);
  rtcAttachGeometryByID(scene_, tri, EmbreeTracer::kTriangleGeom);
  rtcReleaseGeometry(tri);
  }

  if (!scene.spheres.empty()) {
    RTCGeometry sph = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(sph, unsigned(scene.spheres.size()));
    rtcSetGeometryUserData(sph, const_cast<Sphere*>(scene.spheres.data()));
    rtcSetGeometryBoundsFunction(sph, sphere_bounds, nullptr);
    rtcSetGeometryIntersectFunction(sph, sphere_intersect);
    rtcSetGeometryOccludedFunction(sph, sphere_occluded);
    rtcCommitGeometry(sph);
    rtcAttachGeometryByID(scene_, sph, EmbreeTracer::kSphereGeom);
    rtcReleaseGeometry(sph);
  }
  rtcCommitScene(scene_);
  if (rtcGetDeviceError(device_) != RTC_ERROR_NONE) throw std::runtime_error("Embree: scene build failed");
}

EmbreeTracer EmbreeScene::tracer() const { return EmbreeTracer{scene_}; }

EmbreeScene::~EmbreeScene() {
  if (scene_) rtcReleaseScene(scene_);
  if (device_) rtcReleaseDevice(device_);
}

}  // namespace luz
