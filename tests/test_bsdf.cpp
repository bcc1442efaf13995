// BSDF tests (luz/bsdf/bsdf.h): chi-square of sample() against pdf() (the pdf
// is a sub-probability density: failed samples are a bin of their own),
// reciprocity, energy conservation by numerical quadrature (with the loss of
// the horizon-clipped Phong lobe measured), ∫pdf against the observed success
// rate, sample weights against f·cos/pdf, and the two-sided / one-sided rules.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "chi2.h"
#include "luz/bsdf/bsdf.h"

using namespace luz;

namespace {

struct PhongCase {
  const char* name;
  Color kd, ks;
  float n;
};
const PhongCase kPhongCases[] = {
    {"kd=.5 ks=.5 n=1", {.5f, .5f, .5f}, {.5f, .5f, .5f}, 1.f},
    {"kd=.2 ks=.8 n=20", {.2f, .2f, .2f}, {.8f, .8f, .8f}, 20.f},
    {"kd=0 ks=1 n=200", {0.f, 0.f, 0.f}, {1.f, 1.f, 1.f}, 200.f},
    {"kd=.7 ks=.1 n=5", {.7f, .7f, .7f}, {.1f, .1f, .1f}, 5.f},
    {"rgb kd=(.6,.3,.1) ks=(.2,.4,.3) n=10", {.6f, .3f, .1f}, {.2f, .4f, .3f}, 10.f},
    // max(kd) + max(ks) > 1: the lobe probabilities are scaled down.
    {"rgb kd=(.8,.1,.1) ks=(.1,.1,.5) n=50", {.8f, .1f, .1f}, {.1f, .1f, .5f}, 50.f},
};
constexpr float kIncidenceDeg[] = {0.f, 30.f, 60.f, 85.f};
constexpr float kBackIncidenceDeg[] = {30.f, 85.f};
constexpr float kAzimuth = 0.7f;

constexpr int kCasesPerBsdf = int(std::size(kIncidenceDeg) + std::size(kBackIncidenceDeg));
constexpr int kChi2Tests = (1 + int(std::size(kPhongCases))) * kCasesPerBsdf + 1 /* the mismatched lobe */;
const double kThreshold = chi2::sidak(chi2::kAlpha, kChi2Tests);

constexpr uint64_t kSamples = 200000;

// Relative error of a float cos^n α: cos α = dot(wi, r) carries a few 2^-24
// (r and wi are float unit vectors), and the power multiplies it by n.
double float_error(float n) { return 2.0 * double(n) * 0x1p-24; }

Vec3 direction(float theta_deg, float phi) {
  float t = theta_deg * kPi / 180.f;
  return {sinf(t) * cosf(phi), sinf(t) * sinf(phi), cosf(t)};
}
Vec3 mirror_z(Vec3 v) { return {v.x, v.y, -v.z}; }

// All BSDFs under test, one-sided or two-sided.
std::vector<std::pair<std::string, Bsdf>> all_bsdfs(bool two_sided) {
  std::vector<std::pair<std::string, Bsdf>> v;
  v.push_back({"diffuse .5", Bsdf::make_diffuse({.5f, .5f, .5f}, two_sided)});
  v.push_back({"diffuse rgb", Bsdf::make_diffuse({.9f, .4f, .1f}, two_sided)});
  for (const PhongCase& c : kPhongCases)
    v.push_back({std::string("phong ") + c.name, Bsdf::make_phong(c.kd, c.ks, c.n, two_sided)});
  return v;
}

// ∫ over the hemisphere on wo's side of g(wi) dωi, by Gauss-Legendre in
// spherical coordinates (α, φ) around the mirror direction r of wo: the Phong
// lobe depends on α only, so the α panels are graded to the lobe width
// 1/sqrt(n+1) and split where the lobe ends (α = π/2) and where the horizon
// starts and stops cutting the circle of constant α (α = π/2 ∓ θr); for each
// α the φ range above the horizon is computed exactly. Inside each piece the
// integrand is smooth. `order` = nodes per panel in α and per range in φ.
struct GaussLegendre {
  std::vector<double> x, w;
  explicit GaussLegendre(int n) : x(n), w(n) {
    for (int i = 0; i < n; ++i) {
      double z = std::cos(chi2::kPi * (i + 0.75) / (n + 0.5)), pp = 0.0;
      for (int it = 0; it < 100; ++it) {
        double p1 = 1.0, p2 = 0.0;
        for (int j = 1; j <= n; ++j) {
          double p3 = p2;
          p2 = p1;
          p1 = ((2.0 * j - 1.0) * z * p2 - (j - 1.0) * p3) / j;
        }
        pp = n * (z * p1 - p2) / (z * z - 1.0);
        double z1 = z;
        z = z1 - p1 / pp;
        if (std::fabs(z - z1) < 1e-15) break;
      }
      x[i] = z;
      w[i] = 2.0 / ((1.0 - z * z) * pp * pp);
    }
  }
};

template <class G>
double hemisphere_integral(Vec3 wo, float n, G&& g, int order) {
  GaussLegendre gl(order);
  double side = wo.z >= 0.f ? 1.0 : -1.0;
  chi2::D3 r = chi2::normalized({-double(wo.x), -double(wo.y), double(wo.z)});
  chi2::DFrame fr(r);
  // Height above the surface (on wo's side) of the direction (α, φ):
  // A + B cos(φ - φ0).
  double rz = side * r.z, sz = side * fr.s.z, tz = side * fr.t.z;
  double bz = std::hypot(sz, tz), phi0 = std::atan2(tz, sz);
  double theta_r = std::acos(std::clamp(rz, -1.0, 1.0));
  std::vector<double> breaks = {0.0, chi2::kPi / 2, chi2::kPi, chi2::kPi / 2 - theta_r, chi2::kPi / 2 + theta_r};
  double w = 1.0 / std::sqrt(double(n) + 1.0);
  for (double a = w / 16; a < chi2::kPi / 2; a *= 2.0) breaks.push_back(a);
  std::sort(breaks.begin(), breaks.end());
  double total = 0.0;
  for (size_t k = 0; k + 1 < breaks.size(); ++k) {
    double a0 = std::max(0.0, breaks[k]), a1 = std::min(chi2::kPi, breaks[k + 1]);
    if (!(a1 - a0 > 1e-12)) continue;
    double panel = 0.0;
    for (int i = 0; i < order; ++i) {
      double alpha = 0.5 * (a0 + a1) + 0.5 * (a1 - a0) * gl.x[i];
      double A = std::cos(alpha) * rz, B = std::sin(alpha) * bz;
      double p_lo, p_hi;
      if (A >= B) {
        p_lo = 0.0, p_hi = 2.0 * chi2::kPi;
      } else if (A <= -B) {
        continue;
      } else {
        double psi = std::acos(-A / B);
        p_lo = phi0 - psi, p_hi = phi0 + psi;
      }
      double ring = 0.0;
      for (int j = 0; j < order; ++j) {
        double phi = 0.5 * (p_lo + p_hi) + 0.5 * (p_hi - p_lo) * gl.x[j];
        chi2::D3 wi = fr.to_world(alpha, phi);
        ring += gl.w[j] * g(wi);
      }
      panel += gl.w[i] * std::sin(alpha) * ring * 0.5 * (p_hi - p_lo);
    }
    total += panel * 0.5 * (a1 - a0);
  }
  return total;
}

// Albedo ∫ f cos θi dωi (one channel), with an error estimate from doubling
// the quadrature order.
struct Quad {
  double value, error;
};
Quad albedo(const Bsdf& b, Vec3 wo, int channel) {
  auto g = [&](chi2::D3 wi) {
    Vec3 w = chi2::to_vec3(wi);
    return double(b.f(wo, w)[channel]) * std::fabs(wi.z);
  };
  float n = b.type == BsdfType::Phong ? b.phong.exponent : 0.f;
  double lo = hemisphere_integral(wo, n, g, 24), hi = hemisphere_integral(wo, n, g, 48);
  return {hi, std::fabs(hi - lo)};
}
Quad pdf_mass(const Bsdf& b, Vec3 wo) {
  auto g = [&](chi2::D3 wi) { return double(b.pdf(wo, chi2::to_vec3(wi))); };
  float n = b.type == BsdfType::Phong ? b.phong.exponent : 0.f;
  double lo = hemisphere_integral(wo, n, g, 24), hi = hemisphere_integral(wo, n, g, 48);
  return {hi, std::fabs(hi - lo)};
}

// Chi-square of bsdf.sample(wo, ·) against bsdf.pdf(wo, ·). Narrow lobes
// (n ≥ 100) are binned around the mirror direction, over the cap holding all
// but 1e-3 of the lobe; everything else around the normal, θ in [0, π] with
// the horizon on a bin boundary.
chi2::Outcome bsdf_chi2(const Bsdf& b, Vec3 wo, uint64_t seed) {
  chi2::SphereGrid g;
  // The failure bin expects N × (1 - ∫pdf), ∫pdf from the quadrature that
  // follows the lobe (pdf_mass), far more precise than the sum over bins.
  g.total_mass = pdf_mass(b, wo).value;
  float n = b.type == BsdfType::Phong ? b.phong.exponent : 0.f;
  if (n >= 100.f) {
    g.axis = {-wo.x, -wo.y, wo.z};
    g.theta_max = std::acos(std::pow(1e-3, 1.0 / (double(n) + 1.0)));
    g.n_theta = 10;
    g.n_phi = 20;
  } else {
    g.axis = {0.0, 0.0, 1.0};
    g.theta_max = chi2::kPi;
    g.n_theta = 20;
    g.n_phi = 40;
  }
  auto sample = [&](uint64_t i, Vec3& w) {
    BsdfSample s = b.sample(wo, chi2::rand01(seed, i, 0), chi2::rand2(seed, i, 1));
    w = s.wi;
    return s.valid;
  };
  auto pdf = [&](chi2::D3 w) { return double(b.pdf(wo, chi2::to_vec3(w))); };
  return chi2::run_sphere(g, kSamples, sample, pdf);
}

}  // namespace

// The quadrature itself: ∫cos = π, and ∫ (n+2)/2π cos^n α cos θ = 1 exactly at
// normal incidence, for the sharpest lobes too.
TEST(BsdfQuadrature, ExactOnKnownIntegrals) {
  for (float deg : {0.f, 45.f, 89.f}) {
    Vec3 wo = direction(deg, kAzimuth);
    double c = hemisphere_integral(
        wo, 1e4f, [](chi2::D3 w) { return std::fabs(w.z); }, 32);
    EXPECT_NEAR(c, chi2::kPi, 1e-7) << deg;  // α-panel ends: sqrt-type kinks where the horizon starts cutting
    double lobe = hemisphere_integral(
        wo, 1e4f,
        [&](chi2::D3 w) {
          double a = -wo.x * w.x - wo.y * w.y + wo.z * w.z;
          return a > 0 ? (1e4 + 1.0) / (2 * chi2::kPi) * std::pow(a, 1e4) : 0.0;
        },
        32);
    if (deg == 0.f) EXPECT_NEAR(lobe, 1.0, 1e-7);  // all of the lobe is above the horizon
    EXPECT_LE(lobe, 1.0 + 1e-7);
  }
}

TEST(Bsdf, DiffuseChi2) {
  int seed = 100;
  for (bool back : {false, true}) {
    Bsdf b = Bsdf::make_diffuse({.5f, .5f, .5f}, back);
    for (float deg : back ? std::vector<float>(std::begin(kBackIncidenceDeg), std::end(kBackIncidenceDeg))
                          : std::vector<float>(std::begin(kIncidenceDeg), std::end(kIncidenceDeg))) {
      Vec3 wo = direction(deg, kAzimuth);
      if (back) wo = mirror_z(wo);
      chi2::Outcome o = bsdf_chi2(b, wo, seed++);
      EXPECT_NEAR(o.mass, 1.0, 1e-6);
      EXPECT_TRUE(o.result.passes(kThreshold)) << (back ? "back " : "front ") << deg << "°: " << o.describe(kThreshold);
    }
  }
}

TEST(Bsdf, PhongChi2) {
  int seed = 200;
  double min_p = 1.0;
  for (const PhongCase& c : kPhongCases)
    for (bool back : {false, true}) {
      Bsdf b = Bsdf::make_phong(c.kd, c.ks, c.n, /*two_sided=*/back);
      for (float deg : back ? std::vector<float>(std::begin(kBackIncidenceDeg), std::end(kBackIncidenceDeg))
                            : std::vector<float>(std::begin(kIncidenceDeg), std::end(kIncidenceDeg))) {
        Vec3 wo = direction(deg, kAzimuth);
        if (back) wo = mirror_z(wo);
        chi2::Outcome o = bsdf_chi2(b, wo, seed++);
        // ∫pdf ≤ 1, to the cubature's tolerance (1e-8 a bin) and the float
        // evaluation of cos^n (see float_error()).
        EXPECT_LE(o.mass, 1.0 + 1e-5 + float_error(c.n)) << c.name << ", " << deg << "°";
        EXPECT_TRUE(o.result.passes(kThreshold))
            << c.name << (back ? ", back " : ", front ") << deg << "°: " << o.describe(kThreshold);
        min_p = std::min(min_p, o.result.p_value);
      }
    }
  std::printf("Phong chi2: smallest p-value over %d cases %.3g (reject below %.3g)\n",
              int(std::size(kPhongCases)) * kCasesPerBsdf, min_p, kThreshold);
}

// The check can fail: samples from a lobe of exponent 22 tested against the
// pdf of exponent 20 (otherwise equal) must be rejected.
TEST(Bsdf, Chi2RejectsAMismatchedLobe) {
  Bsdf sampled = Bsdf::make_phong({.2f, .2f, .2f}, {.8f, .8f, .8f}, 22.f);
  Bsdf claimed = Bsdf::make_phong({.2f, .2f, .2f}, {.8f, .8f, .8f}, 20.f);
  Vec3 wo = direction(30.f, kAzimuth);
  chi2::SphereGrid g;
  g.n_theta = 20;
  g.n_phi = 40;
  g.total_mass = 1.0;
  auto sample = [&](uint64_t i, Vec3& w) {
    BsdfSample s = sampled.sample(wo, chi2::rand01(300, i, 0), chi2::rand2(300, i, 1));
    w = s.wi;
    return s.valid;
  };
  auto pdf = [&](chi2::D3 w) { return double(claimed.pdf(wo, chi2::to_vec3(w))); };
  chi2::Outcome o = chi2::run_sphere(g, kSamples, sample, pdf);
  std::printf("exponent 22 sampled, 20 claimed: %s\n", o.result.summary().c_str());
  EXPECT_LT(o.result.p_value, kThreshold);
}

// f(wo, wi) = f(wi, wo) for random pairs over the whole sphere (both sides).
TEST(Bsdf, Reciprocity) {
  for (bool two_sided : {false, true})
    for (auto& [name, b] : all_bsdfs(two_sided)) {
      int nonzero = 0;
      for (uint64_t i = 0; i < 20000; ++i) {
        Vec3 a = square_to_uniform_sphere(chi2::rand2(7, i, 0)), c = square_to_uniform_sphere(chi2::rand2(7, i, 1));
        Color f1 = b.f(a, c), f2 = b.f(c, a);
        for (int k = 0; k < 3; ++k) ASSERT_NEAR(f1[k], f2[k], 1e-6f * std::fabs(f1[k])) << name << " pair " << i;
        nonzero += !is_black(f1);
      }
      EXPECT_GT(nonzero, 500) << name;  // the test saw the lobes, not only zeros
    }
}

// Energy: ∫ f cos θi dωi ≤ 1 for k_d + k_s = 1, by quadrature (not by the
// code's sampler), n from 1 to 10^4, incidences up to 89°. At normal incidence
// the modified Phong lobe is exactly normalized (albedo 1); away from it the
// lobe is clipped by the horizon and loses energy: measured and printed here.
TEST(Bsdf, EnergyConservation) {
  const float exponents[] = {1.f, 2.f, 5.f, 10.f, 20.f, 50.f, 100.f, 200.f, 500.f, 1e3f, 2e3f, 5e3f, 1e4f};
  const float incidences[] = {0.f, 15.f, 30.f, 45.f, 60.f, 75.f, 80.f, 85.f, 89.f};
  const float ks_values[] = {1.f, 0.5f, 0.f};
  std::printf("specular albedo (kd = 0, ks = 1) by incidence:\n   n   ");
  for (float deg : incidences) std::printf("%7.0f°", deg);
  std::printf("\n");
  double worst_excess = -1.0;
  for (float n : exponents) {
    std::printf("%6g ", n);
    for (float deg : incidences) {
      Vec3 wo = direction(deg, kAzimuth);
      for (float ks : ks_values) {
        Bsdf b = Bsdf::make_phong({1.f - ks, 1.f - ks, 1.f - ks}, {ks, ks, ks}, n);
        Quad a = albedo(b, wo, 0);
        // Float evaluation of cos^n α: cos α carries 2^-24 relative error, n
        // times that in the lobe; averaged over the nodes, well below it.
        double float_err = 1e-6 + float_error(n) * ks;
        double tol = a.error + float_err;
        EXPECT_LE(a.value, 1.0 + tol) << "n " << n << ", " << deg << "°, ks " << ks;
        worst_excess = std::max(worst_excess, a.value - 1.0);
        if (deg == 0.f) EXPECT_NEAR(a.value, 1.0, tol) << "n " << n << ", ks " << ks;
        if (ks == 0.f) EXPECT_NEAR(a.value, 1.0, tol) << "diffuse, " << deg << "°";
        if (ks == 1.f) std::printf(" %7.4f", a.value);
      }
    }
    std::printf("\n");
  }
  std::printf("largest albedo - 1 over all cases: %.3g\n", worst_excess);
  for (float n : {1.f, 10.f, 100.f}) {
    Bsdf b = Bsdf::make_phong({0.f, 0.f, 0.f}, {1.f, 1.f, 1.f}, n);
    Quad a = albedo(b, direction(85.f, kAzimuth), 0);
    std::printf("grazing loss at 85°, n = %g: albedo %.4f (loses %.1f%%)\n", n, a.value, 100.0 * (1.0 - a.value));
  }
  // RGB materials with k_d + k_s ≤ 1 per channel.
  for (const PhongCase& c : kPhongCases) {
    Bsdf b = Bsdf::make_phong(c.kd, c.ks, c.n);
    for (float deg : kIncidenceDeg)
      for (int ch = 0; ch < 3; ++ch) {
        Quad a = albedo(b, direction(deg, kAzimuth), ch);
        EXPECT_LE(a.value, c.kd[ch] + c.ks[ch] + a.error + 1e-6) << c.name << " " << deg << "° channel " << ch;
      }
  }
}

// ∫pdf over the hemisphere (quadrature) is the probability that sample()
// returns a direction; compared with the observed success rate by a binomial
// z-test (Šidák over all the cases).
TEST(Bsdf, PdfIntegratesToSuccessProbability) {
  auto bsdfs = all_bsdfs(false);
  const int tests = int(bsdfs.size() * std::size(kIncidenceDeg));
  const double level = chi2::sidak(chi2::kAlpha, tests);
  const uint64_t M = 200000;
  int seed = 500;
  for (auto& [name, b] : bsdfs)
    for (float deg : kIncidenceDeg) {
      Vec3 wo = direction(deg, kAzimuth);
      Quad mass = pdf_mass(b, wo);
      float n = b.type == BsdfType::Phong ? b.phong.exponent : 0.f;
      double p_err = mass.error + 1e-6 + float_error(n);
      EXPECT_LE(mass.value, 1.0 + p_err) << name;
      uint64_t ok = 0;
      for (uint64_t i = 0; i < M; ++i) {
        BsdfSample s = b.sample(wo, chi2::rand01(seed, i, 0), chi2::rand2(seed, i, 1));
        ok += s.valid;
      }
      ++seed;
      chi2::BinomialCheck bc = chi2::binomial_check(ok, M, mass.value, p_err, level);
      EXPECT_TRUE(bc.ok) << name << " at " << deg << "°: " << bc.message;
      if (deg == 85.f && b.type == BsdfType::Phong)
        std::printf("%-40s at 85°: ∫pdf = %.5f, success rate %.5f\n", name.c_str(), mass.value, double(ok) / M);
    }
}

// Wherever sample() returns a direction: its pdf is pdf(wo, wi) and its weight
// f(wo, wi)|cos θi| / pdf(wo, wi), to 1e-4 relative; both sides, both kinds.
TEST(Bsdf, SampleWeightMatchesEval) {
  for (bool two_sided : {false, true})
    for (auto& [name, b] : all_bsdfs(two_sided)) {
      int valid = 0;
      for (uint64_t i = 0; i < 20000; ++i) {
        Vec3 wo = square_to_uniform_sphere(chi2::rand2(9, i, 0));
        if (!two_sided && wo.z < 0.f) wo.z = -wo.z;
        BsdfSample s = b.sample(wo, chi2::rand01(9, i, 2), chi2::rand2(9, i, 3));
        if (!s.valid) continue;
        ++valid;
        float pdf = b.pdf(wo, s.wi);
        ASSERT_GT(pdf, 0.f) << name;
        ASSERT_NEAR(s.pdf, pdf, 1e-4f * pdf) << name;
        ASSERT_NEAR(length(s.wi), 1.f, 1e-5f) << name;
        ASSERT_GT(s.wi.z * wo.z, 0.f) << name << ": reflection stays on wo's side";
        Color expect = b.f(wo, s.wi) * (std::fabs(s.wi.z) / pdf);
        for (int k = 0; k < 3; ++k) {
          ASSERT_TRUE(std::isfinite(s.weight[k])) << name;
          ASSERT_NEAR(s.weight[k], expect[k], 1e-4f * std::fabs(expect[k]) + 1e-12f) << name << " channel " << k;
        }
      }
      EXPECT_GT(valid, 1000) << name;
    }
}

// Two-sided: seen from the back, everything is the z-mirror of the front.
TEST(Bsdf, TwoSidedBackMirrorsFront) {
  for (auto& [name, b] : all_bsdfs(true)) {
    for (uint64_t i = 0; i < 5000; ++i) {
      Vec3 wo = square_to_cosine_hemisphere(chi2::rand2(11, i, 0));
      if (!(wo.z > 0.f)) continue;
      Vec3 wi = square_to_uniform_sphere(chi2::rand2(11, i, 1));
      Color f1 = b.f(wo, wi), f2 = b.f(mirror_z(wo), mirror_z(wi));
      for (int k = 0; k < 3; ++k) ASSERT_FLOAT_EQ(f1[k], f2[k]) << name;
      ASSERT_FLOAT_EQ(b.pdf(wo, wi), b.pdf(mirror_z(wo), mirror_z(wi))) << name;
      float u1 = chi2::rand01(11, i, 4);
      Vec2 u2 = chi2::rand2(11, i, 3);
      BsdfSample s1 = b.sample(wo, u1, u2), s2 = b.sample(mirror_z(wo), u1, u2);
      ASSERT_EQ(s1.valid, s2.valid) << name;
      if (!s1.valid) continue;
      ASSERT_FLOAT_EQ(s1.wi.x, s2.wi.x);
      ASSERT_FLOAT_EQ(s1.wi.y, s2.wi.y);
      ASSERT_FLOAT_EQ(s1.wi.z, -s2.wi.z);
      ASSERT_FLOAT_EQ(s1.pdf, s2.pdf);
      for (int k = 0; k < 3; ++k) ASSERT_FLOAT_EQ(s1.weight[k], s2.weight[k]);
    }
  }
}

// One-sided: black, zero pdf and no samples from behind (and at exactly
// grazing wo); and no transmission from the front.
TEST(Bsdf, OneSidedIsBlackFromBehind) {
  for (auto& [name, b] : all_bsdfs(false)) {
    for (uint64_t i = 0; i < 5000; ++i) {
      Vec3 wo = square_to_uniform_sphere(chi2::rand2(13, i, 0));
      if (i % 100 == 0) wo = {wo.x, wo.y, 0.f};
      Vec3 wi = square_to_uniform_sphere(chi2::rand2(13, i, 1));
      if (wo.z > 0.f) {
        if (wi.z < 0.f) {
          ASSERT_TRUE(is_black(b.f(wo, wi))) << name;
          ASSERT_EQ(b.pdf(wo, wi), 0.f) << name;
        }
        continue;
      }
      ASSERT_TRUE(is_black(b.f(wo, wi))) << name;
      ASSERT_TRUE(is_black(b.f(wo, mirror_z(wi)))) << name;
      ASSERT_EQ(b.pdf(wo, wi), 0.f) << name;
      ASSERT_EQ(b.pdf(wo, mirror_z(wi)), 0.f) << name;
      BsdfSample s = b.sample(wo, chi2::rand01(13, i, 4), chi2::rand2(13, i, 3));
      ASSERT_FALSE(s.valid) << name;
    }
  }
}
