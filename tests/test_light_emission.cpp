// Emission sampling (sample_le / pdf_le of light/light.h), for every light model.
//
//  * Directions: chi-square of the sampled directions against their density
//    in closed form, in double: cos θ / π about the emitting normal (area
//    lights, one-sided; |cos θ| / 2π two-sided), 1 / 4π (point, constant), uniform in the spot's
//    cone as the light defines it (cos θ > cos_cutoff), through the Jacobian
//    |det B| / |B w|³ when to_world scales unevenly (B its inverse); the
//    envmap's over its cells, whose probabilities come from pdf_le: its
//    density is c / sin θ within a cell, so one value per cell gives the
//    cell's exact mass.
//  * Positions, where not uniform by construction: a triangle through its
//    barycentrics, a sphere through the direction from its centre, the disk
//    that lights at infinity send their rays through (in polar coordinates),
//    each against pdf_pos; a parallelogram through its (u, v) as well.
//  * At every sample, pdf_le equals the sample's pdfs (4 ulp; the envmap's
//    pdf_dir to 1e-4 away from cell edges, where the sample keeps its own
//    cell's density); unit directions on the emitting side, the delta flags.
//  * Flux: the mean of average(L) |cos θ| / (pdf_pos pdf_dir) (cos about the
//    light's normal for area lights, 1 for the others) is the power each
//    model's phi(scene_radius) states, within a z-bound from the sample
//    variance (plus 1e-4 relative for float rounding). For environments the
//    rays cross the disk perpendicular to their own direction, from every
//    direction: 4π · π r² · mean radiance (pbrt-v4's Phi).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "chi2.h"
#include "envmap_helpers.h"
#include "luz/light/light.h"
#include "luz/math/transform.h"

using namespace luz;
using namespace luz_test;
using chi2::D3;

namespace {

constexpr int kChi2Tests = 14 /* directions */ + 6 /* positions */;
const double kThreshold = chi2::sidak(chi2::kAlpha, kChi2Tests);
constexpr uint64_t kSamples = 200000;
const Vec3 kCenter{0.3f, -0.4f, 0.2f};
constexpr float kRadius = 2.5f;

D3 sub(D3 a, D3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
D3 cross(D3 a, D3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double len(D3 a) { return std::sqrt(chi2::dot(a, a)); }

LightLeSample draw(const Light& l, const LightData& data, uint64_t seed, uint64_t i) {
  return sample_le(l, chi2::rand2(seed, i, 0), chi2::rand2(seed, i, 1), data, kCenter, kRadius);
}
bool valid(const LightLeSample& s) { return s.pdf_pos > 0.f && s.pdf_dir > 0.f; }

// ------------------------------------------------------------------ lights
const Color kRadiance{1.f, 2.f, 3.f};

TriangleLight triangle(bool two_sided = false) {
  TriangleLight l;
  l.two_sided = two_sided;
  l.radiance = kRadiance;
  l.v0 = {0.2f, 0.1f, -0.3f};
  l.v1 = {1.5f, 0.4f, 0.2f};
  l.v2 = {0.1f, 1.2f, 0.6f};
  const Vec3 c = cross(l.v1 - l.v0, l.v2 - l.v0);
  l.area = 0.5f * length(c);
  l.normal = normalize(c);
  return l;
}
ParallelogramLight parallelogram(bool two_sided = false) {
  ParallelogramLight l;
  l.two_sided = two_sided;
  l.radiance = kRadiance;
  l.corner = {-0.5f, 0.3f, 0.1f};
  l.e1 = {1.2f, 0.1f, -0.2f};
  l.e2 = {0.3f, 0.2f, 0.9f};
  const Vec3 c = cross(l.e1, l.e2);
  l.area = length(c);
  l.normal = normalize(c);
  return l;
}
SphereLight sphere(bool flip) {
  SphereLight l;
  l.radiance = kRadiance;
  l.center = {0.4f, -0.2f, 1.1f};
  l.radius = 0.7f;
  l.flip = flip;
  return l;
}
PointLight point() {
  PointLight l;
  l.intensity = kRadiance;
  l.position = {1.f, 2.f, -0.5f};
  return l;
}
// to_world = rotation · diag(scale): the inverse's rows are the rotation's
// columns over the scales. Falloff parameters as the loader sets them.
SpotLight spot(double cutoff_deg, double beam_deg, const Matrix4& rotation, Vec3 scale = {1, 1, 1},
               SpotFalloff falloff = SpotFalloff::LinearAngle) {
  SpotLight l;
  l.intensity = kRadiance;
  l.position = {0.5f, 1.5f, -1.f};
  l.inv_x = rotation.vector({1, 0, 0}) / scale.x;
  l.inv_y = rotation.vector({0, 1, 0}) / scale.y;
  l.inv_z = rotation.vector({0, 0, 1}) / scale.z;
  l.set_cone(cutoff_deg * M_PI / 180.0, beam_deg * M_PI / 180.0, falloff);
  return l;
}
DirectionalLight directional() {
  DirectionalLight l;
  l.irradiance = kRadiance;
  l.direction = normalize(Vec3{0.3f, -1.f, 0.4f});
  return l;
}
ConstantLight constant() {
  ConstantLight l;
  l.radiance = kRadiance;
  return l;
}
const Matrix4 kEnvRotation = Matrix4::rotate({0.3f, 1.f, -0.5f}, 70.0) * Matrix4::rotate({1, 0, 0}, -90.0);
const Matrix4 kSpotRotation = Matrix4::rotate({1.f, 0.4f, -0.2f}, 115.0);
const Vec3 kSpotScale{1.f, 2.5f, 0.6f};

// The spot's density per world solid angle toward unit w, in double.
double spot_pdf(const SpotLight& l, D3 w) {
  const D3 bx = chi2::to_d3(l.inv_x), by = chi2::to_d3(l.inv_y), bz = chi2::to_d3(l.inv_z);
  const D3 v{chi2::dot(bx, w), chi2::dot(by, w), chi2::dot(bz, w)};
  const double lv = len(v);
  if (!(v.z / lv > double(l.cos_cutoff))) return 0.0;
  const double det = std::fabs(chi2::dot(bx, cross(by, bz)));
  return det / (lv * lv * lv) / (2.0 * M_PI * (1.0 - double(l.cos_cutoff)));
}
// The spots' axis in the world (rotation · scale · z is along rotation · z).
D3 spot_axis() { return chi2::normalized(chi2::to_d3(kSpotRotation.vector({0, 0, 1}))); }

// ------------------------------------------------------------ directions

// Chi-square of observe(sample) over g against pdf (double, per unit solid angle).
void check_directions(const char* what, const Light& l, const LightData& data, const chi2::SphereGrid& g, uint64_t seed,
                      const std::function<Vec3(const LightLeSample&)>& observe, const std::function<double(D3)>& pdf) {
  auto sample = [&](uint64_t i, Vec3& w) {
    const LightLeSample s = draw(l, data, seed, i);
    if (!valid(s)) return false;
    w = observe(s);
    return true;
  };
  const chi2::Outcome out = chi2::run_sphere(g, kSamples, sample, pdf);
  std::printf("%-26s %s\n", what, out.result.summary().c_str());
  EXPECT_TRUE(out.result.passes(kThreshold)) << what << ": " << out.describe(kThreshold);
}

Vec3 direction(const LightLeSample& s) { return s.d; }
// The direction in a frame about the sample's normal (z up).
Vec3 about_normal(const LightLeSample& s) {
  const chi2::DFrame f(chi2::to_d3(s.n));
  const D3 d = chi2::to_d3(s.d);
  return chi2::to_vec3({chi2::dot(d, f.s), chi2::dot(d, f.t), chi2::dot(d, f.n)});
}
double cosine(D3 w) { return std::max(0.0, w.z) / M_PI; }
double uniform(D3) { return 1.0 / (4.0 * M_PI); }

chi2::SphereGrid grid(D3 axis, double theta_max = M_PI) {
  chi2::SphereGrid g;
  g.axis = axis;
  g.theta_max = theta_max;
  return g;
}

TEST(LightEmission, AreaDirectionsChi2) {
  const TriangleLight t = triangle();
  const D3 nt = chi2::to_d3(t.normal);
  check_directions("triangle", t, nullptr, grid(nt, M_PI / 2), 1, direction,
                   [&](D3 w) { return std::max(0.0, chi2::dot(w, nt)) / M_PI; });
  const ParallelogramLight p = parallelogram();
  const D3 np = chi2::to_d3(p.normal);
  check_directions("parallelogram", p, nullptr, grid(np, M_PI / 2), 2, direction,
                   [&](D3 w) { return std::max(0.0, chi2::dot(w, np)) / M_PI; });
  // Two-sided: either hemisphere, |cos θ| / 2π.
  check_directions("triangle, two-sided", triangle(true), nullptr, grid(nt), 21, direction,
                   [&](D3 w) { return std::fabs(chi2::dot(w, nt)) / (2 * M_PI); });
  check_directions("parallelogram, two-sided", parallelogram(true), nullptr, grid(np), 22, direction,
                   [&](D3 w) { return std::fabs(chi2::dot(w, np)) / (2 * M_PI); });
  check_directions("sphere", sphere(false), nullptr, grid({0, 0, 1}, M_PI / 2), 3, about_normal, cosine);
  check_directions("sphere, flipped", sphere(true), nullptr, grid({0, 0, 1}, M_PI / 2), 4, about_normal, cosine);
}

TEST(LightEmission, PointAndSpotDirectionsChi2) {
  check_directions("point", point(), nullptr, grid({0.2, 0.3, 1}), 5, direction, uniform);
  for (const auto& [what, l, seed] : {std::tuple{"spot, 4° cone", spot(4, 2, kSpotRotation), 6},
                                      std::tuple{"spot, 70° cone", spot(70, 50, kSpotRotation), 7},
                                      std::tuple{"spot, 120° cone", spot(120, 100, kSpotRotation), 21}}) {
    // Bins up to the rim the light defines, so that none is cut by it.
    chi2::SphereGrid g = grid(spot_axis(), std::acos(double(l.cos_cutoff)));
    g.edge_tol = 1e-6;
    check_directions(what, l, nullptr, g, seed, direction, [&l = l](D3 w) { return spot_pdf(l, w); });
  }
  // An uneven scale: the cone is elliptic in the world, and cuts bins.
  const SpotLight s = spot(40, 30, kSpotRotation, kSpotScale);
  chi2::SphereGrid g = grid(spot_axis());
  g.n_theta = 20;
  g.quad_split = 4;
  g.quad_depth = 8;
  check_directions("spot, scaled to_world", s, nullptr, g, 8, direction, [&](D3 w) { return spot_pdf(s, w); });
}

TEST(LightEmission, ConstantDirectionsChi2) {
  check_directions("constant", constant(), nullptr, grid({0.5, -0.2, 0.3}), 9, direction, uniform);
}

// Cells of the map as bins (the direction the light is seen in, -d, in light
// space), each expecting pdf_le at its centre × sin θ · Δθ · Δφ.
void check_envmap_directions(const char* what, const Map& m, const Matrix4& rotation, uint64_t seed) {
  auto s = env_scene(m, rotation);
  const LightData& data = s->view.lights.data;
  const size_t cells = size_t(m.w) * (m.h - 1);
  std::vector<double> observed(cells, 0.0), expected(cells, 0.0);
  const double dtheta = M_PI / (m.h - 1), dphi = 2 * M_PI / m.w;
  for (uint32_t j = 0; j + 1 < m.h; ++j)
    for (uint32_t i = 0; i < m.w; ++i) {
      const double v = (j + 0.5) / (m.h - 1);
      const D3 toward = apply(rotation, uv_to_direction((i + 1.0) / m.w, v));
      const LightLePdf p = pdf_le(s->light(), {}, {}, chi2::to_vec3({-toward.x, -toward.y, -toward.z}), data, kRadius);
      expected[size_t(j) * m.w + i] = p.pdf_dir * std::sin(v * M_PI) * dtheta * dphi * kSamples;
    }
  uint64_t failed = 0;
  for (uint64_t k = 0; k < kSamples; ++k) {
    const LightLeSample ls = draw(s->light(), data, seed, k);
    if (!valid(ls)) {
      ++failed;
      continue;
    }
    const D3 local = apply_transpose(rotation, chi2::to_d3(-ls.d));
    double gs, gt;
    direction_to_grid(local, m.w, m.h, gs, gt);
    observed[size_t(std::min(uint32_t(gt), m.h - 2)) * m.w + std::min(uint32_t(gs), m.w - 1)] += 1;
  }
  observed.push_back(double(failed));
  expected.push_back(0.0);
  const chi2::Result r = chi2::chi2_test(observed, expected);
  std::printf("%-26s %s\n", what, r.summary().c_str());
  EXPECT_NEAR(r.expected_total, double(kSamples), 1e-5 * kSamples) << what << ": ∫ pdf_dir";
  EXPECT_TRUE(r.passes(kThreshold)) << what << ": " << r.summary();
}

TEST(LightEmission, EnvmapDirectionsChi2) {
  check_envmap_directions("envmap, tiny sun, rotated", sun_map(64, 33, 41, 9), kEnvRotation, 10);
  // A dimmer sun, so that the sky's cells count too.
  check_envmap_directions("envmap, dim sun, rotated", sun_map(32, 17, 5, 14, 30.f), kEnvRotation, 18);
  check_envmap_directions("envmap, smooth", smooth_map(16, 9), {}, 11);
}

// ------------------------------------------------------------- positions

// Chi-square of coords(sample) over a grid against density (per unit of the grid's coordinates).
void check_positions(const char* what, const Light& l, const LightData& data, const chi2::Grid& g, uint64_t seed,
                     const std::function<void(const LightLeSample&, double&, double&)>& coords,
                     const std::function<double(double, double)>& density) {
  auto sample = [&](uint64_t i, double& u, double& v) {
    const LightLeSample s = draw(l, data, seed, i);
    if (!valid(s)) return false;
    coords(s, u, v);
    return true;
  };
  const chi2::Outcome out = chi2::run_grid(g, kSamples, sample, density);
  std::printf("%-26s %s\n", what, out.result.summary().c_str());
  EXPECT_TRUE(out.result.passes(kThreshold)) << what << ": " << out.describe(kThreshold);
}

// (a, b) with p = o + a e1 + b e2, by least squares in double.
void plane_coords(D3 o, D3 e1, D3 e2, D3 p, double& a, double& b) {
  const D3 q = sub(p, o);
  const double g11 = chi2::dot(e1, e1), g12 = chi2::dot(e1, e2), g22 = chi2::dot(e2, e2);
  const double r1 = chi2::dot(q, e1), r2 = chi2::dot(q, e2), det = g11 * g22 - g12 * g12;
  a = (r1 * g22 - r2 * g12) / det;
  b = (r2 * g11 - r1 * g12) / det;
}

// pdf_le's pdf_pos at one sample of the light (constant over each shape).
float pdf_pos_of(const Light& l, const LightData& data) {
  const LightLeSample s = draw(l, data, 99, 0);
  return pdf_le(l, s.p, s.n, s.d, data, kRadius).pdf_pos;
}

TEST(LightEmission, ShapePositionsChi2) {
  chi2::Grid g;
  g.nu = g.nv = 12;
  {
    const TriangleLight t = triangle();
    const D3 v0 = chi2::to_d3(t.v0), e1 = sub(chi2::to_d3(t.v1), v0), e2 = sub(chi2::to_d3(t.v2), v0);
    // Barycentric (b1, b2) cover half the unit square: area 2A per unit.
    const double jac = len(cross(e1, e2)) * pdf_pos_of(t, nullptr);
    check_positions(
        "triangle positions", t, nullptr, g, 12,
        [&](const LightLeSample& s, double& a, double& b) { plane_coords(v0, e1, e2, chi2::to_d3(s.p), a, b); },
        [&](double a, double b) { return a + b <= 1.0 ? jac : 0.0; });
  }
  {
    const ParallelogramLight p = parallelogram();
    const D3 c = chi2::to_d3(p.corner), e1 = chi2::to_d3(p.e1), e2 = chi2::to_d3(p.e2);
    const double jac = len(cross(e1, e2)) * pdf_pos_of(p, nullptr);
    check_positions(
        "parallelogram positions", p, nullptr, g, 13,
        [&](const LightLeSample& s, double& a, double& b) { plane_coords(c, e1, e2, chi2::to_d3(s.p), a, b); },
        [&](double, double) { return jac; });
  }
  {
    // The direction from the centre: pdf_pos r² per steradian.
    const SphereLight sp = sphere(false);
    const double density = double(sp.radius) * sp.radius * pdf_pos_of(sp, nullptr);
    auto sample = [&](uint64_t i, Vec3& w) {
      const LightLeSample s = draw(sp, nullptr, 14, i);
      if (!valid(s)) return false;
      w = s.p - sp.center;
      return true;
    };
    const chi2::Outcome out = chi2::run_sphere(grid({0.1, 0.7, -0.3}), kSamples, sample, [&](D3) { return density; });
    std::printf("%-26s %s\n", "sphere positions", out.result.summary().c_str());
    EXPECT_TRUE(out.result.passes(kThreshold)) << out.describe(kThreshold);
  }
}

// Lights at infinity: each origin lies on the disk of radius r about
// center - d r perpendicular to d; polar (ρ² / r², φ) about d, where a uniform
// disk has density pdf_pos r² / 2.
void check_disk(const char* what, const Light& l, const LightData& data, uint64_t seed) {
  chi2::Grid g;
  g.nu = 10;
  g.nv = 16;
  g.v1 = 2 * M_PI;
  g.edge_tol = 1e-5;
  const double density = 0.5 * double(kRadius) * kRadius * pdf_pos_of(l, data);
  double worst_offset = 0.0;
  check_positions(
      what, l, data, g, seed,
      [&](const LightLeSample& s, double& u, double& v) {
        const D3 d = chi2::to_d3(s.d), c = sub(chi2::to_d3(kCenter), {d.x * kRadius, d.y * kRadius, d.z * kRadius});
        const D3 q = sub(chi2::to_d3(s.p), c);
        const chi2::DFrame f(d);
        worst_offset = std::max(worst_offset, std::fabs(chi2::dot(q, d)) / kRadius);
        const double x = chi2::dot(q, f.s) / kRadius, y = chi2::dot(q, f.t) / kRadius;
        u = x * x + y * y;
        v = std::atan2(y, x);
        if (v < 0.0) v += 2 * M_PI;
      },
      [&](double, double) { return density; });
  EXPECT_LT(worst_offset, 1e-5) << what << ": an origin off the disk's plane";
}

TEST(LightEmission, DiskPositionsChi2) {
  check_disk("directional disk", directional(), nullptr, 15);
  check_disk("constant disk", constant(), nullptr, 16);
  auto s = env_scene(sun_map(64, 33, 41, 9), kEnvRotation);
  check_disk("envmap disk", s->light(), s->view.lights.data, 17);
}

// -------------------------------------------------- pointwise agreement

struct Case {
  std::string name;
  Light light;
  LightData data;
  double flux = 0.0;  // what the mean of L |cos| / (pdf_pos pdf_dir) must be
};

std::vector<Case> cases(const EnvScene& env) {
  std::vector<Case> c;
  auto add = [&](const std::string& name, const Light& l, const LightData& data = nullptr) {
    c.push_back({name, l, data, phi(l, kRadius)});
  };
  add("triangle", triangle());
  add("parallelogram", parallelogram());
  add("triangle, two-sided", triangle(true));
  add("parallelogram, two-sided", parallelogram(true));
  add("sphere", sphere(false));
  add("sphere, flipped", sphere(true));
  add("point", point());
  add("spot, 4° cone", spot(4, 2, kSpotRotation));
  add("spot, 70° cone", spot(70, 50, kSpotRotation));
  add("spot, no falloff", spot(30, 30, kSpotRotation));
  add("spot, pbrt-v4's smoothstep", spot(70, 20, kSpotRotation, {1, 1, 1}, SpotFalloff::SmoothstepCos));
  add("spot, glTF's squared ramp", spot(70, 0, kSpotRotation, {1, 1, 1}, SpotFalloff::SquaredRampCos));
  add("spot, 120° cone", spot(120, 100, kSpotRotation, {1, 1, 1}, SpotFalloff::SmoothstepCos));
  add("directional", directional());
  add("constant", constant());
  add("envmap", env.light(), env.view.lights.data);
  return c;
}

TEST(LightEmission, PdfLeMatchesSamples) {
  auto env = env_scene(sun_map(64, 33, 41, 9), kEnvRotation);
  auto uneven = spot(40, 30, kSpotRotation, kSpotScale);
  std::vector<Case> all = cases(*env);
  all.push_back({"spot, scaled to_world", uneven});
  for (const Case& c : all) {
    const bool area = !is_delta(c.light) && !is_environment(c.light);
    const bool envmap = c.light.type == LightType::Envmap;
    uint64_t failed = 0, compared = 0;
    double worst_dir = 0.0, worst_ref = 0.0;
    for (uint64_t i = 0; i < kSamples / 4; ++i) {
      const LightLeSample s = draw(c.light, c.data, 20, i);
      if (!valid(s)) {
        ++failed;
        continue;
      }
      ASSERT_NEAR(length(s.d), 1.f, 1e-5f) << c.name;
      ASSERT_EQ(s.delta_pos, c.light.type == LightType::Point || c.light.type == LightType::Spot) << c.name;
      ASSERT_EQ(s.delta_dir, c.light.type == LightType::Directional) << c.name;
      if (area) {
        ASSERT_NEAR(length(s.n), 1.f, 1e-5f) << c.name;
        ASSERT_GT(dot(s.n, s.d), 0.f) << c.name << ": emitted toward the back";
      } else {
        ASSERT_TRUE(is_black(s.n)) << c.name;
      }
      if (c.light.type == LightType::Sphere) {
        const SphereLight& sp = c.light.sphere;
        const Vec3 out = (s.p - sp.center) / sp.radius;
        ASSERT_NEAR(length(s.n - (sp.flip ? -out : out)), 0.f, 1e-5f) << c.name << ": not the emitting normal";
      }
      const LightLePdf p = pdf_le(c.light, s.p, s.n, s.d, c.data, kRadius);
      ASSERT_FLOAT_EQ(p.pdf_pos, s.pdf_pos) << c.name;
      if (c.light.type == LightType::Spot) {
        const double want = spot_pdf(c.light.spot, chi2::to_d3(s.d));
        worst_ref = std::max(worst_ref, std::fabs(p.pdf_dir - want) / want);
      }
      if (!envmap) {
        ASSERT_FLOAT_EQ(p.pdf_dir, s.pdf_dir) << c.name;
        continue;
      }
      // Away from cell edges, where rounding may move the direction across.
      double gs, gt;
      direction_to_grid(apply_transpose(kEnvRotation, chi2::to_d3(-s.d)), 64, 33, gs, gt);
      const double fs = gs - std::floor(gs), ft = gt - std::floor(gt);
      if (fs < 1e-4 || fs > 1 - 1e-4 || ft < 1e-4 || ft > 1 - 1e-4) continue;
      ++compared;
      worst_dir = std::max(worst_dir, std::fabs(double(p.pdf_dir) / s.pdf_dir - 1.0));
    }
    std::printf("%-26s failed %llu; envmap: compared %llu, worst rel. pdf_dir %.2g; spot against double %.2g\n",
                c.name.c_str(), (unsigned long long)failed, (unsigned long long)compared, worst_dir, worst_ref);
    EXPECT_LT(double(failed), 1e-4 * kSamples) << c.name;
    EXPECT_LT(worst_dir, 1e-4) << c.name;
    EXPECT_LT(worst_ref, 1e-5) << c.name;
  }
}

// ------------------------------------------------------------------ flux

TEST(LightEmission, FluxIsPhi) {
  auto env = env_scene(sun_map(64, 33, 41, 9), kEnvRotation);
  const std::vector<Case> all = cases(*env);
  const double z = chi2::normal_two_sided_quantile(chi2::sidak(1e-3, int(all.size())));
  for (const Case& c : all) {
    double sum = 0.0, sum2 = 0.0;
    for (uint64_t i = 0; i < kSamples; ++i) {
      const LightLeSample s = draw(c.light, c.data, 30, i);
      if (!valid(s)) continue;
      const double cos = is_black(s.n) ? 1.0 : std::fabs(dot(s.n, s.d));
      const double x = average(s.radiance) * cos / (double(s.pdf_pos) * s.pdf_dir);
      sum += x;
      sum2 += x * x;
    }
    const double n = double(kSamples), mean = sum / n, var = std::max(0.0, sum2 / n - mean * mean);
    const double bound = z * std::sqrt(var / n) + 1e-4 * c.flux;
    std::printf("%-26s flux %.6g, want %.6g (rel. %.2g, bound %.2g)\n", c.name.c_str(), mean, c.flux,
                mean / c.flux - 1.0, bound / c.flux);
    EXPECT_NEAR(mean, c.flux, bound) << c.name;
  }
}

}  // namespace
