// An environment map (Mitsuba's `envmap`): radiance from an equirectangular
// float RGB image at infinity, times `scale`, placed by to_world.
//
// Mitsuba 3's conventions (src/emitters/envmap.cpp): in light space +y is up;
// direction d has u = atan2(d.x, -d.z) / 2π, v = acos(d.y) / π; texel column
// i sits at u = (i + 1/2) / width (the columns wrap around), row j at
// v = j / (height - 1) (the first row is the north pole, the last the south
// pole); radiance is the bilinear interpolation of the four texels around
// (u, v). In grid coordinates s = u·width - 1/2 (mod width), t = v·(height - 1)
// the texels sit on integer points and cell (i, j) = [i, i+1) × [j, j+1) is
// one bilinear patch.
//
// Sampling: a piecewise-constant distribution over those cells, each
// weighted by the mean luminance of its four texels times the mean of sin θ
// over its rows (so that a cell's probability follows its share of the
// sphere's light), uniform within the cell in (s, t). The solid-angle density
// is then density(s, t) · width · (height - 1) / (2π² sin θ); pdf_li
// computes exactly that for any direction, so the two agree, and a cell whose
// four texels are black (zero radiance everywhere in it) is never sampled.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "luz/light/directional.h"
#include "luz/light/light_sample.h"
#include "luz/sampling/distribution.h"

namespace luz {

struct EnvmapLight {
  static constexpr bool kDelta = false, kEnvironment = true;
  uint32_t width = 0, height = 0;  // the image (width >= 2, height >= 3)
  uint32_t texels = 0;             // offset of its width · height RGB floats in the lights' data, rows top to bottom
  Distribution2D cells;            // over width × (height - 1) cells
  float scale = 1.f;
  Vec3 to_world_x, to_world_y, to_world_z;  // columns of to_world's linear part
  Vec3 to_local_x, to_local_y, to_local_z;  // rows of its inverse
  float mean_radiance = 0.f;  // ∫ average(L) dω / 4π, for phi (set by the loader)

  // Grid coordinates (s, t) of a unit light-space direction.
  LUZ_INLINE Vec2 grid(Vec3 d) const {
    const float u = atan2f(d.x, -d.z) * kInv2Pi, v = acosf(min(max(d.y, -1.f), 1.f)) * kInvPi;
    float s = u * float(width) - 0.5f;
    s -= floorf(s / float(width)) * float(width);
    return {min(max(s, 0.f), float(width) * kOneMinusEpsilon), v * float(height - 1)};
  }

  LUZ_INLINE Color lookup(const float* data, Vec2 st) const {
    const uint32_t i = min(uint32_t(st.x), width - 1), j = min(uint32_t(st.y), height - 2);
    const uint32_t i1 = i + 1 == width ? 0 : i + 1;
    const float fx = st.x - float(i), fy = st.y - float(j);
    const float* row0 = data + texels + size_t(j) * width * 3;
    const float* row1 = row0 + size_t(width) * 3;
    Color c;
    for (int k = 0; k < 3; ++k) {
      const float top = row0[3 * i + k] * (1.f - fx) + row0[3 * i1 + k] * fx;
      const float bottom = row1[3 * i + k] * (1.f - fx) + row1[3 * i1 + k] * fx;
      c[k] = (top * (1.f - fy) + bottom * fy) * scale;
    }
    return c;
  }

  LUZ_INLINE Vec3 to_local(Vec3 w) const {
    return normalize(Vec3{dot(to_local_x, w), dot(to_local_y, w), dot(to_local_z, w)});
  }

  // Solid-angle density per unit grid density, at light-space direction d.
  LUZ_INLINE float jacobian(Vec3 d) const {
    const float sin_theta = sqrtf(d.x * d.x + d.z * d.z);
    return sin_theta > 0.f ? float(width) * float(height - 1) / (2.f * kPi * kPi * sin_theta) : 0.f;
  }

  LUZ_INLINE LightSample sample_li(const LightSampleContext&, Vec2 u, const LightData& data) const {
    LightSample ls;
    float density = 0.f;
    const Vec2 st = cells.sample(data.floats, u, density);
    if (!(density > 0.f)) return ls;
    const float phi = 2.f * kPi * (st.x + 0.5f) / float(width), theta = kPi * st.y / float(height - 1);
    const float sin_theta = sinf(theta);
    const Vec3 d{sinf(phi) * sin_theta, cosf(theta), -cosf(phi) * sin_theta};
    const float jac = jacobian(d);
    if (!(jac > 0.f)) return ls;
    ls.wi = normalize(to_world_x * d.x + to_world_y * d.y + to_world_z * d.z);
    ls.dist = kInfinity;
    ls.pdf = density * jac;
    ls.radiance = lookup(data.floats, st);
    return ls;
  }

  LUZ_INLINE float pdf_li(const LightSampleContext&, Vec3 wi, const LightHit&, const LightData& data) const {
    const Vec3 d = to_local(wi);
    return cells.pdf(data.floats, grid(d)) * jacobian(d);
  }
  // Emitted rays: a direction as sample_li draws it (with its own density,
  // which pdf_le matches but where rounding crosses a cell edge), then
  // through the scene's disk.
  LUZ_INLINE LightLeSample sample_le(Vec2 u_pos, Vec2 u_dir, const LightData& data, Vec3 scene_center,
                                     float scene_radius) const {
    return environment_le_sample(*this, u_pos, u_dir, data, scene_center, scene_radius);
  }
  LUZ_INLINE LightLePdf pdf_le(Vec3, Vec3, Vec3 d, const LightData& data, float scene_radius) const {
    return {disk_area_pdf(scene_radius), pdf_li({}, -d, {}, data)};
  }

  LUZ_INLINE Color le(Vec3 dir, const LightData& data) const { return lookup(data.floats, grid(to_local(dir))); }

  // As ConstantLight::phi, with the map's mean radiance.
  double phi(float scene_radius) const {
    return 4.0 * M_PI * (M_PI * double(scene_radius) * scene_radius) * std::max(0.0, double(mean_radiance)) * scale;
  }
  // The irradiance it gives an unoccluded surface, averaged over the ways
  // the surface may face: π times the mean radiance.
  double irradiance_estimate() const { return M_PI * std::max(0.0, double(mean_radiance)) * scale; }
};

// Appends an envmap's texels (width · height RGB, rows top to bottom, finite
// and non-negative) and its sampling distribution to `data`; fills in the
// light's image fields (not scale or the transforms).
inline void build_envmap(EnvmapLight& l, const std::vector<float>& rgb, uint32_t width, uint32_t height,
                         std::vector<float>& data) {
  l.width = width;
  l.height = height;
  l.texels = uint32_t(data.size());
  data.insert(data.end(), rgb.begin(), rgb.end());
  auto luminance = [&](uint32_t i, uint32_t j) {
    const float* p = rgb.data() + (size_t(j) * width + i) * 3;
    return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
  };
  const double dtheta = M_PI / (height - 1);
  std::vector<double> w(size_t(width) * (height - 1));
  double mean = 0.0;
  for (uint32_t j = 0; j + 1 < height; ++j) {
    // ∫ sin θ dθ over the cell's rows, per unit t.
    const double sin_mean = std::cos(j * dtheta) - std::cos((j + 1) * dtheta);
    for (uint32_t i = 0; i < width; ++i) {
      const uint32_t i1 = (i + 1) % width;
      w[size_t(j) * width + i] = 0.25 * (luminance(i, j) + luminance(i1, j) + luminance(i, j + 1) + luminance(i1, j + 1)) * sin_mean;
      for (int c = 0; c < 3; ++c) {
        const float* r0 = rgb.data() + size_t(j) * width * 3;
        const float* r1 = r0 + size_t(width) * 3;
        mean += 0.25 * (r0[3 * i + c] + r0[3 * i1 + c] + r1[3 * i + c] + r1[3 * i1 + c]) / 3.0 * sin_mean;
      }
    }
  }
  // Σ over cells of the cell's mean times its solid angle (2π / width · ∫ sin θ dθ), over 4π.
  l.mean_radiance = float(mean * (2.0 * M_PI / width) / (4.0 * M_PI));
  l.cells = build_distribution2d(w, width, height - 1, data);
}

}  // namespace luz
