#include "luz/scene/mesh_normals.h"

#include <algorithm>
#include <cmath>

namespace luz {

namespace {

// The angle between unit-free edge vectors a and b (0 when either is 0).
double angle_between(const Vec3& a, const Vec3& b) {
  const double la = length(a), lb = length(b);
  if (!(la > 0) || !(lb > 0)) return 0;
  return std::acos(std::clamp(double(dot(a, b)) / (la * lb), -1.0, 1.0));
}

}  // namespace

void compute_vertex_normals(std::vector<Vec3>& positions, std::vector<uint32_t>& indices, std::vector<Vec2>& uvs,
                            std::vector<Vec3>& normals, double max_angle_deg, std::vector<Color>* colors) {
  const size_t nv = positions.size(), nf = indices.size() / 3;
  // Unit face normals (zero for a degenerate face).
  std::vector<Vec3> fn(nf);
  for (size_t f = 0; f < nf; ++f) {
    const Vec3 &p0 = positions[indices[3 * f]], &p1 = positions[indices[3 * f + 1]], &p2 = positions[indices[3 * f + 2]];
    const Vec3 n = cross(p1 - p0, p2 - p0);
    const float l = length(n);
    fn[f] = l > 0.f && std::isfinite(l) ? n / l : Vec3{};
  }
  // The corners around each vertex (CSR: corner k = 3 f + j).
  std::vector<uint32_t> start(nv + 1, 0), corners(indices.size());
  for (uint32_t v : indices) ++start[v + 1];
  for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  {
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (size_t k = 0; k < indices.size(); ++k) corners[fill[indices[k]]++] = uint32_t(k);
  }
  const bool crease = max_angle_deg >= 0;
  const double cos_max = crease ? std::cos(max_angle_deg * M_PI / 180.0) : -2.0;
  normals.assign(nv, Vec3{});
  std::vector<int32_t> group(indices.size(), -1);  // per corner, its group at its vertex
  std::vector<uint32_t> vertex_of;                 // per group of the vertex at hand: its vertex
  std::vector<Vec3> sum;                           // and its angle-weighted normal sum
  for (size_t v = 0; v < nv; ++v) {
    const uint32_t a = start[v], b = start[v + 1];
    vertex_of.clear();
    for (uint32_t i = a; i < b; ++i) {
      const uint32_t ci = corners[i];
      if (group[ci] >= 0 || length(fn[ci / 3]) == 0.f) continue;  // degenerate faces join group 0 below
      // Group 0 keeps the vertex; each other group gets a copy.
      const int32_t g = int32_t(vertex_of.size());
      vertex_of.push_back(g == 0 ? uint32_t(v) : uint32_t(positions.size()));
      if (g > 0) {
        positions.push_back(positions[v]);
        if (!uvs.empty()) uvs.push_back(uvs[v]);
        if (colors && !colors->empty()) colors->push_back((*colors)[v]);
        normals.push_back(Vec3{});
      }
      group[ci] = g;
      const Vec3 seed = fn[ci / 3];
      for (uint32_t j = i + 1; j < b; ++j) {
        const uint32_t cj = corners[j];
        if (group[cj] < 0 && (!crease || double(dot(seed, fn[cj / 3])) > cos_max)) group[cj] = g;
      }
    }
    if (vertex_of.empty()) vertex_of.push_back(uint32_t(v));
    sum.assign(vertex_of.size(), Vec3{});
    for (uint32_t i = a; i < b; ++i) {
      const uint32_t c = corners[i], f = c / 3, j = c % 3;
      if (group[c] < 0) group[c] = 0;
      const Vec3& p = positions[v];
      const Vec3 e1 = positions[indices[3 * f + (j + 1) % 3]] - p, e2 = positions[indices[3 * f + (j + 2) % 3]] - p;
      sum[size_t(group[c])] = sum[size_t(group[c])] + fn[f] * float(angle_between(e1, e2));
    }
    // A group's seed face is not degenerate, so its sum is not 0 unless its
    // faces' angles all are (then the vertex's normal stays 0).
    for (size_t g = 0; g < vertex_of.size(); ++g) {
      const float l = length(sum[g]);
      normals[vertex_of[g]] = l > 0.f && std::isfinite(l) ? sum[g] / l : Vec3{};
    }
    for (uint32_t i = a; i < b; ++i) indices[corners[i]] = vertex_of[size_t(group[corners[i]])];
  }
}

bool normals_are_flat(const std::vector<Vec3>& positions, const std::vector<uint32_t>& indices,
                      const std::vector<Vec3>& normals) {
  for (size_t f = 0; f + 2 < indices.size(); f += 3) {
    const Vec3 &p0 = positions[indices[f]], &p1 = positions[indices[f + 1]], &p2 = positions[indices[f + 2]];
    const Vec3 n = cross(p1 - p0, p2 - p0);
    const float l = length(n);
    if (!(l > 0.f)) continue;
    for (int k = 0; k < 3; ++k)
      if (!(dot(n / l, normals[indices[f + size_t(k)]]) > 1.f - 1e-6f)) return false;
  }
  return true;
}

}  // namespace luz
