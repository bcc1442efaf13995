// Host-side tables of the rough plastic model (roughplastic.h): the rough
// coat's single-scattering transmittance T(μ) from outside and its
// hemispherical internal reflectance R_int, by Gauss-Legendre quadrature over
// the visible-normal sample square, as Mitsuba 3 does (eval_transmittance /
// eval_reflectance in include/mitsuba/render/microfacet.h: 32² nodes where
// the Fresnel term is smooth over the facets, 48² where total internal
// reflection makes it jump; Mitsuba uses 128², which changes R_int by < 1e-4).
#include "luz/bsdf/roughplastic.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "luz/math/quadrature.h"

namespace luz {

namespace {

// Single-scattering albedos of a rough dielectric interface seen from w
// (w.z > 0, the near side), relative IOR eta = η_far / η_near: the expected
// weights of a visible-normal sample, R for reflection (F G2/G1) and T for
// refraction ((1 - F) G2/G1, radiant power, no η² factor).
void interface_albedo(const MicrofacetDistribution& d, float eta, Vec3 w, const std::vector<double>& x,
                      const std::vector<double>& wx, double& R, double& T) {
  R = T = 0.0;
  double lw = d.lambda(w);
  for (size_t i = 0; i < x.size(); ++i)
    for (size_t j = 0; j < x.size(); ++j) {
      Vec3 m = d.sample_visible(w, {float(x[i]), float(x[j])});
      float wm = dot(w, m);
      if (!(wm > 0.f)) continue;
      double q = wx[i] * wx[j];
      FresnelDielectric fr = fresnel_dielectric(wm, eta);
      Vec3 wr = reflect(w, m);
      if (wr.z > 0.f) R += q * fr.F * (1.0 + lw) / (1.0 + lw + d.lambda(wr));
      if (fr.F < 1.f) {
        Vec3 wt = normalize(refract(w, m, fr.cos_t, fr.eta_ti));
        if (wt.z < 0.f) T += q * (1.0 - fr.F) * (1.0 + lw) / (1.0 + lw + d.lambda(wt));
      }
    }
}

Vec3 direction_at(double mu) {
  mu = std::max(mu, 1e-6);
  return {float(std::sqrt(std::max(0.0, 1.0 - mu * mu))), 0.f, float(mu)};
}

}  // namespace

double rough_coat_internal_reflectance(MicrofacetType t, float alpha, float eta) {
  MicrofacetDistribution d = MicrofacetDistribution::make(t, alpha, alpha);
  std::vector<double> x, wx, mu, wmu;
  gauss_legendre_01(eta > 1.f ? 48 : 32, x, wx);  // from inside: total internal reflection when η > 1
  gauss_legendre_01(16, mu, wmu);
  // R(μ) turns steeply to 1 at the critical cosine sqrt(1 - 1/η²) (a jump
  // for a smooth coat): the μ integral is split there (unsplit, 32 nodes
  // were off by 0.008 at α = 0.01; split, 16 + 16 agree with 64 + 64 to 1e-4).
  double split = eta > 1.f ? std::sqrt(1.0 - 1.0 / (double(eta) * eta)) : 0.5;
  double r_int = 0.0, R, T;
  for (int piece = 0; piece < 2; ++piece) {
    double lo = piece ? split : 0.0, hi = piece ? 1.0 : split;
    for (size_t k = 0; k < mu.size(); ++k) {
      double m = lo + (hi - lo) * mu[k];
      interface_albedo(d, 1.f / eta, direction_at(m), x, wx, R, T);
      r_int += 2.0 * wmu[k] * (hi - lo) * m * R;
    }
  }
  return r_int;
}

RoughPlasticBsdf RoughPlasticBsdf::make(MicrofacetType t, float alpha, Color diffuse, Color specular, float int_ior,
                                        float ext_ior, bool nonlinear) {
  RoughPlasticBsdf p;
  p.distribution = t;
  p.alpha = alpha;
  p.eta = int_ior / ext_ior;
  p.diffuse_reflectance = diffuse;
  p.specular_reflectance = specular;
  p.nonlinear = nonlinear;
  float dm = average(diffuse), sm = average(specular);
  p.specular_sampling_weight = dm + sm > 0.f ? sm / (dm + sm) : 0.5f;

  MicrofacetDistribution d = p.dist();
  std::vector<double> x_out, w_out;
  gauss_legendre_01(p.eta > 1.f ? 32 : 48, x_out, w_out);  // from outside: total reflection when η < 1

  // T(μ) at μ = i/63 (μ = 0 replaced by 1e-6, as Mitsuba), rounded down.
  double R, T;
  for (int i = 0; i < kTableSize; ++i) {
    interface_albedo(d, p.eta, direction_at(double(i) / (kTableSize - 1)), x_out, w_out, R, T);
    p.transmittance[i] = uint16_t(std::floor(std::clamp(T, 0.0, 1.0) * 65535.0));
  }
  double r_int = rough_coat_internal_reflectance(t, alpha, p.eta);
  // T̄ = 2 ∫ T(μ) μ dμ of the interpolated table (quadratic per interval:
  // Simpson's rule is exact there), and the cap R_int ≤ 1 - T̄/η².
  double t_bar = 0.0, h = 1.0 / (kTableSize - 1);
  for (int i = 0; i + 1 < kTableSize; ++i) {
    double a = i * h, b = a + h, m = 0.5 * (a + b);
    auto g = [&](double u) { return 2.0 * u * double(p.external_transmittance(float(u))); };
    t_bar += h / 6.0 * (g(a) + 4.0 * g(m) + g(b));
  }
  p.internal_reflectance = float(std::clamp(std::min(r_int, 1.0 - t_bar / (double(p.eta) * p.eta)), 0.0, 1.0));
  return p;
}

}  // namespace luz
