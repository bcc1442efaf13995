// Spectra that scene files give and Luz, an RGB renderer, turns into linear
// sRGB colours when loading.
#pragma once

#include <vector>

#include "luz/math/vec.h"

namespace luz {

// CIE 1931 XYZ of a blackbody (Planck's law) at `kelvin`, scaled to Y = 1:
// the matching functions are Wyman, Sloan and Shirley's multi-lobe fit
// (JCGT 2013, within the tables' own uncertainty), summed over 360-830 nm
// in 1 nm steps. Throws std::invalid_argument unless kelvin is finite and
// positive.
Vec3 blackbody_xyz(double kelvin);

// That blackbody in linear sRGB (XYZ→sRGB, D65 white): luminance 1, as
// pbrt-v4's lights emit "blackbody L [T]" (each light's spectrum divided by
// its photometric integral, so it is as bright as "rgb L [1 1 1]"). Below
// about 1,900 K blue falls outside sRGB and comes out negative: the caller
// clamps.
Color blackbody_rgb(double kelvin);

// A piecewise-linear spectrum given as (λ nm, value) pairs, λ increasing,
// 0 outside them (pbrt-v4's PiecewiseLinearSpectrum), in CIE 1931 XYZ and
// in linear sRGB, scaled to luminance 1 as pbrt-v4's lights emit any
// spectrum but RGB. Throws std::invalid_argument for bad pairs, a lone
// pair (non-zero at one wavelength: pbrt-v4 warns and renders it black) or
// no luminance. Out-of-gamut
// spectra come out with negative sRGB components: the caller clamps.
Vec3 sampled_spectrum_xyz(const std::vector<double>& pairs);
Color sampled_spectrum_rgb(const std::vector<double>& pairs);

}  // namespace luz
