// The furnace scene shared by tests/test_furnace.cpp and tests/test_materials.cpp:
// a unit sphere of one material under a constant environment of radiance 1,
// seen by a 32×32 pinhole camera, and the per-pixel check of a film against
// expected values (z-test with Šidák correction, plus the image-wide mean).
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "luz/device/cpu/render.h"
#include "luz/film/film.h"
#include "luz/scene/scene.h"
#include "stat_helpers.h"

namespace luz_test {

using namespace luz;

constexpr int kRes = 32;
constexpr double kCamZ = -3.0;    // camera at (0,0,-3), looking down +z at the unit sphere
constexpr double kTanHalf = 0.5;  // the sphere spans 2/3 of the image width

inline luz::Scene furnace_scene(const luz::Bsdf& material, luz::IntegratorType type, uint32_t spp, uint64_t seed) {
  Scene s;
  uint32_t m = s.add_material(material);
  s.add_sphere({0.f, 0.f, 0.f}, 1.f, m, nullptr, false);
  ConstantLight env;
  env.radiance = {1.f, 1.f, 1.f};
  s.lights.push_back(env);
  s.camera.origin = {0.f, 0.f, float(kCamZ)};
  s.camera.x_axis = {1.f, 0.f, 0.f};
  s.camera.y_axis = {0.f, 1.f, 0.f};
  s.camera.z_axis = {0.f, 0.f, 1.f};
  s.camera.tan_half_x = s.camera.tan_half_y = float(kTanHalf);
  s.camera.width = s.camera.height = kRes;
  s.settings.sampler = SamplerType::Independent;
  s.settings.spp = spp;
  s.settings.seed = seed;
  s.settings.filter = FilterKind::Box;  // a pixel is the plain average over its square
  s.settings.integrator.type = type;
  s.settings.integrator.max_depth = -1;
  s.compile();
  return s;
}

// Renders on two threads; a furnace must not produce non-finite samples.
inline luz::Film render(const luz::Scene& s) {
  CpuRenderOptions opt;
  opt.threads = 2;
  RenderStats stats;
  Film f = render_cpu(s, opt, stats);
  EXPECT_EQ(stats.discarded, 0u) << "non-finite samples";
  return f;
}

// cos θo at the sphere for film position (fx, fy), or -1 if the ray misses.
inline double view_cosine(double fx, double fy) {
  double sx = (1.0 - 2.0 * fx / kRes) * kTanHalf, sy = (1.0 - 2.0 * fy / kRes) * kTanHalf;
  double len = std::sqrt(sx * sx + sy * sy + 1.0);
  double d[3] = {sx / len, sy / len, 1.0 / len};
  double o[3] = {0, 0, kCamZ};
  double b = o[2] * d[2];                // dot(o, d)
  double c = o[2] * o[2] - 1.0;          // |o|² - r²
  double disc = b * b - c;
  if (disc <= 0) return -1;
  double t = -b - std::sqrt(disc);
  double n[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};  // unit normal (r = 1)
  return -(n[0] * d[0] + n[1] * d[1] + n[2] * d[2]);
}

struct CheckResult {
  double worst_z = 0;     // max over checked pixels of (|Δ| - bias)/σ
  double threshold = 0;
  double image_z = 0;     // image-wide mean test
  double max_abs_diff = 0;
  int checked = 0;
};

// |mean - expected| ≤ z σ + bias per pixel and channel, and the image mean;
// the threshold is Šidák-corrected at family level alpha over all of them.
inline CheckResult check(const luz::Film& f, const std::vector<double>& expected, const std::vector<double>& bias,
                         const std::vector<bool>& valid, double alpha) {
  CheckResult r;
  std::vector<double> mean = luz_test::pixel_means(f), var = f.variance_of_mean();
  for (size_t i = 0; i < valid.size(); ++i) r.checked += valid[i] ? 3 : 0;
  r.threshold = sidak_z(alpha, r.checked + 3);  // + the image-wide test, per channel
  double img_diff[3] = {0, 0, 0}, img_var[3] = {0, 0, 0}, img_bias = 0;
  for (size_t i = 0; i < valid.size(); ++i) {
    if (!valid[i]) continue;
    img_bias += bias[i];
    for (int c = 0; c < 3; ++c) {
      double d = mean[3 * i + c] - expected[i];
      double floor = luz_test::rounding_floor(expected[i]);
      double sigma = std::sqrt(var[3 * i + c] + floor * floor);
      r.worst_z = std::max(r.worst_z, (std::fabs(d) - bias[i]) / sigma);
      r.max_abs_diff = std::max(r.max_abs_diff, std::fabs(d));
      img_diff[c] += d;
      img_var[c] += var[3 * i + c] + floor * floor;
    }
  }
  for (int c = 0; c < 3; ++c)
    r.image_z = std::max(r.image_z, (std::fabs(img_diff[c]) - img_bias) / std::sqrt(img_var[c]));
  return r;
}

}  // namespace luz_test
