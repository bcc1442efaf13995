// Orthographic camera: Mitsuba 3's `orthographic`
// (src/sensors/orthographic.cpp). Rays run along camera +z from the film
// point p, the film spanning [-1, 1] × [-1/aspect, 1/aspect] of camera space
// (square pixels); to_world's scale in x and y sets the size of the view, so
// the frame's x_axis and y_axis keep their lengths (z_axis is a unit vector)
// and its origin is to_world's image of (0, 0, near_clip), where Mitsuba's
// rays start. No far_clip.
#pragma once

#include "luz/camera/frame.h"

namespace luz {

LUZ_INLINE Ray orthographic_ray(const CameraFrame& f, Vec2 p) {
  Ray r;
  r.o = f.point(p.x, p.y);
  r.d = f.z_axis;
  return r;
}

}  // namespace luz
