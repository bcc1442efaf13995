// Area-light sampling (sample_li / pdf_li of light/light.h): chi-square of the
// sampled directions against the solid-angle density of the emitter as seen
// from the reference point, computed here independently (own ray-triangle and
// ray-sphere intersection, in double), and agreement of the code's pdfs with
// that density at the sampled directions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <type_traits>
#include <vector>

#include "chi2.h"
#include "luz/scene/scene.h"

using namespace luz;
using chi2::D3;

namespace {

constexpr int kChi2Tests = 3 /* triangles */ + 3 /* spheres from outside */ + 2 /* from inside */ + 1 /* parallelogram */ +
                           3 /* constant environment */ + 2 /* two-sided, from behind */;
const double kThreshold = chi2::sidak(chi2::kAlpha, kChi2Tests);
constexpr uint64_t kSamples = 200000;
// Relative agreement of the code's float pdfs with the double reference: a
// few dozen float ulps (the conversions chain a handful of roundings).
constexpr double kPdfRelTol = 2e-5;

D3 sub(D3 a, D3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
D3 add(D3 a, D3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
D3 mul(D3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
D3 cross(D3 a, D3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
double len(D3 a) { return std::sqrt(chi2::dot(a, a)); }
double angle_between(D3 a, D3 b) { return std::atan2(len(cross(a, b)), chi2::dot(a, b)); }

// ---------------------------------------------------------------------------
// Triangle emitters: one-sided, emitting on the side of (p1-p0)×(p2-p0), or two-sided.
struct TriangleRef {
  D3 p0, p1, p2, n;  // n: unit normal
  double area;
  bool two_sided = false;
  TriangleRef(D3 a, D3 b, D3 c) : p0(a), p1(b), p2(c) {
    D3 x = cross(sub(b, a), sub(c, a));
    area = 0.5 * len(x);
    n = mul(x, 1.0 / len(x));
  }
  // Möller-Trumbore in double: the distance along unit w, if the ray hits.
  std::optional<double> hit(D3 o, D3 w) const {
    D3 e1 = sub(p1, p0), e2 = sub(p2, p0), pv = cross(w, e2);
    double det = chi2::dot(e1, pv);
    if (std::fabs(det) < 1e-300) return std::nullopt;
    D3 tv = sub(o, p0);
    double u = chi2::dot(tv, pv) / det;
    if (u < 0.0 || u > 1.0) return std::nullopt;
    D3 qv = cross(tv, e1);
    double v = chi2::dot(w, qv) / det;
    if (v < 0.0 || u + v > 1.0) return std::nullopt;
    double t = chi2::dot(e2, qv) / det;
    if (t <= 0.0) return std::nullopt;
    return t;
  }
  // Solid-angle density of uniform area sampling, seen from o, toward unit w.
  double pdf(D3 o, D3 w) const {
    auto t = hit(o, w);
    if (!t) return 0.0;
    double cos_l = two_sided ? std::fabs(chi2::dot(n, w)) : -chi2::dot(n, w);
    if (cos_l <= 0.0) return 0.0;  // the back of a one-sided emitter
    return (*t) * (*t) / (cos_l * area);
  }
};

// ---------------------------------------------------------------------------
// Sphere emitters: emitting outward, or inward when flipped.
struct SphereRef {
  D3 c;
  double r;
  bool flip;
  // Nearest positive hit distance along unit w from o.
  std::optional<double> hit(D3 o, D3 w) const {
    D3 f = sub(o, c);
    double b = chi2::dot(f, w), cc = chi2::dot(f, f) - r * r;
    double disc = b * b - cc;
    if (disc < 0.0) return std::nullopt;
    double s = std::sqrt(disc);
    double t0 = -b - s, t1 = -b + s;
    if (t0 > 0.0) return t0;
    if (t1 > 0.0) return t1;
    return std::nullopt;
  }
  bool inside(D3 o) const { return chi2::dot(sub(o, c), sub(o, c)) < r * r; }
  // Outside: the uniform density over the cone the sphere subtends; inside:
  // uniform area sampling converted to solid angle.
  double pdf(D3 o, D3 w) const {
    D3 to_c = sub(c, o);
    double d = len(to_c);
    if (!inside(o)) {
      if (flip) return 0.0;  // seen from outside, a flipped sphere shows its back
      double s2 = r * r / (d * d), one_minus_cos = s2 / (1.0 + std::sqrt(1.0 - s2));
      double theta_c = std::asin(r / d);
      return angle_between(to_c, w) <= theta_c ? 1.0 / (2.0 * chi2::kPi * one_minus_cos) : 0.0;
    }
    if (!flip) return 0.0;  // from inside, an outward-emitting sphere shows its back
    auto t = hit(o, w);
    if (!t) return 0.0;
    D3 n_out = mul(sub(add(o, mul(w, *t)), c), 1.0 / r);
    double cos_l = chi2::dot(n_out, w);
    if (cos_l <= 0.0) return 0.0;
    return (*t) * (*t) / (cos_l * 4.0 * chi2::kPi * r * r);
  }
};

Vec3 v3(D3 a) { return chi2::to_vec3(a); }

// ---------------------------------------------------------------------------
// A parallelogram light p0 + u e1 + v e2 as a mesh's two triangles (which
// Scene::compile merges into one Parallelogram emitter): uniform over the
// whole area, so the density toward w is t² / (cos θ_l · area of both).
struct QuadRef {
  TriangleRef t1, t2;
  D3 n;
  double area;
  bool two_sided = false;
  QuadRef(D3 p0, D3 e1, D3 e2)
      : t1(p0, add(p0, e1), add(p0, e2)), t2(add(add(p0, e1), e2), add(p0, e2), add(p0, e1)) {
    n = t1.n;
    area = t1.area + t2.area;
  }
  std::optional<double> hit(D3 o, D3 w) const {
    auto a = t1.hit(o, w);
    return a ? a : t2.hit(o, w);
  }
  double pdf(D3 o, D3 w) const {
    auto t = hit(o, w);
    if (!t) return 0.0;
    double cos_l = two_sided ? std::fabs(chi2::dot(n, w)) : -chi2::dot(n, w);
    if (cos_l <= 0.0) return 0.0;
    return (*t) * (*t) / (cos_l * area);
  }
};

struct EmitterScene {
  Scene scene;
  SceneView view;
};

std::unique_ptr<EmitterScene> triangle_scene(const TriangleRef& t) {
  auto s = std::make_unique<EmitterScene>();
  uint32_t m = s->scene.add_material(Bsdf::make_diffuse({.5f, .5f, .5f}));
  Color e{1.f, 2.f, 3.f};
  s->scene.add_mesh({v3(t.p0), v3(t.p1), v3(t.p2)}, {}, {0, 1, 2}, m, &e, {}, -1, t.two_sided);
  s->scene.compile();
  s->view = s->scene.view();
  return s;
}
std::unique_ptr<EmitterScene> sphere_scene(const SphereRef& sp) {
  auto s = std::make_unique<EmitterScene>();
  uint32_t m = s->scene.add_material(Bsdf::make_diffuse({.5f, .5f, .5f}));
  Color e{1.f, 2.f, 3.f};
  s->scene.add_sphere(v3(sp.c), float(sp.r), m, &e, sp.flip);
  s->scene.compile();
  s->view = s->scene.view();
  return s;
}

// Chi-square of sample_li(light 0, ref, ·) directions against `pdf`, plus the
// pointwise checks: at every sampled direction, ls.pdf and pdf_li() (fed the
// light point found by our own intersection) equal pdf(wi).
// `probability`, if not empty, gives the bins' probabilities (else they are
// the cubature of pdf over each bin).
template <class Ref>
void check_emitter(const SceneView& view, const Ref& light, D3 ref, const chi2::SphereGrid& g, uint64_t seed,
                   const char* what, const std::vector<double>& probability = {}) {
  Vec3 ref_f = v3(ref);
  ASSERT_EQ(view.lights.num_lights, 1u);
  const Light& lt = view.lights[0];
  const LightSampleContext ctx{ref_f, {}, {}};
  double worst_ls = 0.0, worst_ep = 0.0;
  uint64_t checked = 0;
  auto sample = [&](uint64_t i, Vec3& w) {
    LightSample ls = sample_li(lt, ctx, chi2::rand2(seed, i, 0), nullptr);
    if (!(ls.pdf > 0.f)) return false;
    w = ls.wi;
    if (i % 16 == 0) {
      D3 wd = chi2::normalized(chi2::to_d3(ls.wi));
      double want = light.pdf(ref, wd);
      auto t = light.hit(ref, wd);
      if (want > 0.0 && t) {
        worst_ls = std::max(worst_ls, std::fabs(ls.pdf - want) / want);
        // The light point as our own intersection sees it.
        Interaction it;
        D3 p = add(ref, mul(wd, *t));
        it.p = v3(p);
        it.emitter = 0;
        if constexpr (!std::is_same_v<Ref, SphereRef>) {
          it.ng = v3(light.n);
        } else {
          D3 n_out = mul(sub(p, light.c), 1.0 / light.r);
          it.ng = v3(light.flip ? mul(n_out, -1.0) : n_out);
        }
        it.ns = it.ng;
        float ep = pdf_li(lt, ctx, ls.wi, {it.ng, float(*t)}, nullptr);
        worst_ep = std::max(worst_ep, std::fabs(ep - want) / want);
        // The sample's own light point and distance agree with ours.
        EXPECT_NEAR(ls.dist, *t, 1e-5 * *t + 1e-6) << what;
        EXPECT_NEAR(length(ls.p - it.p), 0.f, 1e-5f * (ls.dist + length(it.p))) << what;
        EXPECT_FALSE(is_black(ls.radiance)) << what;
        ++checked;
      }
    }
    return true;
  };
  auto pdf = [&](D3 w) { return light.pdf(ref, w); };
  chi2::Outcome o = probability.empty() ? chi2::run_sphere(g, kSamples, sample, pdf)
                                        : chi2::run_sphere_expected(g, kSamples, sample, probability);
  std::printf("%-34s %s; worst rel. error: ls.pdf %.2g, emitter_pdf %.2g\n", what, o.result.summary().c_str(), worst_ls,
              worst_ep);
  EXPECT_NEAR(o.mass, 1.0, 1e-5) << what;
  EXPECT_EQ(o.failures, 0u) << what;
  EXPECT_TRUE(o.result.passes(kThreshold)) << what << ": " << o.describe(kThreshold);
  EXPECT_GT(checked, kSamples / 32) << what;
  EXPECT_LT(worst_ls, kPdfRelTol) << what;
  EXPECT_LT(worst_ep, kPdfRelTol) << what;
}

// Bins around the direction of the triangle's centroid, out to its farthest
// vertex (a spherical triangle lies in the cap its vertices lie in, for caps
// below a hemisphere); when the triangle fills more than that, bins over the
// hemisphere toward its plane.
chi2::SphereGrid triangle_grid(const TriangleRef& t, D3 ref) {
  chi2::SphereGrid g;
  // For the solid-angle cubature: the density jumps to zero at the
  // triangle's edges, which cut bins at any angle; start from 8×8 cells a bin.
  g.quad_split = 8;
  g.total_mass = 1.0;
  D3 centroid = mul(add(add(t.p0, t.p1), t.p2), 1.0 / 3.0);
  g.axis = chi2::normalized(sub(centroid, ref));
  double a = 0.0;
  for (D3 p : {t.p0, t.p1, t.p2}) a = std::max(a, angle_between(g.axis, sub(p, ref)));
  if (a * 1.02 < chi2::kPi / 2) {
    g.theta_max = a * 1.02;
  } else {
    g.axis = mul(t.n, -1.0);
    g.theta_max = chi2::kPi / 2;
  }
  return g;
}

// The bins' probabilities for a triangle, ∫bin pdf dω, taken over the
// triangle's area instead of over solid angle: with ω(p) the direction of
// the point p and dω = cos θ_l / d² dA,
//   ∫bin pdf dω = ∫{p : ω(p) ∈ bin} pdf(ω(p)) cos θ_l(p) / d(p)² dA,
// by the midpoint rule on m² congruent sub-triangles. The edges of the
// triangle are then exact, and a corner seen nearly edge-on (a needle a
// fraction of a bin wide, which the solid-angle cubature partly misses) is
// integrated like any other part; only sub-triangles cut by a bin boundary
// are misassigned, an O(1/m) relative error per bin that mostly cancels.
std::vector<double> triangle_bin_probabilities(const TriangleRef& t, D3 ref, const chi2::SphereGrid& g, int m) {
  chi2::SphereBinner binner(g);
  std::vector<double> prob(size_t(g.n_theta) * g.n_phi + 1, 0.0);
  D3 e1 = sub(t.p1, t.p0), e2 = sub(t.p2, t.p0);
  double sub_area = t.area / (double(m) * m);
  for (int i = 0; i < m; ++i)
    for (int j = 0; i + j < m; ++j)
      for (int up = 0; up < 2; ++up) {
        if (up && i + j + 1 >= m) continue;
        // Centroid of the "down" triangle (i,j),(i+1,j),(i,j+1) or the "up" one
        // (i+1,j),(i,j+1),(i+1,j+1), in units of 1/m.
        double b1 = (up ? i + 2.0 / 3.0 : i + 1.0 / 3.0) / m, b2 = (up ? j + 2.0 / 3.0 : j + 1.0 / 3.0) / m;
        D3 p = add(t.p0, add(mul(e1, b1), mul(e2, b2)));
        D3 d = sub(p, ref);
        double dist = len(d);
        D3 w = mul(d, 1.0 / dist);
        double cos_l = std::fabs(chi2::dot(t.n, w));
        double weight = t.pdf(ref, w) * cos_l / (dist * dist) * sub_area;
        long k = binner.bin(w);
        if (k >= 0) prob[size_t(k)] += weight;
      }
  return prob;
}

TriangleRef facing(D3 a, D3 b, D3 c, D3 ref) {
  TriangleRef t(a, b, c);
  if (chi2::dot(t.n, sub(ref, a)) < 0.0) return TriangleRef(a, c, b);
  return t;
}

}  // namespace

TEST(EmitterSampling, TriangleChi2) {
  struct Case {
    const char* what;
    D3 a, b, c, ref;
  };
  const Case cases[] = {
      {"triangle, ordinary view", {-1, -0.5, 2}, {1.2, -0.7, 2.5}, {0.1, 1, 1.8}, {0.3, -0.2, 0}},
      // 5 cm above a big triangle: it fills most of the hemisphere, with
      // cos θ_l → 0 toward its far corners.
      {"triangle, close up", {-1, -1, 0}, {3, -1, 0}, {-1, 3, 0}, {0.1, 0.2, 0.05}},
      // Seen nearly edge-on: the d²/cos conversion at grazing angles.
      {"triangle, grazing", {0, 0, 0}, {1, 0, 0}, {0, 1, 0.02}, {3, 2.5, 0.2}},
  };
  int seed = 1;
  for (const Case& c : cases) {
    TriangleRef t = facing(c.a, c.b, c.c, c.ref);
    auto s = triangle_scene(t);
    chi2::SphereGrid g = triangle_grid(t, c.ref);
    std::vector<double> prob = triangle_bin_probabilities(t, c.ref, g, 1000);
    // The same probabilities by cubature over solid angle: ∫pdf dω must be 1
    // (this checks the reference density itself), and the bins agree but for
    // the needle-like corners of grazing views.
    chi2::SphereBinner binner(g);
    chi2::Outcome direct;
    direct.samples = kSamples;
    direct.expected.assign(prob.size() + 1, 0.0);
    chi2::integrate_bins(direct, binner.grid, [&](double theta, double phi) {
      return t.pdf(c.ref, binner.frame.to_world(theta, phi)) * std::sin(theta);
    });
    double worst = 0.0;
    for (size_t k = 0; k < prob.size(); ++k)
      worst = std::max(worst, std::fabs(direct.expected[k] - prob[k] * kSamples) / std::sqrt(prob[k] * kSamples + 1.0));
    std::printf("%-34s solid-angle cubature: ∫pdf dω - 1 = %.2g; worst bin difference %.2g standard deviations\n",
                c.what, direct.mass - 1.0, worst);
    EXPECT_NEAR(direct.mass, 1.0, 1e-3) << c.what;
    check_emitter(s->view, t, c.ref, g, seed++, c.what, prob);
  }
}

TEST(EmitterSampling, SphereFromOutsideChi2) {
  struct Case {
    const char* what;
    D3 c;
    double r;
    D3 ref;
  };
  const Case cases[] = {
      {"sphere r=.05 at distance 10", {0.3, 9.99, -0.2}, 0.05, {0, 0, 0}},
      {"sphere r=.1 at distance 3", {1, -2, 2}, 0.1, {0, 0, 0}},  // sin²θ just above 1e-3
      {"sphere r=1 at distance 1.2", {0.5, 0.3, -1}, 1.0, {0.2, 0.1, 0.02}},
  };
  int seed = 10;
  for (const Case& c : cases) {
    SphereRef sp{c.c, c.r, false};
    auto s = sphere_scene(sp);
    D3 to_c = sub(c.c, c.ref);
    chi2::SphereGrid g;
    g.total_mass = 1.0;
    g.axis = chi2::normalized(to_c);
    g.theta_max = std::asin(c.r / len(to_c));  // bins over exactly the cone
    g.edge_tol = 1e-6;                         // float rounding of the direction at the rim
    check_emitter(s->view, sp, c.ref, g, seed++, c.what);
  }
}

TEST(EmitterSampling, SphereFromInsideChi2) {
  struct Case {
    const char* what;
    D3 ref;
  };
  const Case cases[] = {
      {"inside flipped sphere, off centre", {0.3, -0.2, 0.1}},
      {"inside flipped sphere, near wall", {0.1, 0.05, 0.85}},
  };
  SphereRef sp{{0.2, -0.1, 0.3}, 1.0, true};
  auto s = sphere_scene(sp);
  int seed = 20;
  for (const Case& c : cases) {
    D3 ref = add(c.ref, sp.c);
    chi2::SphereGrid g;
    g.total_mass = 1.0;
    g.axis = chi2::normalized(sub(ref, sp.c));  // the nearest wall at θ = 0
    check_emitter(s->view, sp, ref, g, seed++, c.what);
  }
}

// One-sided emitters seen from the back: no sample succeeds, pdf_li is 0.
TEST(EmitterSampling, BackFacesGiveNothing) {
  {
    D3 ref{0.3, -0.2, 0};
    TriangleRef front = facing({-1, -0.5, 2}, {1.2, -0.7, 2.5}, {0.1, 1, 1.8}, ref);
    TriangleRef back(front.p0, front.p2, front.p1);
    auto s = triangle_scene(back);
    for (uint64_t i = 0; i < 1000; ++i) {
      const LightSampleContext ctx{v3(ref), {}, {}};
      LightSample ls = sample_li(s->view.lights[0], ctx, chi2::rand2(30, i, 0), nullptr);
      ASSERT_EQ(ls.pdf, 0.f);
      Interaction it;
      it.ng = v3(back.n);
      it.emitter = 0;
      ASSERT_EQ(pdf_li(s->view.lights[0], ctx, ls.wi, {it.ng, ls.dist}, nullptr), 0.f);
    }
  }
  {
    SphereRef outward{{0, 0, 0}, 1.0, false};
    auto s = sphere_scene(outward);
    for (uint64_t i = 0; i < 1000; ++i)
      ASSERT_EQ(sample_li(s->view.lights[0], {{0.2f, 0.3f, -0.1f}, {}, {}}, chi2::rand2(31, i, 0), nullptr).pdf, 0.f)
          << "outward sphere seen from inside";
  }
  {
    SphereRef inward{{0, 0, 0}, 1.0, true};
    auto s = sphere_scene(inward);
    for (uint64_t i = 0; i < 1000; ++i)
      ASSERT_EQ(sample_li(s->view.lights[0], {{0.5f, 2.f, -0.1f}, {}, {}}, chi2::rand2(32, i, 0), nullptr).pdf, 0.f)
          << "flipped sphere seen from outside";
  }
}

// cdf_find over a stored CDF (a 0 in front) is the first k with u < cdf[k]
// (checked against std::upper_bound, zero-power entries included: never
// chosen). PowerLightSampler over the same pmfs (an alias table) picks only
// lights with power, returns their pmf, rescales u into [0,1), and leaves it
// alone when there is one light.
TEST(EmitterSampling, SelectionIsTheCdfInverse) {
  for (std::vector<float> cdf : {std::vector<float>{1.f}, {0.5f, 1.f}, {0.f, 0.25f, 0.25f, 0.7f, 1.f},
                                 {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f, 0.8f, 0.9f, 1.f, 1.f}}) {
    std::vector<double> w(cdf.size());
    for (size_t k = 0; k < cdf.size(); ++k) w[k] = double(cdf[k]) - (k > 0 ? cdf[k - 1] : 0.f);
    std::vector<float> stored{0.f};
    stored.insert(stored.end(), cdf.begin(), cdf.end());
    std::vector<AliasEntry> entries;
    std::vector<float> pmf;
    ASSERT_TRUE(build_alias_table(w.data(), uint32_t(w.size()), entries, pmf));
    PowerLightSampler v;
    v.table = {entries.data(), pmf.data(), uint32_t(cdf.size())};
    for (int k = 0; k < 4096; ++k) {
      float u = (k + 0.5f) / 4096.f;
      uint32_t e = cdf_find(stored.data(), uint32_t(cdf.size()), u);
      EXPECT_EQ(e, uint32_t(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin())) << u;
      float lo = e > 0 ? cdf[e - 1] : 0.f;
      EXPECT_GT(cdf[e], lo) << "an empty interval was chosen";
      float r = u;
      const SampledLight sl = v.sample({}, r);
      EXPECT_GT(w[sl.light], 0.0) << "a light without power was chosen";
      EXPECT_EQ(sl.pmf, pmf[sl.light]);
      EXPECT_EQ(v.pmf({}, sl.light), pmf[sl.light]);
      if (cdf.size() == 1) {
        EXPECT_EQ(r, u);
        continue;
      }
      EXPECT_GE(r, 0.f);
      EXPECT_LT(r, 1.f);
    }
  }
}

// A quad light (two triangles of one mesh forming a parallelogram) is merged
// into one Parallelogram emitter, sampled uniformly over its area: chi-square
// against the density of the two triangles' union, computed independently.
// A quad that is not a parallelogram stays two triangle emitters.
TEST(EmitterSampling, ParallelogramChi2) {
  const D3 p0{-1, -0.5, 2}, e1{1.8, 0.3, 0.4}, e2{0.5, 1.4, -0.2}, ref{0.2, 0.1, 0};
  QuadRef q(p0, e1, e2);
  if (chi2::dot(q.n, sub(ref, p0)) < 0.0) q = QuadRef(p0, e2, e1);
  auto s = std::make_unique<EmitterScene>();
  uint32_t m = s->scene.add_material(Bsdf::make_diffuse({.5f, .5f, .5f}));
  Color e{1.f, 2.f, 3.f};
  s->scene.add_mesh({v3(q.t1.p0), v3(q.t1.p1), v3(q.t1.p2), v3(q.t2.p0)}, {}, {0, 1, 2, 3, 2, 1}, m, &e);
  s->scene.compile();
  s->view = s->scene.view();
  ASSERT_EQ(s->scene.lights.size(), 1u);
  EXPECT_EQ(s->scene.lights[0].type, LightType::Parallelogram);
  EXPECT_NEAR(s->scene.lights[0].parallelogram.area, q.area, 1e-5 * q.area);
  chi2::SphereGrid g;
  g.quad_split = 8;
  g.total_mass = 1.0;
  D3 center = add(p0, mul(add(e1, e2), 0.5));
  g.axis = chi2::normalized(sub(center, ref));
  double a = 0.0;
  for (D3 p : {q.t1.p0, q.t1.p1, q.t1.p2, q.t2.p0}) a = std::max(a, angle_between(g.axis, sub(p, ref)));
  g.theta_max = a * 1.02;
  check_emitter(s->view, q, ref, g, 11, "parallelogram (two triangles)");

  // Move one corner: a trapezoid, not merged.
  Scene t;
  uint32_t mt = t.add_material(Bsdf::make_diffuse({.5f, .5f, .5f}));
  t.add_mesh({v3(q.t1.p0), v3(q.t1.p1), v3(q.t1.p2), v3(add(q.t2.p0, mul(e1, 0.1)))}, {}, {0, 1, 2, 3, 2, 1}, mt, &e);
  t.compile();
  EXPECT_EQ(t.lights.size(), 2u);
  EXPECT_EQ(t.lights[0].type, LightType::Triangle);
}

// Two-sided emitters (pbrt-v4's twosided area lights) seen from behind:
// the densities of the front, with |cos θ_l|. (From behind, a one-sided
// emitter gives no sample: TriangleChi2's facing() avoids that case.)
TEST(EmitterSampling, TwoSidedSeenFromBehind) {
  const D3 ref{0.3, -0.2, 0};
  const TriangleRef front = facing({-1, -0.5, 2}, {1.2, -0.7, 2.5}, {0.1, 1, 1.8}, ref);
  TriangleRef back(front.p0, front.p2, front.p1);
  back.two_sided = true;
  ASSERT_LT(chi2::dot(back.n, sub(ref, back.p0)), 0.0);
  auto t = triangle_scene(back);
  EXPECT_TRUE(t->scene.lights[0].triangle.two_sided);
  check_emitter(t->view, back, ref, triangle_grid(back, ref), 31, "triangle, two-sided, from behind");

  const D3 p0{-1, -0.5, 2}, e1{1.8, 0.3, 0.4}, e2{0.5, 1.4, -0.2};
  QuadRef q(p0, e1, e2);
  if (chi2::dot(q.n, sub(ref, p0)) > 0.0) q = QuadRef(p0, e2, e1);
  q.two_sided = true;
  auto s = std::make_unique<EmitterScene>();
  const uint32_t m = s->scene.add_material(Bsdf::make_diffuse({.5f, .5f, .5f}));
  const Color e{1.f, 2.f, 3.f};
  s->scene.add_mesh({v3(q.t1.p0), v3(q.t1.p1), v3(q.t1.p2), v3(q.t2.p0)}, {}, {0, 1, 2, 3, 2, 1}, m, &e, {}, -1, true);
  s->scene.compile();
  s->view = s->scene.view();
  ASSERT_EQ(s->scene.lights.size(), 1u);
  ASSERT_EQ(s->scene.lights[0].type, LightType::Parallelogram);
  EXPECT_TRUE(s->scene.lights[0].parallelogram.two_sided);
  chi2::SphereGrid g;
  g.quad_split = 8;
  g.total_mass = 1.0;
  g.axis = chi2::normalized(sub(add(p0, mul(add(e1, e2), 0.5)), ref));
  double a = 0.0;
  for (D3 p : {q.t1.p0, q.t1.p1, q.t1.p2, q.t2.p0}) a = std::max(a, angle_between(g.axis, sub(p, ref)));
  g.theta_max = a * 1.02;
  check_emitter(s->view, q, ref, g, 32, "parallelogram, two-sided, from behind");

  // Merged only with a neighbour of the same sidedness.
  Scene mixed;
  const uint32_t mm = mixed.add_material(Bsdf::make_diffuse({.5f, .5f, .5f}));
  mixed.add_mesh({v3(q.t1.p0), v3(q.t1.p1), v3(q.t1.p2)}, {}, {0, 1, 2}, mm, &e, {}, -1, true);
  mixed.add_mesh({v3(q.t2.p0), v3(q.t2.p1), v3(q.t2.p2)}, {}, {0, 1, 2}, mm, &e);
  mixed.compile();
  EXPECT_EQ(mixed.lights.size(), 2u);
}

// compile() after a change of geometry re-derives the merged light: undone,
// then merged again from the triangles as they are now; a degenerate
// neighbour (a repeated position) is never merged.
TEST(EmitterSampling, ParallelogramFollowsGeometryChanges) {
  Scene s;
  uint32_t m = s.add_material(Bsdf::make_diffuse({.5f, .5f, .5f}));
  Color e{1.f, 1.f, 1.f};
  s.add_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}}, {}, {0, 1, 2, 3, 2, 1}, m, &e);
  s.compile();
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_FLOAT_EQ(s.lights[0].parallelogram.area, 1.f);
  for (Vec3& p : s.positions) p = p * 2.f + Vec3{0, 0, 1};
  s.compile();
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].type, LightType::Parallelogram);
  EXPECT_FLOAT_EQ(s.lights[0].parallelogram.area, 4.f);
  EXPECT_FLOAT_EQ(s.lights[0].parallelogram.corner.z, 1.f);
  // Now not a parallelogram: two triangle emitters, each naming itself.
  s.positions[3] = Vec3{3, 3, 1};
  s.compile();
  ASSERT_EQ(s.lights.size(), 2u);
  EXPECT_EQ(s.tri_emitter[0], 0);
  EXPECT_EQ(s.tri_emitter[1], 1);
  EXPECT_EQ(s.lights[1].triangle.prim, 1u);
  // A degenerate emitter triangle next to a proper one.
  Scene d;
  uint32_t md = d.add_material(Bsdf::make_diffuse({.5f, .5f, .5f}));
  d.add_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}}, {}, {0, 1, 2, 1, 3, 2}, md, &e);
  d.compile();
  EXPECT_EQ(d.lights.size(), 2u);
}

namespace {

// The constant environment toward a point that receives light from one
// hemisphere (LightSampleContext::hemisphere): directions by the cosine about
// its pole (χ² over the whole sphere, the lower half expecting nothing), each
// sample's pdf equal to pdf_li, and pdf_li integrating to one; without a
// hemisphere, uniform over the sphere; with a guide (light/env_guide.h: a
// distribution over bins of the world sphere, some empty, some below the
// pole's horizon), the mixture of the guide and the cosine.
TEST(EmitterSampling, ConstantEnvironmentOverTheHemisphere) {
  ConstantLight sky;
  sky.radiance = {1.f, 1.f, 1.f};
  const Light l(sky);
  const D3 pole = chi2::normalized({0.3, -0.5, 0.8});
  const LightSampleContext ctx{{0.1f, 0.2f, 0.3f}, chi2::to_vec3(pole), {}, chi2::to_vec3(pole)};
  // One grid cell; every side's region the one distribution.
  std::vector<int32_t> regions(EnvGuide::kSides, 0);
  std::vector<float> cdf(EnvGuide::kBins);
  double total = 0;
  for (int b = 0; b < EnvGuide::kBins; ++b) total += b % 7 == 0 ? 5 : b % 3 == 0 ? 0 : 1;
  for (int b = 0, acc = 0; b < EnvGuide::kBins; ++b) {
    acc += b % 7 == 0 ? 5 : b % 3 == 0 ? 0 : 1;
    cdf[size_t(b)] = b == EnvGuide::kBins - 1 ? 1.f : float(acc / total);
  }
  EnvGuide guide;
  guide.regions = regions.data();
  guide.cdf = cdf.data();
  guide.lo = {-10.f, -10.f, -10.f};
  guide.inv_cell = {0.05f, 0.05f, 0.05f};
  guide.nx = guide.ny = guide.nz = 1;
  guide.mix = 0.85f;
  ASSERT_EQ(guide.find(ctx.p, ctx.hemisphere), 0);
  LightData guided;
  guided.guide = &guide;
  for (const int kind : {0, 1, 2}) {
    const bool hemisphere = kind != 1;
    const LightSampleContext c = hemisphere ? ctx : LightSampleContext{ctx.p, ctx.n, ctx.ns};
    const LightData data = kind == 2 ? guided : LightData(nullptr);
    uint64_t mismatched = 0;
    auto sample = [&](uint64_t i, Vec3& w) {
      const LightSample ls = sample_li(l, c, chi2::rand2(40, i, 0), data);
      if (!(ls.pdf > 0.f)) return false;
      mismatched += std::fabs(ls.pdf - pdf_li(l, c, ls.wi, {}, data)) > 1e-4f * ls.pdf;
      w = ls.wi;
      return true;
    };
    auto pdf = [&](D3 w) { return double(pdf_li(l, c, chi2::to_vec3(w), {}, data)); };
    chi2::SphereGrid g;
    g.axis = pole;
    g.total_mass = 1.0;
    const chi2::Outcome o = chi2::run_sphere(g, kSamples, sample, pdf);
    const char* what = kind == 2 ? "constant, guide and cosine" : hemisphere ? "constant, cosine about the pole" : "constant, uniform";
    std::printf("%-40s %s\n", what, o.result.summary().c_str());
    EXPECT_TRUE(o.result.passes(kThreshold)) << what << ": " << o.describe(kThreshold);
    EXPECT_EQ(mismatched, 0u) << what;
    const double mass = chi2::integrate_2d(
        [&](double theta, double phi) {
          const D3 w{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
          return pdf(w) * std::sin(theta);
        },
        0, M_PI, 0, 2 * M_PI);
    EXPECT_NEAR(mass, 1.0, 1e-3) << what;
  }
}

}  // namespace
