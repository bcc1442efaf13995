// Chi-square tests of every warp in luz/sampling/warp.h against its pdf
// (harness: tests/chi2.h), and a demonstration that the same check rejects the
// seed's uncorrected disk formula.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "chi2.h"
#include "luz/sampling/warp.h"

using namespace luz;

namespace {

// Cones by sin²θmax of the sphere that subtends them (cone_one_minus_cos), from
// a hemisphere down to a sphere of radius 1e-6 seen from distance 1.
constexpr float kConeSin2[] = {1.f, 0.5f, 0.0011f, 2.5e-5f, 1e-8f, 1e-12f};
constexpr float kPowerExponents[] = {1.f, 2.f, 5.f, 10.f, 50.f, 100.f, 1000.f};
// disk, seed disk, cosine hemisphere, sphere, full-sphere cone, cones, powers, triangle.
constexpr int kChi2Tests = 4 + 1 + int(std::size(kConeSin2)) + int(std::size(kPowerExponents)) + 1;
const double kThreshold = chi2::sidak(chi2::kAlpha, kChi2Tests);

constexpr uint64_t kSamples = 200000;

// The seed's disk: radius r1 instead of sqrt(r1). Its density is 1/(2πr), not 1/π.
Vec2 seed_disk(Vec2 u) {
  float r = u.x, phi = 2.f * kPi * u.y;
  return {r * cosf(phi), r * sinf(phi)};
}

// Disk points binned in (r², φ): 10 × 20 bins of equal area. The density in
// those coordinates is pdf(p) / 2 (dA = r dr dφ = ½ d(r²) dφ).
template <class Warp>
chi2::Outcome disk_test(Warp warp, uint64_t seed, uint64_t n = kSamples) {
  chi2::Grid g;
  g.nu = 10;
  g.nv = 20;
  g.u0 = 0.0;
  g.u1 = 1.0;
  g.u_end = 4.0;  // anything beyond the unit circle lands in the overflow bin
  g.edge_tol = 1e-6;
  g.v0 = 0.0;
  g.v1 = 2.0 * chi2::kPi;
  g.total_mass = 1.0;  // a warp never fails
  auto sample = [&](uint64_t i, double& q, double& phi) {
    Vec2 p = warp(chi2::rand2(seed, i, 0));
    q = double(p.x) * p.x + double(p.y) * p.y;
    phi = std::atan2(double(p.y), double(p.x));
    if (phi < 0.0) phi += 2.0 * chi2::kPi;
    return true;
  };
  auto density = [](double q, double phi) {
    double r = std::sqrt(q);
    return 0.5 * double(uniform_disk_pdf({float(r * std::cos(phi)), float(r * std::sin(phi))}));
  };
  return chi2::run_grid(g, n, sample, density);
}

}  // namespace

TEST(Warp, UniformDiskChi2) {
  chi2::Outcome o = disk_test(square_to_uniform_disk, 1);
  EXPECT_NEAR(o.mass, 1.0, 1e-6);
  EXPECT_TRUE(o.result.passes(kThreshold)) << o.describe(kThreshold);
  std::printf("uniform disk: %s\n", o.result.summary().c_str());
}

// The same check, fed the seed's formula, must reject it: this is what shows the
// check can fail.
TEST(Warp, SeedDiskFormulaIsRejected) {
  chi2::Outcome o = disk_test(seed_disk, 1);
  std::printf("seed disk (r = r1): %s\n", o.result.summary().c_str());
  EXPECT_FALSE(o.result.passes(kThreshold)) << o.describe(kThreshold);
  EXPECT_LT(o.result.p_value, kThreshold);
  // Also with a hundred times fewer samples.
  chi2::Outcome o2 = disk_test(seed_disk, 2, kSamples / 100);
  std::printf("seed disk, %llu samples: %s\n", (unsigned long long)(kSamples / 100), o2.result.summary().c_str());
  EXPECT_LT(o2.result.p_value, kThreshold);
}

// The inline sin/cos of the concentric map against double-precision libm, on
// a dense grid of [-π/4, π/4] and its end points.
TEST(Warp, CosSinQuarterIsAccurate) {
  double worst_s = 0, worst_c = 0;
  const int n = 200001;
  for (int k = 0; k < n; ++k) {
    float x = float(-kPi / 4.0 + (kPi / 2.0) * k / (n - 1));
    Vec2 cs = cos_sin_quarter(x);
    double s = std::sin(double(x)), c = std::cos(double(x));
    // Errors in units of the last place of the exact value.
    worst_s = std::max(worst_s, std::abs(cs.y - s) / std::max(double(std::nextafter(float(std::abs(s)), 1.f) - float(std::abs(s))), 1e-45));
    worst_c = std::max(worst_c, std::abs(cs.x - c) / double(std::nextafter(float(c), 2.f) - float(c)));
  }
  RecordProperty("worst_sin_ulp", std::to_string(worst_s));
  RecordProperty("worst_cos_ulp", std::to_string(worst_c));
  std::printf("cos_sin_quarter: worst %.2f ulp (sin), %.2f ulp (cos)\n", worst_s, worst_c);
  EXPECT_LE(worst_s, 2.0);
  EXPECT_LE(worst_c, 2.0);
}

TEST(Warp, CosineHemisphereChi2) {
  chi2::SphereGrid g;
  g.total_mass = 1.0;           // a warp never fails
  g.theta_max = chi2::kPi / 2;  // the lower hemisphere is the overflow bin: expected 0
  g.edge_tol = 1e-6;
  auto sample = [](uint64_t i, Vec3& w) {
    w = square_to_cosine_hemisphere(chi2::rand2(3, i, 0));
    return true;
  };
  auto pdf = [](chi2::D3 w) { return double(cosine_hemisphere_pdf(chi2::to_vec3(w))); };
  chi2::Outcome o = chi2::run_sphere(g, kSamples, sample, pdf);
  EXPECT_NEAR(o.mass, 1.0, 1e-6);
  EXPECT_TRUE(o.result.passes(kThreshold)) << o.describe(kThreshold);
}

TEST(Warp, UniformSphereChi2) {
  chi2::SphereGrid g;
  g.total_mass = 1.0;  // a warp never fails
  auto sample = [](uint64_t i, Vec3& w) {
    w = square_to_uniform_sphere(chi2::rand2(4, i, 0));
    return true;
  };
  auto pdf = [](chi2::D3) { return double(uniform_sphere_pdf()); };
  chi2::Outcome o = chi2::run_sphere(g, kSamples, sample, pdf);
  EXPECT_NEAR(o.mass, 1.0, 1e-6);
  EXPECT_TRUE(o.result.passes(kThreshold)) << o.describe(kThreshold);
}

namespace {
// θ×φ bins over exactly the cone (so the density is constant in every bin),
// everything else in the overflow bin, which must stay empty.
chi2::Outcome cone_test(float one_minus_cos, uint64_t seed) {
  // θmax from 1 - cos θ = 2 sin²(θ/2), exact for tiny cones.
  double theta_c = 2.0 * std::asin(std::sqrt(0.5 * double(one_minus_cos)));
  chi2::SphereGrid g;
  g.total_mass = 1.0;  // a warp never fails
  g.theta_max = std::min(theta_c, chi2::kPi);
  g.edge_tol = 1e-5 * theta_c;  // float rounding of the sampled direction at the rim
  auto sample = [&](uint64_t i, Vec3& w) {
    w = square_to_uniform_cone(chi2::rand2(seed, i, 0), one_minus_cos);
    return true;
  };
  auto pdf = [&](chi2::D3 w) {
    double theta = std::atan2(std::sqrt(w.x * w.x + w.y * w.y), w.z);
    return theta <= theta_c ? double(uniform_cone_pdf(one_minus_cos)) : 0.0;
  };
  return chi2::run_sphere(g, kSamples, sample, pdf);
}
}  // namespace

TEST(Warp, UniformConeFullSphereChi2) {
  chi2::Outcome o = cone_test(2.f, 5);
  EXPECT_NEAR(o.mass, 1.0, 1e-6);
  EXPECT_TRUE(o.result.passes(kThreshold)) << o.describe(kThreshold);
}

TEST(Warp, UniformConeChi2) {
  int k = 0;
  for (float s2 : kConeSin2) {
    float omc = cone_one_minus_cos(s2);
    chi2::Outcome o = cone_test(omc, 10 + k++);
    EXPECT_NEAR(o.mass, 1.0, 1e-5) << "sin2 " << s2;
    EXPECT_TRUE(o.result.passes(kThreshold)) << "sin2 " << s2 << ", 1-cos " << omc << ": " << o.describe(kThreshold);
  }
}

// 1 - cos θmax = 1 - sqrt(1 - s²) to float precision everywhere, including near
// the switch between the series and the closed form (a few ulps; the
// cancellation in 1 - sqrt(1 - s²) would lose ~1e-4 there).
TEST(Warp, ConeOneMinusCosIsAccurate) {
  double worst = 0.0, worst_s2 = 0.0;
  for (double s2 = 1e-12; s2 <= 1.0; s2 *= 1.01) {
    float f = cone_one_minus_cos(float(s2));
    double exact = double(float(s2)) / (1.0 + std::sqrt(1.0 - double(float(s2))));
    double rel = std::fabs(f - exact) / exact;
    if (rel > worst) worst = rel, worst_s2 = s2;
  }
  std::printf("cone_one_minus_cos: worst relative error %.3g at sin2 = %.4g\n", worst, worst_s2);
  EXPECT_LT(worst, 4e-7);  // four float ulps
}

TEST(Warp, CosinePowerChi2) {
  int k = 0;
  for (float n : kPowerExponents) {
    // Bins over the cap holding all but 1e-3 of the lobe (P(θ > t) = cos^{n+1} t),
    // whose rest is the overflow bin (expected 1e-3 N).
    double theta_max = std::acos(std::pow(1e-3, 1.0 / (double(n) + 1.0)));
    chi2::SphereGrid g;
    g.total_mass = 1.0;
    g.theta_max = theta_max;
    auto sample = [&](uint64_t i, Vec3& w) {
      w = square_to_cosine_power(chi2::rand2(20 + k, i, 0), n);
      return true;
    };
    auto pdf = [&](chi2::D3 w) { return double(cosine_power_pdf(float(w.z), n)); };
    chi2::Outcome o = chi2::run_sphere(g, kSamples, sample, pdf);
    ++k;
    EXPECT_NEAR(o.mass, 1.0, 1e-4) << "n " << n;
    EXPECT_TRUE(o.result.passes(kThreshold)) << "n " << n << ": " << o.describe(kThreshold);
  }
}

// Uniform on a triangle. The triangle is cut into m² congruent sub-triangles
// (rows i of the barycentric grid, "up" and "down" ones), each expecting
// N × ∫pdf = N × area / total area; the histogram counts where the sampled
// barycentrics land, mapped to a real triangle in the plane and back.
TEST(Warp, TriangleBarycentricsChi2) {
  const int m = 12;
  const double p0[2] = {0.2, -0.3}, p1[2] = {2.0, 0.1}, p2[2] = {0.7, 1.6};
  double e1[2] = {p1[0] - p0[0], p1[1] - p0[1]}, e2[2] = {p2[0] - p0[0], p2[1] - p0[1]};
  double det = e1[0] * e2[1] - e1[1] * e2[0], area = 0.5 * std::fabs(det);
  std::vector<double> observed(m * m + 1, 0.0), expected(m * m + 1, 0.0);
  uint64_t outside = 0;
  for (uint64_t i = 0; i < kSamples; ++i) {
    Vec2 b = square_to_triangle_barycentrics(chi2::rand2(30, i, 0));
    // The point on the triangle, then its barycentrics recovered in double.
    double x = p0[0] + b.x * e1[0] + b.y * e2[0] - p0[0], y = p0[1] + b.x * e1[1] + b.y * e2[1] - p0[1];
    double b1 = (x * e2[1] - y * e2[0]) / det, b2 = (e1[0] * y - e1[1] * x) / det;
    const double tol = 1e-6;
    if (b1 < -tol || b2 < -tol || b1 + b2 > 1.0 + tol) {
      ++outside;
      observed[m * m] += 1.0;
      continue;
    }
    double s = std::clamp(b1, 0.0, 1.0) * m, t = std::clamp(b2, 0.0, 1.0) * m;
    int is = std::min(int(s), m - 1), it = std::min(int(t), m - 1 - is);
    bool up = (s - is) + (t - it) > 1.0 && is + it < m - 1;
    // Index: cells (is, it) with is + it ≤ m - 1 ("down" triangles, m(m+1)/2 of
    // them) then the "up" ones with is + it ≤ m - 2.
    int down_index = is * m - is * (is - 1) / 2 + it;
    int up_index = m * (m + 1) / 2 + is * (m - 1) - is * (is - 1) / 2 + it;
    observed[up ? up_index : down_index] += 1.0;
  }
  // Expected: N ∫ pdf over each sub-triangle, pdf = 1/area, sub-triangle area
  // area/m² (centroid rule, exact for a constant); the rest (outside) 0.
  for (int k = 0; k < m * m; ++k) expected[k] = double(kSamples) * (1.0 / area) * (area / (m * m));
  chi2::Result r = chi2::chi2_test(observed, expected);
  EXPECT_EQ(outside, 0u);
  EXPECT_TRUE(r.passes(kThreshold)) << r.summary();
}

// Domain and pdf sanity over a grid of inputs (including the corners 0 and
// 1-ε): disk points in the disk, directions of unit length in their domain.
TEST(Warp, OutputsStayInTheirDomains) {
  const float us[] = {0.f, 1e-7f, 0.25f, 0.5f, 0.75f, 1.f - 1e-7f, kOneMinusEpsilon};
  for (float a : us)
    for (float b : us) {
      Vec2 u{a, b};
      Vec2 d = square_to_uniform_disk(u);
      EXPECT_LE(d.x * d.x + d.y * d.y, 1.f + 1e-6f);
      Vec3 h = square_to_cosine_hemisphere(u);
      EXPECT_NEAR(length(h), 1.f, 1e-6f);
      EXPECT_GE(h.z, 0.f);
      Vec3 s = square_to_uniform_sphere(u);
      EXPECT_NEAR(length(s), 1.f, 1e-6f);
      for (float omc : {2.f, 1.f, 1e-3f, 1e-9f}) {
        Vec3 c = square_to_uniform_cone(u, omc);
        EXPECT_NEAR(length(c), 1.f, 1e-6f);
        EXPECT_GE(c.z, 1.f - omc - 1e-6f);
      }
      for (float n : kPowerExponents) {
        Vec3 c = square_to_cosine_power(u, n);
        EXPECT_NEAR(length(c), 1.f, 1e-6f);
        EXPECT_GE(c.z, 0.f);
      }
      Vec2 t = square_to_triangle_barycentrics(u);
      EXPECT_GE(t.x, 0.f);
      EXPECT_GE(t.y, 0.f);
      EXPECT_LE(t.x + t.y, 1.f + 1e-6f);
    }
}
