// Pinhole perspective camera: Mitsuba 3's `perspective` (fov, fov_axis,
// principal_point_offset_x/y; src/sensors/perspective.cpp). The ray leaves
// the pinhole, the frame's origin, through the point p of the plane z = 1 of
// camera space. Unlike Mitsuba, it starts at the pinhole, not at near_clip,
// and has no far_clip.
#pragma once

#include "luz/camera/frame.h"

namespace luz {

LUZ_INLINE Ray perspective_ray(const CameraFrame& f, Vec2 p) {
  Ray r;
  r.o = f.origin;
  r.d = normalize(f.direction(p.x, p.y));
  return r;
}

}  // namespace luz
