// White furnace tests (DESIGN.md, validation layer 3).
//
// A unit sphere inside a constant environment of radiance 1, seen by a pinhole
// camera so that some pixels see the sphere, some the background and some
// both. The sphere is convex, so every path from the camera has at most one
// bounce before it escapes to the environment:
//
//   * Lambertian sphere of albedo 1: every pixel equals 1 exactly (in
//     expectation) for each of the path, bsdf and light estimators.
//   * Phong sphere with k_d + k_s = 1: a pixel on the sphere equals the
//     directional albedo  a(wo) = ∫ f(wo,wi) cosθi dωi  at its view angle,
//     averaged over the pixel's footprint. a(wo) is computed here by numerical
//     quadrature of the Phong formula  f = k_d/π + k_s (n+2)/(2π) cos^n α,
//     written out below, independent of luz's BSDF code.
//
// The check: for every pixel and channel,  |mean - expected| ≤ z·σ + bias,
// with σ² the pixel's variance of the mean (from its own samples, floored by
// float rounding where every sample is identical), z the Šidák-corrected
// two-sided normal threshold for all tests in the image at family level
// 1e-3, and bias a bound on the quadrature error of `expected` (0 for the
// Lambertian case). An image-wide mean test is done as well. Negative
// controls show the same checks reject an albedo off by 1% and a Phong
// expectation that ignores the view angle.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "luz/device/cpu/render.h"
#include "luz/scene/scene.h"
#include "furnace.h"
#include "stat_helpers.h"
#include "sanitizer.h"

using namespace luz;
using luz_test::sidak_z;
using namespace luz_test;

namespace {

constexpr double kFamilyAlpha = 1e-3;

// ---- Independent geometry: the pinhole mapping and the ray/unit-sphere hit, in double.

// ---- Independent Phong albedo by quadrature.
//
// a(μo) = k_d + k_s S(μo),  S(μo) = (n+2)/(2π) ∫_{H+} cos^n α cosθi dωi.
// Around the mirror direction r (r.z = μo): wi = u r + √(1-u²)(cosφ t + sinφ b),
// u = cos α, dω = du dφ, cosθi = u μo + √(1-u²) sinθo cosφ =: A + B cosφ.
// The φ integral of max(0, A + B cosφ) is closed-form; the u integral is a
// midpoint rule.
double phong_specular_albedo(double mu_o, double n, int steps = 8192) {
  double sin_o = std::sqrt(std::max(0.0, 1.0 - mu_o * mu_o));
  double acc = 0;
  for (int i = 0; i < steps; ++i) {
    double u = (i + 0.5) / steps;
    double A = u * mu_o, B = std::sqrt(1.0 - u * u) * sin_o;
    double g;
    if (B <= A)
      g = 2.0 * M_PI * A;
    else {
      double phi0 = std::acos(-A / B);
      g = 2.0 * (A * phi0 + B * std::sin(phi0));
    }
    acc += std::pow(u, n) * g;
  }
  return (n + 2.0) / (2.0 * M_PI) * acc / steps;
}

// S tabulated on μ ∈ [0,1], linearly interpolated.
struct AlbedoTable {
  static constexpr int kN = 1024;
  static constexpr double kMaxError = 1e-4;  // checked in PhongQuadratureSanity; added to the bias
  std::vector<double> s;
  explicit AlbedoTable(double n) : s(kN + 1) {
    for (int i = 0; i <= kN; ++i) s[i] = phong_specular_albedo(double(i) / kN, n);
  }
  double operator()(double mu) const {
    double x = std::clamp(mu, 0.0, 1.0) * kN;
    int i = std::min(int(x), kN - 1);
    double f = x - i;
    return s[i] * (1 - f) + s[i + 1] * f;
  }
};

// Expected value per pixel (RGB-independent here: grey k_d, k_s), and a bound
// on its quadrature error; valid = false for pixels that straddle the
// silhouette (those are not checked against the Phong albedo).
struct Expectation {
  std::vector<double> value, bias;
  std::vector<bool> valid, on_sphere;
};

Expectation phong_expectation(double kd, double ks, double n) {
  AlbedoTable S(n);
  Expectation e;
  e.value.assign(kRes * kRes, 0);
  e.bias.assign(kRes * kRes, 0);
  e.valid.assign(kRes * kRes, false);
  e.on_sphere.assign(kRes * kRes, false);
  auto footprint = [&](int x, int y, int k, bool& all_hit, bool& none_hit) {
    double acc = 0;
    all_hit = true;
    none_hit = true;
    for (int j = 0; j < k; ++j)
      for (int i = 0; i < k; ++i) {
        double mu = view_cosine(x + (i + 0.5) / k, y + (j + 0.5) / k);
        if (mu < 0) {
          all_hit = false;
          acc += 1.0;  // the environment
        } else {
          none_hit = false;
          acc += kd + ks * S(mu);
        }
      }
    return acc / (k * k);
  };
  for (int y = 0; y < kRes; ++y)
    for (int x = 0; x < kRes; ++x) {
      // A pixel is on the sphere if its four corners are (the silhouette is convex).
      bool inside = view_cosine(x, y) > 0 && view_cosine(x + 1, y) > 0 && view_cosine(x, y + 1) > 0 &&
                    view_cosine(x + 1, y + 1) > 0;
      bool outside = view_cosine(x, y) < 0 && view_cosine(x + 1, y) < 0 && view_cosine(x, y + 1) < 0 &&
                     view_cosine(x + 1, y + 1) < 0;
      // Outside pixels could still clip the sphere between corners near its
      // top/bottom/left/right extremes; the sub-pixel sampling below tells.
      bool a16, n16, a8, n8;
      double v16 = footprint(x, y, 16, a16, n16), v8 = footprint(x, y, 8, a8, n8);
      size_t i = size_t(y) * kRes + x;
      if (inside) {
        e.value[i] = v16;
        // Midpoint rule over the pixel: the 16×16 error is about a third of the
        // 8×8-to-16×16 change; the whole change is a safe bound.
        e.bias[i] = std::fabs(v16 - v8) + ks * AlbedoTable::kMaxError;
        e.valid[i] = true;
        e.on_sphere[i] = true;
      } else if (outside && n16) {
        e.value[i] = 1.0;
        e.valid[i] = true;
      }
    }
  return e;
}

const char* name(IntegratorType t) {
  switch (t) {
    case IntegratorType::Bsdf: return "bsdf";
    case IntegratorType::Light: return "light";
    default: return "path";
  }
}

const IntegratorType kAll[] = {IntegratorType::Path, IntegratorType::Bsdf, IntegratorType::Light};

}  // namespace

// The quadrature itself: at normal incidence the lobe integrates to exactly 1
// ((n+2)/(2π)·2π∫u^{n+1}du); it never exceeds 1; and it falls off at grazing
// angles, where part of the lobe lies below the horizon.
TEST(Furnace, PhongQuadratureSanity) {
  for (double n : {1.0, 10.0, 40.0}) {
    EXPECT_NEAR(phong_specular_albedo(1.0, n), 1.0, 1e-5) << "n=" << n;
    for (double mu : {0.05, 0.2, 0.5, 0.8}) EXPECT_LE(phong_specular_albedo(mu, n), 1.0 + 1e-9);
    EXPECT_LT(phong_specular_albedo(0.05, n), 0.8);
    // The table (midpoint rule, linear interpolation) against a 4× finer
    // direct quadrature: within the error it declares, far below the noise.
    AlbedoTable t(n);
    for (double mu = 0.0004; mu < 1; mu += 0.0131)
      EXPECT_NEAR(t(mu), phong_specular_albedo(mu, n, 32768), AlbedoTable::kMaxError) << "n=" << n << " mu=" << mu;
  }
}

TEST(Furnace, LambertAlbedoOneIsOneEverywhere) {
  std::vector<double> one(kRes * kRes, 1.0), zero(kRes * kRes, 0.0);
  std::vector<bool> all(kRes * kRes, true);
  for (IntegratorType t : kAll) {
    Scene s = furnace_scene(Bsdf::make_diffuse({1.f, 1.f, 1.f}), t, 1024, 7);
    Film f = render(s);
    CheckResult r = check(f, one, zero, all, kFamilyAlpha);
    std::printf("[furnace lambert %-5s] worst pixel z %.2f (threshold %.2f), image-mean z %.2f, max |mean-1| %.2e\n",
                name(t), r.worst_z, r.threshold, r.image_z, r.max_abs_diff);
    EXPECT_LE(r.worst_z, r.threshold) << name(t);
    EXPECT_LE(r.image_z, r.threshold) << name(t);
  }
}

// Negative control: an albedo of 0.99 must be told apart from 1 by the same
// check (path integrator, the noisiest of the sphere-lit estimators after light).
TEST(Furnace, LambertCheckRejectsAlbedo099) {
  std::vector<double> one(kRes * kRes, 1.0), zero(kRes * kRes, 0.0);
  std::vector<bool> all(kRes * kRes, true);
  for (IntegratorType t : kAll) {
    Scene s = furnace_scene(Bsdf::make_diffuse({0.99f, 0.99f, 0.99f}), t, 1024, 7);
    CheckResult r = check(render(s), one, zero, all, kFamilyAlpha);
    std::printf("[furnace lambert 0.99 %-5s] image-mean z %.1f, worst pixel z %.1f\n", name(t), r.image_z, r.worst_z);
    EXPECT_GT(r.image_z, r.threshold) << name(t);
  }
}

TEST(Furnace, PhongSphereMatchesDirectionalAlbedo) {
  struct Combo {
    double kd, ks, n;
  };
  for (Combo c : {Combo{0.3, 0.7, 10.0}, Combo{0.6, 0.4, 40.0}}) {
    Expectation e = phong_expectation(c.kd, c.ks, c.n);
    int on_sphere = 0;
    double lo = 1, hi = 0;
    for (int i = 0; i < kRes * kRes; ++i)
      if (e.on_sphere[i]) {
        ++on_sphere;
        lo = std::min(lo, e.value[i]);
        hi = std::max(hi, e.value[i]);
      }
    ASSERT_GT(on_sphere, 200);
    ASSERT_LT(lo, 0.9);  // the view-angle dependence is visible in the image
    for (IntegratorType t : kAll) {
      Bsdf b = Bsdf::make_phong({float(c.kd), float(c.kd), float(c.kd)}, {float(c.ks), float(c.ks), float(c.ks)},
                                float(c.n));
      Scene s = furnace_scene(b, t, luz_test::sanitized_count<uint32_t>(4096), 11);
      Film f = render(s);
      CheckResult r = check(f, e.value, e.bias, e.valid, kFamilyAlpha);
      std::printf(
          "[furnace phong kd=%.1f ks=%.1f n=%g %-5s] %d sphere px (albedo %.3f..%.3f), worst pixel z %.2f "
          "(threshold %.2f), image-mean z %.2f\n",
          c.kd, c.ks, c.n, name(t), on_sphere, lo, hi, r.worst_z, r.threshold, r.image_z);
      EXPECT_LE(r.worst_z, r.threshold) << name(t);
      EXPECT_LE(r.image_z, r.threshold) << name(t);
      if (t == IntegratorType::Path) {
        // Negative control: ignoring the view angle (expecting k_d + k_s = 1 on
        // the whole sphere) must be rejected.
        std::vector<double> flat(e.valid.size(), 1.0), nobias(e.valid.size(), 0.0);
        CheckResult bad = check(f, flat, nobias, e.valid, kFamilyAlpha);
        EXPECT_GT(bad.worst_z, bad.threshold);
      }
    }
  }
}
