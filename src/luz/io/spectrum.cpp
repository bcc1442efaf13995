#include "luz/io/spectrum.h"

#include <cmath>
#include <stdexcept>
#include <vector>

namespace luz {

namespace {

// exp(-((λ - μ) / σ)² / 2) with σ = lo below μ and hi above.
double lobe(double lambda, double mu, double lo, double hi) {
  const double t = (lambda - mu) / (lambda < mu ? lo : hi);
  return std::exp(-0.5 * t * t);
}

struct Xyz {
  double x, y, z;
};

// CIE 1931 x̄, ȳ, z̄ at λ nm: Wyman, Sloan and Shirley's multi-lobe fit.
Xyz cmf(double l) {
  return {1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7) - 0.065 * lobe(l, 501.1, 20.4, 26.2),
          0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1),
          1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8)};
}

// XYZ over 360-830 nm in 1 nm steps of the spectrum s(λ), scaled to Y = 1;
// {0, 0, 0} when its Y is not positive and finite.
template <class S>
Vec3 xyz_luminance_one(const S& s) {
  double x = 0, y = 0, z = 0;
  for (int nm = 360; nm <= 830; ++nm) {
    const double v = s(double(nm));
    const Xyz c = cmf(nm);
    x += v * c.x, y += v * c.y, z += v * c.z;
  }
  if (!(y > 0.0) || !std::isfinite(x + y + z)) return {0.f, 0.f, 0.f};
  return {float(x / y), 1.f, float(z / y)};
}

// The inverse of sRGB's XYZ matrix (io/image.cpp's), D65 white.
Color xyz_to_srgb(Vec3 c) {
  return {3.240479f * c.x - 1.537150f * c.y - 0.498535f * c.z, -0.969256f * c.x + 1.875992f * c.y + 0.041556f * c.z,
          0.055648f * c.x - 0.204043f * c.y + 1.057311f * c.z};
}

}  // namespace

Vec3 blackbody_xyz(double kelvin) {
  if (!(kelvin > 0.0) || !std::isfinite(kelvin)) throw std::invalid_argument("a blackbody temperature must be positive");
  constexpr double c2 = 1.438776877e-2;  // second radiation constant h c / k_B, m K
  const Vec3 c = xyz_luminance_one([&](double l) {
    const double m = l * 1e-9;
    return 1.0 / (std::pow(m, 5) * std::expm1(c2 / (m * kelvin)));  // Planck, up to a constant
  });
  if (!(c.y > 0.f)) throw std::invalid_argument("the blackbody temperature is out of range (no finite visible light)");
  return c;
}

Color blackbody_rgb(double kelvin) { return xyz_to_srgb(blackbody_xyz(kelvin)); }

Vec3 sampled_spectrum_xyz(const std::vector<double>& pairs) {
  if (pairs.size() < 2 || pairs.size() % 2 != 0) throw std::invalid_argument("a spectrum needs (wavelength, value) pairs");
  for (size_t i = 0; i < pairs.size(); i += 2) {
    if (!std::isfinite(pairs[i]) || !(pairs[i + 1] >= 0.0) || !std::isfinite(pairs[i + 1]))
      throw std::invalid_argument("a spectrum's wavelengths and values must be finite, its values not negative");
    if (i > 0 && !(pairs[i] > pairs[i - 2])) throw std::invalid_argument("a spectrum's wavelengths must increase");
  }
  const size_t n = pairs.size() / 2;
  if (n == 1) throw std::invalid_argument("a spectrum of one (wavelength, value) pair is non-zero at one wavelength only");
  const Vec3 c = xyz_luminance_one([&](double l) {
    if (l < pairs[0] || l > pairs[2 * (n - 1)]) return 0.0;  // pbrt-v4's PiecewiseLinearSpectrum: 0 outside
    size_t k = 0;
    while (k + 2 < n && pairs[2 * (k + 1)] < l) ++k;
    const double l0 = pairs[2 * k], l1 = pairs[2 * k + 2], t = (l - l0) / (l1 - l0);
    return pairs[2 * k + 1] * (1 - t) + pairs[2 * k + 3] * t;
  });
  if (!(c.y > 0.f)) throw std::invalid_argument("the spectrum has no luminance (nothing between 360 and 830 nm)");
  return c;
}

Color sampled_spectrum_rgb(const std::vector<double>& pairs) { return xyz_to_srgb(sampled_spectrum_xyz(pairs)); }

}  // namespace luz
