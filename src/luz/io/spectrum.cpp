#include "luz/io/spectrum.h"

#include <cmath>
#include <stdexcept>

namespace luz {

namespace {

// exp(-((λ - μ) / σ)² / 2) with σ = lo below μ and hi above.
double lobe(double lambda, double mu, double lo, double hi) {
  const double t = (lambda - mu) / (lambda < mu ? lo : hi);
  return std::exp(-0.5 * t * t);
}

}  // namespace

Vec3 blackbody_xyz(double kelvin) {
  if (!(kelvin > 0.0) || !std::isfinite(kelvin)) throw std::invalid_argument("a blackbody temperature must be positive");
  constexpr double c2 = 1.438776877e-2;  // second radiation constant h c / k_B, m K
  double x = 0, y = 0, z = 0;
  for (int nm = 360; nm <= 830; ++nm) {
    const double l = nm, m = l * 1e-9;
    const double b = 1.0 / (std::pow(m, 5) * std::expm1(c2 / (m * kelvin)));  // Planck, up to a constant
    x += b * (1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7) - 0.065 * lobe(l, 501.1, 20.4, 26.2));
    y += b * (0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1));
    z += b * (1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8));
  }
  if (!(y > 0.0) || !std::isfinite(x + y + z)) throw std::invalid_argument("the blackbody temperature is out of range (no finite visible light)");
  return {float(x / y), 1.f, float(z / y)};
}

Color blackbody_rgb(double kelvin) {
  const Vec3 c = blackbody_xyz(kelvin);
  // The inverse of sRGB's XYZ matrix (io/image.cpp's), D65 white.
  return {3.240479f * c.x - 1.537150f * c.y - 0.498535f * c.z, -0.969256f * c.x + 1.875992f * c.y + 0.041556f * c.z,
          0.055648f * c.x - 0.204043f * c.y + 1.057311f * c.z};
}

}  // namespace luz
