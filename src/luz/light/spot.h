// A spot light: a point light whose intensity I is full within the beam
// angle of its axis, falls off to 0 at the cutoff angle, and is 0 beyond,
// optionally times a projected texture (Mitsuba's `texture`: the image spans
// the cutoff cone's tangent plane). The falloff follows the format the light
// came from: linear in the angle (Mitsuba's falloff_curve), a smoothstep in
// cos θ (pbrt-v4's SpotLight::I), or the square of a linear ramp in cos θ
// (glTF's KHR_lights_punctual). Light space has the axis along +z; to_world
// places it. A delta light.
#pragma once

#include <algorithm>
#include <cmath>

#include "luz/light/point.h"

namespace luz {

enum class SpotFalloff : uint8_t {
  LinearAngle,     // (cutoff - θ) / (cutoff - beam): Mitsuba
  SmoothstepCos,   // smoothstep(t), t = (cos θ - cos cutoff) / (cos beam - cos cutoff): pbrt-v4
  SquaredRampCos,  // t²: glTF
};

struct SpotLight {
  static constexpr bool kDelta = true, kEnvironment = false;
  Color intensity;  // W/sr on the axis
  Vec3 position;
  // Rows of the inverse of to_world's linear part: world direction -> light space.
  Vec3 inv_x, inv_y, inv_z;
  float cutoff = 0.f, beam = 0.f;  // angles in radians, 0 <= beam <= cutoff <= π (π/2 with a texture), cutoff > 0
  float cos_cutoff = 1.f, cos_beam = 1.f;
  float inv_transition = 0.f;      // 1 / (cutoff - beam), 0 when equal
  float inv_cos_transition = 0.f;  // 1 / (cos beam - cos cutoff), 0 when equal
  int32_t texture = -1;            // LightData::textures, or -1: none
  float tan_cutoff = 0.f;          // the texture's extent: uv = 1/2 + (x, y) / (2 z tan(cutoff))
  SpotFalloff falloff_kind = SpotFalloff::LinearAngle;

  // The cone's angles in radians (0 <= beam <= cutoff <= π, cutoff > 0;
  // π/2 at most with a projected texture) and its falloff's shape.
  void set_cone(double cutoff_rad, double beam_rad, SpotFalloff kind) {
    cutoff = float(cutoff_rad);
    beam = float(beam_rad);
    cos_cutoff = float(std::cos(cutoff_rad));
    cos_beam = float(std::cos(beam_rad));
    inv_transition = beam_rad < cutoff_rad ? float(1.0 / (cutoff_rad - beam_rad)) : 0.f;
    inv_cos_transition = cos_beam > cos_cutoff ? float(1.0 / (std::cos(beam_rad) - std::cos(cutoff_rad))) : 0.f;
    tan_cutoff = float(std::tan(cutoff_rad));
    falloff_kind = kind;
  }

  // The falloff factor in [0, 1] toward the light-space direction d.
  LUZ_INLINE float falloff(Vec3 d) const {
    const float cos_theta = normalize(d).z;
    if (!(cos_theta > cos_cutoff)) return 0.f;
    if (cos_theta >= cos_beam) return 1.f;
    if (falloff_kind == SpotFalloff::LinearAngle) return (cutoff - acosf(cos_theta)) * inv_transition;
    const float t = fminf(1.f, (cos_theta - cos_cutoff) * inv_cos_transition);
    return falloff_kind == SpotFalloff::SmoothstepCos ? t * t * (3.f - 2.f * t) : t * t;
  }

  // World direction w in light space (not normalised).
  LUZ_INLINE Vec3 to_local(Vec3 w) const { return {dot(inv_x, w), dot(inv_y, w), dot(inv_z, w)}; }
  // Light-space direction v in world space, normalised: to_world's linear
  // part is the inverse of the matrix of rows inv_x, inv_y, inv_z, whose
  // columns are (inv_y × inv_z, inv_z × inv_x, inv_x × inv_y) / det.
  LUZ_INLINE Vec3 to_world(Vec3 v) const {
    const Vec3 w = cross(inv_y, inv_z) * v.x + cross(inv_z, inv_x) * v.y + cross(inv_x, inv_y) * v.z;
    return normalize(dot(inv_x, cross(inv_y, inv_z)) < 0.f ? -w : w);
  }

  // The intensity toward the light-space direction v of falloff f.
  LUZ_INLINE Color intensity_toward(Vec3 v, float f, const LightData& data) const {
    if (texture < 0) return intensity * f;
    const float k = 0.5f / (v.z * tan_cutoff);
    return intensity * data.textures.eval(uint32_t(texture), {0.5f + v.x * k, 0.5f + v.y * k}) * f;
  }

  LUZ_INLINE LightSample sample_li(const LightSampleContext& ctx, Vec2, const LightData& data) const {
    const Vec3 v = to_local(ctx.p - position);  // from the light toward the shading point
    const float f = falloff(v);
    if (!(f > 0.f)) return {};
    return point_light_sample(position, ctx.p, intensity_toward(v, f, data));
  }
  LUZ_INLINE float pdf_li(const LightSampleContext&, Vec3, const LightHit&, const LightData&) const { return 0.f; }
  // Emitted rays: uniform in the light-space cone cos θ > cos_cutoff (the
  // cone falloff() lights: 1 - cos_cutoff is exact in float), mapped to the
  // world; the pdf is taken from pdf_le, so that the two agree exactly.
  LUZ_INLINE LightLeSample sample_le(Vec2, Vec2 u_dir, const LightData& data, Vec3, float) const {
    LightLeSample s;
    const Vec3 d = to_world(square_to_uniform_cone(u_dir, 1.f - cos_cutoff));
    const LightLePdf pdf = pdf_le({}, {}, d, nullptr, 0.f);
    if (!(pdf.pdf_dir > 0.f)) return s;  // on the rim, lost to rounding
    s.p = position;
    s.d = d;
    const Vec3 v = to_local(d);
    s.radiance = intensity_toward(v, falloff(v), data);
    s.pdf_pos = 1.f;
    s.pdf_dir = pdf.pdf_dir;
    s.delta_pos = true;
    return s;
  }
  // The cone's density in light space times the solid-angle Jacobian of
  // w -> v = B w / |B w| (B = to_world's inverse), |det B| / |B w|³ for unit
  // w: 1 for a rotation, and still right when to_world scales unevenly.
  LUZ_INLINE LightLePdf pdf_le(Vec3, Vec3, Vec3 d, const LightData&, float) const {
    const Vec3 v = to_local(d);
    const float len = length(v);
    if (!(normalize(v).z > cos_cutoff)) return {1.f, 0.f};
    const float det = fabsf(dot(inv_x, cross(inv_y, inv_z)));
    return {1.f, uniform_cone_pdf(1.f - cos_cutoff) * det / (len * len * len)};
  }
  LUZ_INLINE Color eval(Vec3, Vec3, Vec2, const LightData&) const { return {}; }
  // 2π I ∫ falloff(θ) sin θ dθ: 2π I (1 - (sin c - sin b) / (c - b)) linear
  // in the angle, 2π I ((1 - cos b) + k (cos b - cos c)) for the ramps in
  // cos θ (k = 1/2 for the smoothstep, 1/3 for the square), 2π I (1 - cos c)
  // when b = c (a projected texture not counted: power only weighs light
  // selection).
  double phi(float) const {
    const double b = beam, c = cutoff;
    double solid = 1.0 - std::cos(c);
    if (c - b > 1e-7) {
      if (falloff_kind == SpotFalloff::LinearAngle) solid = 1.0 - (std::sin(c) - std::sin(b)) / (c - b);
      else solid = (1.0 - std::cos(b)) + (falloff_kind == SpotFalloff::SmoothstepCos ? 0.5 : 1.0 / 3.0) * (std::cos(b) - std::cos(c));
    }
    return 2.0 * M_PI * solid * std::max(0.0, double(average(intensity)));
  }
  // Full intensity within the beam around the axis, spreading to the cutoff
  // (pbrt-v4's SpotLight::Bounds). The axis is inv_z when to_world is a
  // rotation times a uniform scale; otherwise every direction.
  LightBounds bounds() const {
    LightBounds b;
    b.lo = b.hi = position;
    b.phi = float(std::max(0.0, double(average(intensity))));
    const float sx = length(inv_x), sy = length(inv_y), sz = length(inv_z);
    const float tol = 1e-4f * sz;
    const bool conformal = std::fabs(sx - sz) <= tol && std::fabs(sy - sz) <= tol && std::fabs(dot(inv_x, inv_y)) <= tol * sz &&
                           std::fabs(dot(inv_y, inv_z)) <= tol * sz && std::fabs(dot(inv_x, inv_z)) <= tol * sz && sz > 0.f;
    b.w = conformal ? inv_z / sz : Vec3{0.f, 0.f, 1.f};
    b.cos_theta_o = conformal ? cos_beam : -1.f;
    b.cos_theta_e = conformal ? std::cos(cutoff - beam) : 0.f;
    return b;
  }
};

}  // namespace luz
