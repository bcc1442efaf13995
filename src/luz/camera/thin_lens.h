// Thin-lens perspective camera: Mitsuba 3's `thinlens` (aperture_radius,
// focus_distance; src/sensors/thinlens.cpp; pbrt-v4 §5.2.3). The lens is a
// disk of radius aperture_radius (scene units) around the origin of the plane
// z = 0 of camera space. The ray through film point p (on the plane z = 1, as
// the pinhole's) starts at the lens point a = aperture_radius · disk(u) and
// passes through p · focus_distance, where the pinhole ray through p meets
// the focal plane z = focus_distance (a plane, as Mitsuba's, not a sphere).
// Points on that plane image sharply; a point at depth z images, on the plane
// z = 1, to a disk of radius aperture_radius · |1/focus_distance − 1/z|
// around its pinhole image (the circle of confusion). Mitsuba's near_clip is
// not applied (perspective.h).
#pragma once

#include "luz/camera/frame.h"
#include "luz/sampling/warp.h"

namespace luz {

struct ThinLens {
  float aperture_radius = 0.f;  // scene units
  float focus_distance = 1.f;   // depth of the focal plane along camera +z, scene units

  // u in [0,1)²: the lens sample.
  LUZ_INLINE Ray ray(const CameraFrame& f, Vec2 p, Vec2 u) const {
    const Vec2 disk = square_to_uniform_disk(u);
    const float ax = disk.x * aperture_radius, ay = disk.y * aperture_radius;
    // (p · fd − a) / fd: the direction scaled so that its z is 1, which makes
    // aperture_radius 0 give the pinhole's ray bit for bit.
    Ray r;
    r.o = f.point(ax, ay);
    r.d = normalize(f.direction(p.x - ax / focus_distance, p.y - ay / focus_distance));
    return r;
  }
};

}  // namespace luz
