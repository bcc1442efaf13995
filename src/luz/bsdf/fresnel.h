// Fresnel equations and named index-of-refraction presets.
//
//  - fresnel_dielectric: exact unpolarised reflectance of a smooth interface
//    between two dielectrics (Born & Wolf, Principles of Optics, §1.5.2; the
//    form of Walter et al. 2007, eq. 22, written with cos θt so total
//    internal reflection and η < 1 come out exactly).
//  - fresnel_conductor: exact unpolarised reflectance of a dielectric (η = 1
//    outside) / conductor interface with complex IOR η + ik, in the closed
//    form of K. D. Möller, "Optics" (1988), also used by pbrt-v3 and
//    Mitsuba: with a² + b² = sqrt((η² - k² - sin²θ)² + 4η²k²) and
//    a² = (a² + b² + η² - k² - sin²θ)/2,
//      Rs = (a² + b² + cos²θ - 2a cos θ) / (a² + b² + cos²θ + 2a cos θ),
//      Rp = Rs (cos²θ (a² + b²) + sin⁴θ - 2a cos θ sin²θ)
//             / (cos²θ (a² + b²) + sin⁴θ + 2a cos θ sin²θ),
//      F = (Rs + Rp) / 2.
//  - fresnel_diffuse_reflectance: hemispherical average 2∫ F(μ) μ dμ, by
//    quadrature (host-side, once per material).
//  - schlick_weight: Schlick's (1 - cos θ)⁵, the weight of F90 in his
//    approximation F = F0 + (F90 - F0)(1 - cos θ)⁵ (glTF's and the Disney
//    models' Fresnel).
//
// Presets (names as Mitsuba's): dielectric IORs from Mitsuba's table (its
// documentation of the `dielectric` plugin); conductor (η, k) as RGB.
#pragma once

#include "luz/math/vec.h"

namespace luz {

LUZ_INLINE float schlick_weight(float cos_theta) {
  const float x = clamp(1.f - cos_theta, 0.f, 1.f), x2 = x * x;
  return x2 * x2 * x;
}

// Result of the dielectric Fresnel equations for cos θi = cos_i (signed: < 0
// means the incident direction is inside, below the surface) and eta =
// η_inside / η_outside.
struct FresnelDielectric {
  float F = 1.f;        // reflectance
  float cos_t = 0.f;    // cos θt of the refracted direction, signed (opposite side), 0 on TIR
  float eta_it = 1.f;   // η_transmitted / η_incident
  float eta_ti = 1.f;   // its inverse
};

LUZ_INLINE FresnelDielectric fresnel_dielectric(float cos_i, float eta) {
  FresnelDielectric r;
  bool outside = cos_i >= 0.f;
  r.eta_it = outside ? eta : 1.f / eta;
  r.eta_ti = outside ? 1.f / eta : eta;
  // Snell: sin²θt = (η_i/η_t)² sin²θi.
  float cos_t2 = 1.f - r.eta_ti * r.eta_ti * (1.f - cos_i * cos_i);
  if (cos_t2 <= 0.f) {  // total internal reflection
    r.F = 1.f;
    r.cos_t = 0.f;
    return r;
  }
  float ci = fabsf(cos_i), ct = sqrtf(cos_t2);
  if (eta == 1.f) {
    r.F = 0.f;
  } else if (ci == 0.f) {
    r.F = 1.f;
  } else {
    // rs = (η_i cos_i - η_t cos_t)/(η_i cos_i + η_t cos_t), rp likewise.
    float rs = (ci - r.eta_it * ct) / (ci + r.eta_it * ct);
    float rp = (r.eta_it * ci - ct) / (r.eta_it * ci + ct);
    r.F = 0.5f * (rs * rs + rp * rp);
  }
  r.cos_t = outside ? -ct : ct;
  return r;
}

// Refraction of w (pointing away from the surface) about the normal m, given
// the signed cos θt and η_t/η_i's inverse from fresnel_dielectric evaluated
// with cos_i = dot(w, m).
LUZ_INLINE Vec3 refract(Vec3 w, Vec3 m, float cos_t, float eta_ti) {
  return m * (dot(w, m) * eta_ti + cos_t) - w * eta_ti;
}

LUZ_INLINE float fresnel_conductor(float cos_i, float eta, float k) {
  float c2 = cos_i * cos_i, s2 = 1.f - c2, s4 = s2 * s2;
  float t1 = eta * eta - k * k - s2;
  float a2pb2 = safe_sqrt(t1 * t1 + 4.f * eta * eta * k * k);
  float a = safe_sqrt(0.5f * (a2pb2 + t1));
  float term1 = a2pb2 + c2, term2 = 2.f * cos_i * a;
  float rs = (term1 - term2) / (term1 + term2);
  float term3 = a2pb2 * c2 + s4, term4 = term2 * s2;
  float rp = rs * (term3 - term4) / (term3 + term4);
  return 0.5f * (rs + rp);
}
LUZ_INLINE Color fresnel_conductor(float cos_i, Color eta, Color k) {
  cos_i = clamp(fabsf(cos_i), 0.f, 1.f);
  return {fresnel_conductor(cos_i, eta.x, k.x), fresnel_conductor(cos_i, eta.y, k.y),
          fresnel_conductor(cos_i, eta.z, k.z)};
}

// Hemispherical-average reflectance F_dr(η) = 2 ∫0^1 F(μ, η) μ dμ seen from
// the outside (μ = cos θ of the incident direction), η = η_inside/η_outside.
// The integrand is smooth for η > 1 (no total reflection from outside);
// for η < 1 it is 1 below the critical cosine and smooth above it, and the
// two pieces are integrated separately. Composite Simpson, n panels: meant
// for the host, once per material.
LUZ_INLINE float fresnel_diffuse_reflectance(float eta, int n = 2048) {
  double lo = 0.0, sum = 0.0;
  if (eta < 1.f) {
    double mu_c = sqrt(1.0 - double(eta) * eta);  // cos of the critical angle
    sum = mu_c * mu_c;                            // 2 ∫0^μc μ dμ
    lo = mu_c;
  }
  double h = (1.0 - lo) / n, acc = 0.0;
  for (int i = 0; i <= n; ++i) {
    double mu = lo + i * h;
    double w = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
    // F in double (the float routine loses the last digits near grazing).
    double ci = mu, st2 = (1.0 - ci * ci) / (double(eta) * eta), ct2 = 1.0 - st2, F = 1.0;
    if (ct2 > 0.0 && ci > 0.0) {
      double ct = sqrt(ct2), rs = (ci - eta * ct) / (ci + eta * ct), rp = (eta * ci - ct) / (eta * ci + ct);
      F = 0.5 * (rs * rs + rp * rp);
    }
    acc += w * F * mu;
  }
  sum += 2.0 * acc * h / 3.0;
  return float(sum);
}

// --- presets ----------------------------------------------------------------

// Dielectric IORs at ~589 nm, Mitsuba 3's named table (include/mitsuba/render/ior.h).
struct IorPreset {
  const char* name;
  float ior;
};
inline constexpr IorPreset kIorPresets[] = {
    {"vacuum", 1.0f},          {"helium", 1.000036f},       {"hydrogen", 1.000132f},
    {"air", 1.000277f},        {"carbon dioxide", 1.00045f}, {"water", 1.333f},
    {"acetone", 1.36f},        {"ethanol", 1.361f},          {"carbon tetrachloride", 1.461f},
    {"glycerol", 1.4729f},     {"benzene", 1.501f},          {"silicone oil", 1.52045f},
    {"bromine", 1.661f},       {"water ice", 1.31f},         {"fused quartz", 1.458f},
    {"pyrex", 1.47f},          {"acrylic glass", 1.49f},     {"polypropylene", 1.49f},
    {"bk7", 1.5046f},          {"sodium chloride", 1.544f},  {"amber", 1.55f},
    {"pet", 1.575f},           {"diamond", 2.419f},
    // Not in Mitsuba's table: common textbook values.
    {"glass", 1.5f},           {"polycarbonate", 1.585f},
};

// Conductors: complex IOR η + ik per RGB channel.
//
// Mitsuba's names, with the RGB values Mitsuba 3 itself uses in its RGB
// modes, recomputed offline the way it computes them (Mitsuba 3,
// include/mitsuba/render/ior.h `complex_ior_from_file` and
// src/core/spectrum.cpp `spectrum_list_to_srgb`): the spectral file
// data/ior/<name>.{eta,k}.spd (Mitsuba's luxpop.com data, read from Mitsuba's
// repository) is scaled by 1/106.7502593994140625 (MI_CIE_Y_NORMALIZATION),
// interpolated linearly at 1000 wavelengths spaced uniformly over
// [360, 830] nm (wavelengths outside the file's range skipped), multiplied by
// the CIE 1931 2° matching functions (Mitsuba's 5 nm table, linearly
// interpolated), summed and scaled by 470/1000, turned into linear sRGB with
// Mitsuba's XYZ→Rec.709 matrix, negatives clamped to 0 (the script is not
// part of Luz: it would have to carry the data). "none" is Mitsuba's perfect mirror (F = 1).
//
// Not (yet) here: Mitsuba's other names (a-C, AlAs, AlSb, Be, CsI, Cu2O,
// CuO, d-C, Hg, HgTe, Ir, K, Li, MgO, Mo, Na_palik, Nb, Ni_palik, Rh, Se,
// SiC, SnTe, Ta, Te, ThF4, TiC, TiN, TiO2, VC, V_palik, VN, W): the loader
// refuses them by name. "Fe" and "Pt" are Luz extras, not Mitsuba names:
// η, k sampled at 650 / 550 / 450 nm from refractiveindex.info (as
// tabulated in Chaos Group's "Understanding metalness", 2019), a different
// (point-sampled) conversion from the one above.
struct ConductorPreset {
  const char* name;
  Color eta, k;
};
inline constexpr ConductorPreset kConductorPresets[] = {
    {"none", {0.f, 0.f, 0.f}, {1.f, 1.f, 1.f}},
    {"Au", {0.143036f, 0.375307f, 1.44205f}, {3.983f, 2.38556f, 1.60336f}},
    {"Ag", {0.155276f, 0.116728f, 0.138388f}, {4.82835f, 3.12222f, 2.1469f}},
    {"Cu", {0.201006f, 0.923749f, 1.10222f}, {3.91326f, 2.45305f, 2.14209f}},
    {"Al", {1.6575f, 0.880405f, 0.521244f}, {9.22381f, 6.2695f, 4.837f}},
    {"Cr", {4.36967f, 2.91651f, 1.6549f}, {5.20655f, 4.23131f, 3.7547f}},
    {"Fe", {2.9114f, 2.9497f, 2.5845f}, {3.0893f, 2.9318f, 2.767f}},
    {"Pt", {2.3757f, 2.0847f, 1.8453f}, {4.2655f, 3.7153f, 3.1365f}},
};

// Host-side lookups (the loader's): false when the name is unknown.
inline bool find_ior_preset(const char* name, float& ior) {
  for (const IorPreset& p : kIorPresets) {
    const char *a = p.name, *b = name;
    while (*a && *a == *b) ++a, ++b;
    if (*a == 0 && *b == 0) {
      ior = p.ior;
      return true;
    }
  }
  return false;
}
inline bool find_conductor_preset(const char* name, Color& eta, Color& k) {
  for (const ConductorPreset& p : kConductorPresets) {
    const char *a = p.name, *b = name;
    while (*a && *a == *b) ++a, ++b;
    if (*a == 0 && *b == 0) {
      eta = p.eta;
      k = p.k;
      return true;
    }
  }
  return false;
}

}  // namespace luz
