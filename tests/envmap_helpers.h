// Environment maps for tests (test_envmap.cpp, test_light_emission.cpp):
// deterministic images, Mitsuba 3's equirectangular mapping written out in
// double, and a scene holding one envmap light.
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "chi2.h"
#include "luz/math/transform.h"
#include "luz/scene/scene.h"

namespace luz_test {

using chi2::D3;
using luz::EnvmapLight;
using luz::Light;
using luz::Matrix4;
using luz::Scene;
using luz::SceneView;

struct Map {
  uint32_t w, h;
  std::vector<float> rgb;
};

// Deterministic test maps.
inline Map smooth_map(uint32_t w, uint32_t h) {
  Map m{w, h, std::vector<float>(size_t(w) * h * 3)};
  for (uint32_t j = 0; j < h; ++j)
    for (uint32_t i = 0; i < w; ++i)
      for (int c = 0; c < 3; ++c)
        m.rgb[(size_t(j) * w + i) * 3 + c] =
            float(1.0 + 0.8 * std::sin(0.7 * i + 1.3 * c) * std::cos(0.9 * j) + 0.1 * chi2::rand01(77, j * w + i, c));
  return m;
}
inline Map sun_map(uint32_t w, uint32_t h, uint32_t si, uint32_t sj, float sun = 2e4f) {
  Map m{w, h, std::vector<float>(size_t(w) * h * 3, 0.05f)};
  for (int c = 0; c < 3; ++c) m.rgb[(size_t(sj) * w + si) * 3 + c] = sun;
  return m;
}

// Mitsuba 3's uv_to_direction (light space).
inline D3 uv_to_direction(double u, double v) {
  const double theta = v * M_PI, phi = u * 2 * M_PI;
  return {std::sin(phi) * std::sin(theta), std::cos(theta), -std::cos(phi) * std::sin(theta)};
}
// The inverse, and grid coordinates s = u W - 1/2 (mod W), t = v (H - 1).
inline void direction_to_grid(D3 d, uint32_t w, uint32_t h, double& s, double& t) {
  d = chi2::normalized(d);
  const double u = std::atan2(d.x, -d.z) / (2 * M_PI), v = std::acos(std::clamp(d.y, -1.0, 1.0)) / M_PI;
  s = u * w - 0.5;
  s -= std::floor(s / w) * w;
  t = v * (h - 1);
}

struct EnvScene {
  Scene scene;
  SceneView view;
  const Light& light() const { return view.lights[0]; }
};

// rotation: to_world (a rotation; identity by default).
inline std::unique_ptr<EnvScene> env_scene(const Map& m, const Matrix4& rotation = {}, float scale = 1.f) {
  auto s = std::make_unique<EnvScene>();
  EnvmapLight l;
  l.scale = scale;
  l.to_world_x = rotation.vector({1, 0, 0});
  l.to_world_y = rotation.vector({0, 1, 0});
  l.to_world_z = rotation.vector({0, 0, 1});
  // A rotation's inverse is its transpose: the inverse's rows are its columns.
  l.to_local_x = l.to_world_x;
  l.to_local_y = l.to_world_y;
  l.to_local_z = l.to_world_z;
  build_envmap(l, m.rgb, m.w, m.h, s->scene.light_data);
  s->scene.lights.push_back(l);
  s->scene.compile();
  s->view = s->scene.view();
  return s;
}

inline D3 apply(const Matrix4& r, D3 d) {
  return {r.m[0][0] * d.x + r.m[0][1] * d.y + r.m[0][2] * d.z, r.m[1][0] * d.x + r.m[1][1] * d.y + r.m[1][2] * d.z,
          r.m[2][0] * d.x + r.m[2][1] * d.y + r.m[2][2] * d.z};
}
inline D3 apply_transpose(const Matrix4& r, D3 d) {
  return {r.m[0][0] * d.x + r.m[1][0] * d.y + r.m[2][0] * d.z, r.m[0][1] * d.x + r.m[1][1] * d.y + r.m[2][1] * d.z,
          r.m[0][2] * d.x + r.m[1][2] * d.y + r.m[2][2] * d.z};
}

}  // namespace luz_test
