// Test geometry and random numbers shared by the BVH and instancing tests.
#pragma once

#include <cmath>
#include <cstdint>

#include "luz/scene/scene_builder.h"

namespace luz_test {

// Deterministic random numbers (splitmix64).
struct Rng {
  uint64_t s;
  explicit Rng(uint64_t seed) : s(seed * 0x9E3779B97F4A7C15ull + 0x1234567ull) {}
  uint64_t next() {
    uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  float uniform() { return float(next() >> 40) * 0x1p-24f; }
};

// A UV sphere of radius 1 and 2 nu (nv - 1) triangles, with per-vertex
// normals and texture coordinates.
inline luz::TriangleMesh uv_sphere(int nu, int nv) {
  luz::TriangleMesh m;
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) {
      const float th = luz::kPi * float(j) / float(nv), ph = 2.f * luz::kPi * float(i) / float(nu);
      const luz::Vec3 p{std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph)};
      m.positions.push_back(p);
      m.normals.push_back(p);
      m.uvs.push_back({float(i) / float(nu), float(j) / float(nv)});
    }
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const uint32_t a = uint32_t(j * (nu + 1) + i), b = a + 1, c = a + uint32_t(nu + 1), d = c + 1;
      if (j > 0) m.indices.insert(m.indices.end(), {a, c, b});
      if (j < nv - 1) m.indices.insert(m.indices.end(), {b, c, d});
    }
  return m;
}

}  // namespace luz_test
