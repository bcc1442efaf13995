// Where a camera stands: what every camera model shares. Mitsuba's
// conventions: camera space looks down +z with +y up; +x appears on the LEFT
// of the image (Mitsuba's lookat builds to_world with columns (left, up, dir,
// origin)).
#pragma once

#include "luz/math/vec.h"

namespace luz {

struct CameraFrame {
  // Columns of the camera-to-world matrix (linear part) and its origin.
  Vec3 x_axis{1, 0, 0}, y_axis{0, 1, 0}, z_axis{0, 0, 1}, origin{};

  // The camera-space vector (x, y, 1) in world space.
  LUZ_INLINE Vec3 direction(float x, float y) const { return x_axis * x + y_axis * y + z_axis; }
  // The camera-space point (x, y, 0) in world space.
  LUZ_INLINE Vec3 point(float x, float y) const { return origin + x_axis * x + y_axis * y; }
};

}  // namespace luz
