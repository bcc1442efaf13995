// Pinhole perspective camera with Mitsuba's conventions: camera space looks
// down +z with +y up; +x appears on the LEFT of the image (Mitsuba's lookat
// builds to_world with columns (left, up, dir, origin)).
#pragma once

#include "luz/math/vec.h"

namespace luz {

struct Camera {
  // Columns of the camera-to-world matrix (linear part) and its origin.
  Vec3 x_axis{1, 0, 0}, y_axis{0, 1, 0}, z_axis{0, 0, 1}, origin{};
  float tan_half_x = 0.5f, tan_half_y = 0.5f;
  int width = 256, height = 256;

  // (fx, fy): continuous film position in pixels, (0,0) the top-left corner.
  LUZ_INLINE Ray generate_ray(float fx, float fy) const {
    // fx · (2 / width): the division is the same for every ray, so it leaves the per-sample loop.
    float sx = (1.f - fx * (2.f / float(width))) * tan_half_x;
    float sy = (1.f - fy * (2.f / float(height))) * tan_half_y;
    Ray r;
    r.o = origin;
    r.d = normalize(x_axis * sx + y_axis * sy + z_axis);
    return r;
  }
};

}  // namespace luz
