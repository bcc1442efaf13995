// Vertex normals computed for meshes that come without them (Mitsuba's
// meshes: Mitsuba 3 shades them smooth unless face_normals is set) or whose
// normals a scene asks to rebuild (Mitsuba 0.5/0.6's max_smooth_angle).
// Host only.
#pragma once

#include <cstdint>
#include <vector>

#include "luz/math/vec.h"

namespace luz {

// Sets `normals` (one per vertex) to the angle-weighted sum of the unit face
// normals around each vertex, normalised: the face normal weighted by the
// face's angle at the vertex, as Mitsuba 3's recompute_vertex_normals
// (0 at a vertex of degenerate faces only).
//
// max_angle_deg ≥ 0 (Mitsuba 0.6's maxSmoothAngle): first, at each vertex,
// the faces around it are grouped: each face not yet grouped starts a group
// and takes every later ungrouped face whose normal is within max_angle_deg
// of its own (degenerate faces join the first group); each group beyond the
// first gets a copy of the vertex (and of its uv and colour), so creases sharper than
// the angle stay sharp. `indices` then refer to the copies. max_angle_deg
// < 0: one group per vertex.
void compute_vertex_normals(std::vector<Vec3>& positions, std::vector<uint32_t>& indices, std::vector<Vec2>& uvs,
                            std::vector<Vec3>& normals, double max_angle_deg = -1, std::vector<Color>* colors = nullptr);

// Whether every vertex normal is (within float rounding, 1e-6 in its
// cosine) the normal of each face around it: shading by them is shading flat.
bool normals_are_flat(const std::vector<Vec3>& positions, const std::vector<uint32_t>& indices,
                      const std::vector<Vec3>& normals);

}  // namespace luz
