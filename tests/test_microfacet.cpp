// Microfacet distributions (luz/bsdf/microfacet.h): normalisation of D, Smith
// G1 against the projected-area identity, and chi-square of the visible-normal
// sampling against its density, for Beckmann and GGX, isotropic (α from 0.01
// to 1) and anisotropic.
//
// Quadratures run in the stretched slope plane, (x, y) = (αu tan β cos ψ,
// αv tan β sin ψ), β ∈ [0, π/2), ψ ∈ [0, 2π): with dω = cos³θm d²slope and
// d²slope = αu αv tan β sec²β dβ dψ, the integrand is smooth (the GGX tail
// too) and the lobe's width is the same for every α.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "chi2.h"
#include "luz/bsdf/microfacet.h"
#include "sanitizer.h"

using namespace luz;

namespace {

struct Alphas {
  float u, v;
};
const Alphas kAlphas[] = {{0.01f, 0.01f}, {0.05f, 0.05f}, {0.3f, 0.3f}, {1.f, 1.f}, {0.05f, 0.4f}, {0.6f, 0.15f}};
const MicrofacetType kTypes[] = {MicrofacetType::Beckmann, MicrofacetType::GGX};
const float kIncidenceDeg[] = {0.f, 45.f, 80.f, 89.f};
constexpr float kAzimuth = 0.7f;
constexpr uint64_t kSamples = 200000;
constexpr int kChi2Tests = int(std::size(kTypes) * std::size(kAlphas) * std::size(kIncidenceDeg)) + 1;
const double kThreshold = chi2::sidak(chi2::kAlpha, kChi2Tests);

const char* name(MicrofacetType t) { return t == MicrofacetType::GGX ? "GGX" : "Beckmann"; }

Vec3 direction(float theta_deg, float phi) {
  float t = theta_deg * kPi / 180.f;
  return {sinf(t) * cosf(phi), sinf(t) * sinf(phi), cosf(t)};
}

// ∫ g(m) dωm over the upper hemisphere, in stretched slope coordinates.
template <class G>
double slope_integral(const MicrofacetDistribution& d, G&& g, double rel_tol) {
  auto integrand = [&](double beta, double psi) {
    double t = std::tan(beta), x = d.alpha_u * t * std::cos(psi), y = d.alpha_v * t * std::sin(psi);
    double len = std::sqrt(1.0 + x * x + y * y), cos_t = 1.0 / len;
    Vec3 m = {float(-x / len), float(-y / len), float(cos_t)};
    double c = std::cos(beta);
    return g(m) * cos_t * cos_t * cos_t * double(d.alpha_u) * d.alpha_v * t / (c * c);
  };
  return chi2::integrate_2d(integrand, 0.0, chi2::kPi / 2, 0.0, 2 * chi2::kPi, rel_tol, 1e-14, 4, 10);
}

// ∫ max(0, w·m) g(m) dωm: the visible side of the slope plane is the half
// plane p < p0, p the stretched slope along c = (αu wx, αv wy), p0 = wz/|c|;
// integrated over it in (p, q) = (p0 - tan u, tan v), so the kink of max(0, ·)
// lies on the domain's edge, not inside a cell.
template <class G>
double visible_integral(const MicrofacetDistribution& d, Vec3 w, G&& g, double rel_tol, int depth) {
  double cx = double(d.alpha_u) * w.x, cy = double(d.alpha_v) * w.y, cl = std::hypot(cx, cy);
  if (cl < 1e-12) return slope_integral(d, [&](Vec3 m) { return std::max(0.0, double(dot(w, m))) * g(m); }, rel_tol);
  double ux = cx / cl, uy = cy / cl, p0 = double(w.z) / cl;
  // piece 0: p = p0' - tan u (p0' = min(p0, 0)); piece 1 (p0 > 0): p = tan u,
  // u < atan p0. Both keep the lobe (around p = 0) at the scale of u.
  auto piece = [&](int k) {
    auto integrand = [&](double u, double v) {
      double p = k == 0 ? std::min(p0, 0.0) - std::tan(u) : std::tan(u), q = std::tan(v);
      double sx = p * ux - q * uy, sy = p * uy + q * ux;  // stretched slope
      double x = d.alpha_u * sx, y = d.alpha_v * sy;
      double len = std::sqrt(1.0 + x * x + y * y), cos_t = 1.0 / len;
      Vec3 m = {float(-x / len), float(-y / len), float(cos_t)};
      double wm = (-x * w.x - y * w.y + double(w.z)) / len;  // exact w·m, ≥ 0 here
      double cu = std::cos(u), cv = std::cos(v);
      return std::max(0.0, wm) * g(m) * cos_t * cos_t * cos_t * double(d.alpha_u) * d.alpha_v / (cu * cu * cv * cv);
    };
    double u1 = k == 0 ? chi2::kPi / 2 : std::atan(p0);
    return chi2::integrate_2d(integrand, 0.0, u1, -chi2::kPi / 2, chi2::kPi / 2, rel_tol, 1e-14, 4, depth);
  };
  return piece(0) + (p0 > 0.0 ? piece(1) : 0.0);
}

}  // namespace

// ∫ D(m) cos θm dωm = 1. Tolerance: the quadrature's own error (two
// tolerances compared) plus the float rounding of D (a few ulp, < 1e-5).
TEST(Microfacet, DistributionIsNormalised) {
  for (MicrofacetType t : kTypes)
    for (const Alphas& a : kAlphas) {
      MicrofacetDistribution d = MicrofacetDistribution::make(t, a.u, a.v);
      auto g = [&](Vec3 m) { return double(d.D(m)) * m.z; };
      double coarse = slope_integral(d, g, 1e-5), fine = slope_integral(d, g, 1e-7);
      EXPECT_NEAR(fine, 1.0, std::fabs(fine - coarse) + 1e-5) << name(t) << " α = (" << a.u << ", " << a.v << ")";
    }
}

// Tolerance: coarse (1e-5, depth 6) against fine (1e-7, depth 9) cubature,
// plus float rounding of D.
// Smith: G1(ω) = cos θ / ∫ max(0, ω·m) D(m) dωm (the projected area of the
// visible microsurface equals that of the macrosurface; Heitz 2014, eq. 17),
// i.e. 1 + Λ(ω) = ∫ max(0, ω·m) D(m) dωm / cos θ.
TEST(Microfacet, SmithG1MatchesProjectedArea) {
  double worst = 0.0;
  for (MicrofacetType t : kTypes)
    for (const Alphas& a : kAlphas) {
      MicrofacetDistribution d = MicrofacetDistribution::make(t, a.u, a.v);
      for (float deg : {0.f, 30.f, 60.f, 80.f, 89.f})
        for (float phi : {0.f, 0.7f, 2.f}) {
          Vec3 w = direction(deg, phi);
          auto g = [&](Vec3 m) { return double(d.D(m)); };
          double coarse = visible_integral(d, w, g, 1e-5, 6) / w.z, fine = visible_integral(d, w, g, 1e-7, 9) / w.z;
          double expect = 1.0 + d.lambda(w);
          double g1 = d.G1(w, Vec3{0.f, 0.f, 1.f});
          EXPECT_NEAR(g1 * fine, 1.0, std::fabs(fine - coarse) / fine + 1e-5)
              << name(t) << " α = (" << a.u << ", " << a.v << "), θ = " << deg << "°, φ = " << phi;
          worst = std::max(worst, std::fabs(fine / expect - 1.0));
        }
    }
  std::printf("Smith G1 vs projected area: largest relative difference %.3g\n", worst);
}

// Chi-square of sample_visible(ω, ·) against pdf_visible(ω, ·); ∫pdf = 1.
TEST(Microfacet, VisibleNormalSamplingChi2) {
  uint64_t seed = 1000;
  double min_p = 1.0, worst_mass = 0.0;
  for (MicrofacetType t : kTypes)
    for (const Alphas& a : kAlphas)
      for (float deg : kIncidenceDeg) {
        MicrofacetDistribution d = MicrofacetDistribution::make(t, a.u, a.v);
        Vec3 w = direction(deg, kAzimuth);
        chi2::SphereGrid g;
        g.n_theta = 20;
        g.n_phi = 40;
        // The grid covers the normals up to a slope of 5 α (the rest is the
        // overflow bin); beyond π/2 nothing may land.
        g.theta_max = std::min(chi2::kPi / 2, std::atan(5.0 * std::max(a.u, a.v)));
        g.total_mass = 1.0;
        ++seed;
        auto sample = [&](uint64_t i, Vec3& m) {
          m = d.sample_visible(w, chi2::rand2(seed, i, 0));
          return true;
        };
        auto pdf = [&](chi2::D3 m) { return double(d.pdf_visible(w, chi2::to_vec3(m))); };
        chi2::Outcome o = chi2::run_sphere(g, luz_test::sanitized_count(kSamples), sample, pdf);
        // (∫pdf = 1 is SmithG1MatchesProjectedArea's business: the bins'
        // cubature is cut by the visibility kink and is good to ~1e-4 only.)
        worst_mass = std::max(worst_mass, std::fabs(o.mass - 1.0));
        EXPECT_TRUE(o.result.passes(kThreshold))
            << name(t) << " α = (" << a.u << ", " << a.v << "), θ = " << deg << "°: " << o.describe(kThreshold);
        min_p = std::min(min_p, o.result.p_value);
      }
  std::printf("visible normals: smallest p-value over %d cases %.3g (reject below %.3g); |sum of bins - 1| <= %.2g\n",
              kChi2Tests - 1, min_p, kThreshold, worst_mass);
}

// The test has power: Beckmann samples checked against the GGX density of the
// same α must be rejected.
TEST(Microfacet, Chi2RejectsTheWrongDistribution) {
  MicrofacetDistribution b = MicrofacetDistribution::make(MicrofacetType::Beckmann, 0.3f, 0.3f);
  MicrofacetDistribution g = MicrofacetDistribution::make(MicrofacetType::GGX, 0.3f, 0.3f);
  Vec3 w = direction(45.f, kAzimuth);
  chi2::SphereGrid sg;
  sg.theta_max = chi2::kPi / 2;
  sg.total_mass = 1.0;
  auto sample = [&](uint64_t i, Vec3& m) {
    m = b.sample_visible(w, chi2::rand2(77, i, 0));
    return true;
  };
  auto pdf = [&](chi2::D3 m) { return double(g.pdf_visible(w, chi2::to_vec3(m))); };
  chi2::Outcome o = chi2::run_sphere(sg, kSamples, sample, pdf);
  EXPECT_LT(o.result.p_value, kThreshold);
}

// Sampling all normals (D cos θ, used by Ward): chi-square too.
TEST(Microfacet, AllNormalSamplingMatchesDCos) {
  for (MicrofacetType t : kTypes) {
    MicrofacetDistribution d = MicrofacetDistribution::make(t, 0.2f, 0.5f);
    chi2::SphereGrid sg;
    sg.theta_max = chi2::kPi / 2;
    sg.total_mass = 1.0;
    auto sample = [&](uint64_t i, Vec3& m) {
      m = d.sample_all(chi2::rand2(78, i, 0));
      return true;
    };
    auto pdf = [&](chi2::D3 m) {
      Vec3 v = chi2::to_vec3(m);
      return double(d.D(v)) * std::max(0.0, m.z);
    };
    chi2::Outcome o = chi2::run_sphere(sg, kSamples, sample, pdf);
    EXPECT_TRUE(o.result.passes(chi2::sidak(chi2::kAlpha, 2))) << name(t) << ": " << o.describe(kThreshold);
  }
}
