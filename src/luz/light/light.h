// Lights: one tagged union over the models (one file each) and one dispatch,
// `visit`, through which every question to a light goes. A model is a plain
// struct with
//   static constexpr bool kDelta;        // a point or a direction: found by no ray
//   static constexpr bool kEnvironment;  // found by the rays that leave the scene
//   LightSample sample_li(const LightSampleContext&, Vec2 u, const LightData& data) const;
//   float pdf_li(const LightSampleContext&, Vec3 wi, const LightHit&, const LightData& data) const;
//   LightLeSample sample_le(Vec2 u_pos, Vec2 u_dir, const LightData& data, Vec3 scene_center, float scene_radius) const;
//   LightLePdf pdf_le(Vec3 p, Vec3 n, Vec3 d, const LightData& data, float scene_radius) const;
//   Color eval(Vec3 n, Vec3 w, Vec2 uv, const LightData&) const;  // others: radiance from a
//                                       // surface point of normal n and texture coordinates uv toward w
//   Color le(Vec3 dir, const LightData& data) const;  // environments: radiance arriving along -dir, from dir
//   double phi(float scene_radius) const;  // power (host), for light selection
//   LightBounds bounds() const;            // (host, finite lights only) for the light BVH
//   double irradiance_estimate() const;    // (host, infinite lights only) for the light BVH
// pdf_li is the solid-angle density with which sample_li finds the light
// along wi (0 for delta lights: no ray finds them). sample_le draws an
// emitted ray (light tracing, BDPT; pbrt-v4's SampleLe), pdf_le gives its
// densities for a ray from p (normal n on area lights) along d; lights at
// infinity send their rays through the disk of the scene's bounding sphere.
// `data` (LightsView::data): the lights' shared float array, where images and
// distributions live, and the scene's textures (textured area lights).
#pragma once

#include <optional>
#include <type_traits>
#include <utility>

#include "luz/light/area.h"
#include "luz/light/constant.h"
#include "luz/light/directional.h"
#include "luz/light/envmap.h"
#include "luz/light/point.h"
#include "luz/light/spot.h"

namespace luz {

enum class LightType : uint32_t { Triangle, Parallelogram, Sphere, Constant, Point, Spot, Directional, Envmap };

struct Light {
  LightType type = LightType::Triangle;
  union {
    TriangleLight triangle;
    ParallelogramLight parallelogram;
    SphereLight sphere;
    ConstantLight constant;
    PointLight point;
    SpotLight spot;
    DirectionalLight directional;
    EnvmapLight envmap;
  };

  LUZ_INLINE Light() : triangle() {}
  LUZ_INLINE Light(const TriangleLight& m) : type(LightType::Triangle), triangle(m) {}
  LUZ_INLINE Light(const ParallelogramLight& m) : type(LightType::Parallelogram), parallelogram(m) {}
  LUZ_INLINE Light(const SphereLight& m) : type(LightType::Sphere), sphere(m) {}
  LUZ_INLINE Light(const ConstantLight& m) : type(LightType::Constant), constant(m) {}
  LUZ_INLINE Light(const PointLight& m) : type(LightType::Point), point(m) {}
  LUZ_INLINE Light(const SpotLight& m) : type(LightType::Spot), spot(m) {}
  LUZ_INLINE Light(const DirectionalLight& m) : type(LightType::Directional), directional(m) {}
  LUZ_INLINE Light(const EnvmapLight& m) : type(LightType::Envmap), envmap(m) {}
};
static_assert(std::is_trivially_copyable_v<Light>, "lights are copied to the GPU as bytes");

// Calls f with the light's model.
template <class F>
LUZ_FORCE_INLINE decltype(auto) visit(const Light& l, F&& f) {
  switch (l.type) {
    case LightType::Triangle: return f(l.triangle);
    case LightType::Parallelogram: return f(l.parallelogram);
    case LightType::Sphere: return f(l.sphere);
    case LightType::Constant: return f(l.constant);
    case LightType::Point: return f(l.point);
    case LightType::Spot: return f(l.spot);
    case LightType::Directional: return f(l.directional);
    default: return f(l.envmap);
  }
}

// Triangles and parallelograms are sampled inline; the other models out of
// line on the CPU, so that their code does not enlarge every scene's path
// loop (a call per sample is small beside an envmap's or a sphere's sampling).
template <class M>
LUZ_CPU_NOINLINE LightSample sample_li_outlined(const M& m, LightSampleContext ctx, Vec2 u, const LightData& data) {
  return m.sample_li(ctx, u, data);
}

LUZ_FORCE_INLINE LightSample sample_li(const Light& l, const LightSampleContext& ctx, Vec2 u, const LightData& data) {
  return visit(l, [&](const auto& m) LUZ_LAMBDA_FORCE_INLINE {
    using M = std::decay_t<decltype(m)>;
    if constexpr (std::is_same_v<M, TriangleLight> || std::is_same_v<M, ParallelogramLight>) return m.sample_li(ctx, u, data);
    else return sample_li_outlined(m, ctx, u, data);
  });
}

LUZ_INLINE float pdf_li(const Light& l, const LightSampleContext& ctx, Vec3 wi, const LightHit& h, const LightData& data) {
  return visit(l, [&](const auto& m) { return m.pdf_li(ctx, wi, h, data); });
}

LUZ_INLINE LightLeSample sample_le(const Light& l, Vec2 u_pos, Vec2 u_dir, const LightData& data, Vec3 scene_center,
                                   float scene_radius) {
  return visit(l, [&](const auto& m) { return m.sample_le(u_pos, u_dir, data, scene_center, scene_radius); });
}

LUZ_INLINE LightLePdf pdf_le(const Light& l, Vec3 p, Vec3 n, Vec3 d, const LightData& data, float scene_radius) {
  return visit(l, [&](const auto& m) { return m.pdf_le(p, n, d, data, scene_radius); });
}

// Radiance a surface light sends from a point of normal n and texture
// coordinates uv toward w.
LUZ_INLINE Color eval(const Light& l, Vec3 n, Vec3 w, Vec2 uv, const LightData& data) {
  return visit(l, [&](const auto& m) {
    if constexpr (!std::decay_t<decltype(m)>::kEnvironment) return m.eval(n, w, uv, data);
    else return Color{};
  });
}

// Radiance an environment sends along -dir (a ray leaving the scene along dir).
LUZ_INLINE Color le(const Light& l, Vec3 dir, const LightData& data) {
  return visit(l, [&](const auto& m) {
    if constexpr (std::decay_t<decltype(m)>::kEnvironment) return m.le(dir, data);
    else return Color{};
  });
}

LUZ_INLINE bool is_delta(const Light& l) {
  return visit(l, [](const auto& m) { return std::decay_t<decltype(m)>::kDelta; });
}
LUZ_INLINE bool is_environment(const Light& l) {
  return visit(l, [](const auto& m) { return std::decay_t<decltype(m)>::kEnvironment; });
}

inline double phi(const Light& l, float scene_radius) {
  return visit(l, [&](const auto& m) { return m.phi(scene_radius); });
}

template <class M, class = void>
struct HasBounds : std::false_type {};
template <class M>
struct HasBounds<M, std::void_t<decltype(std::declval<const M&>().bounds())>> : std::true_type {};

// Where and how a light emits, for the light BVH (host); none for the
// infinite ones (environments, directional), which it samples apart.
inline std::optional<LightBounds> bounds(const Light& l) {
  return visit(l, [](const auto& m) -> std::optional<LightBounds> {
    if constexpr (HasBounds<std::decay_t<decltype(m)>>::value) return m.bounds();
    else return std::nullopt;
  });
}

template <class M, class = void>
struct HasIrradianceEstimate : std::false_type {};
template <class M>
struct HasIrradianceEstimate<M, std::void_t<decltype(std::declval<const M&>().irradiance_estimate())>>
    : std::true_type {};

// The irradiance an infinite light gives an unoccluded surface (host; 0 for
// the others): what the light BVH weighs it by against the tree's
// importance, itself an estimate of irradiance.
inline double irradiance_estimate(const Light& l) {
  return visit(l, [](const auto& m) -> double {
    if constexpr (HasIrradianceEstimate<std::decay_t<decltype(m)>>::value) return m.irradiance_estimate();
    else return 0.0;
  });
}

}  // namespace luz
