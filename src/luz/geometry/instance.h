// Instancing, for both devices: an object's triangles are stored once in
// object space (a range of the scene's triangle arrays) and placed by
// instances, each an affine map. A hit on an instance names it
// (Hit::inst); the surface there is computed from the triangle's vertices
// mapped to world space (SceneView::interaction), so that an instanced hit
// gives what the same triangle flattened into the scene would.
#pragma once

#include "luz/math/vec.h"

namespace luz {

// An affine map p -> M p + t as 3 rows of (M row, t): 48 bytes, Embree's
// RTC_FORMAT_FLOAT3X4_ROW_MAJOR.
struct Affine3 {
  float m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};

  LUZ_INLINE Vec3 point(Vec3 p) const {
    return {m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
            m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
            m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3]};
  }
  LUZ_INLINE Vec3 vector(Vec3 d) const {
    return {m[0][0] * d.x + m[0][1] * d.y + m[0][2] * d.z, m[1][0] * d.x + m[1][1] * d.y + m[1][2] * d.z,
            m[2][0] * d.x + m[2][1] * d.y + m[2][2] * d.z};
  }
  // The transpose of the linear part applied to n: with this the inverse
  // map, a normal's map (the inverse transpose of the forward map).
  LUZ_INLINE Vec3 transpose_vector(Vec3 n) const {
    return {m[0][0] * n.x + m[1][0] * n.y + m[2][0] * n.z, m[0][1] * n.x + m[1][1] * n.y + m[2][1] * n.z,
            m[0][2] * n.x + m[1][2] * n.y + m[2][2] * n.z};
  }
};

inline constexpr uint32_t kNoInstance = 0xffffffffu;  // Hit::inst of world geometry

// An object: triangles [first_triangle, first_triangle + num_triangles) of
// the scene's arrays, whose vertices are [first_vertex, first_vertex +
// num_vertices); lo, hi: their bounds in object space.
struct SceneObject {
  uint32_t first_triangle = 0, num_triangles = 0;
  uint32_t first_vertex = 0, num_vertices = 0;
  Vec3 lo, hi;
};

// One placement of an object. The winding is kept (a mirroring map turns the
// geometric normal, as the flattened triangles' would turn: pbrt and Mitsuba
// do the same).
struct Instance {
  Affine3 to_world, to_object;  // to_object: to_world's inverse
  uint32_t object = 0;

  // A vertex normal to world space: the inverse transpose, normalised; zero
  // stays zero (a vertex shaded flat).
  LUZ_INLINE Vec3 normal(Vec3 n) const {
    const Vec3 w = to_object.transpose_vector(n);
    const float len = length(w);
    return len > 0.f ? w / len : Vec3{};
  }
};

struct InstancesView {
  const Instance* list = nullptr;
  uint32_t count = 0;  // 0: no instances
  const SceneObject* objects = nullptr;
  uint32_t num_objects = 0;
};

}  // namespace luz
