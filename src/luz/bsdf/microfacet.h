// Microfacet distributions: Beckmann and GGX (Trowbridge-Reitz), isotropic or
// anisotropic (Mitsuba's alpha_u along the local x axis, alpha_v along y).
//
// All directions live in the local shading frame (macro normal +z). Sources:
//  [H14] E. Heitz, "Understanding the Masking-Shadowing Function in
//        Microfacet-Based BRDFs", JCGT 3(2), 2014: the Beckmann and GGX
//        distributions, isotropic and anisotropic (the projected roughness
//        α(φ)), their Smith Λ (GGX: eq. 72), G1 = χ⁺(ω·m) / (1 + Λ(ω)), and
//        the height-correlated masking-shadowing function
//        G2 = χ⁺(ωo·m) χ⁺(ωi·m) / (1 + Λ(ωo) + Λ(ωi)) (eq. 99).
//  [HD14] E. Heitz, E. d'Eon, "Importance Sampling Microfacet-Based BSDFs
//        using the Distribution of Visible Normals", EGSR 2014: the density of
//        visible normals D_ω(m) = G1(ω, m) max(0, ω·m) D(m) / cos θ and its
//        sampling by stretching to α = 1, sampling the visible slope
//        distribution, rotating and unstretching (with the Beckmann case).
//  [H18] E. Heitz, "Sampling the GGX Distribution of Visible Normals", JCGT
//        7(4), 2018 (Appendix A, Listing 1, whose steps are §§3.2, 4.1-4.3 and
//        3.4): the exact GGX routine.
//  [W07] B. Walter, S. Marschner, H. Li, K. Torrance, "Microfacet Models for
//        Refraction through Rough Surfaces", EGSR 2007: Beckmann D (eq. 25)
//        and GGX D (eq. 33), sampling m ∝ D(m) cos θm (eqs. 28, 35).
//
// For the Beckmann visible slopes we invert the 1D marginal CDF numerically
// (Newton steps safeguarded by bisection, in the erf domain where the search
// interval is bounded), an approach Mitsuba also uses instead of the paper's
// fitted inverse; the code here is derived from the CDF below, not copied.
#pragma once

#include "luz/math/special.h"
#include "luz/math/vec.h"

namespace luz {

enum class MicrofacetType : uint32_t { Beckmann, GGX };

struct MicrofacetDistribution {
  MicrofacetType type = MicrofacetType::GGX;
  float alpha_u = 0.1f, alpha_v = 0.1f;

  LUZ_INLINE static MicrofacetDistribution make(MicrofacetType t, float au, float av) {
    MicrofacetDistribution d;
    d.type = t;
    // Below ~1e-4 the squares underflow the float range used by D.
    d.alpha_u = max(au, 1e-4f);
    d.alpha_v = max(av, 1e-4f);
    return d;
  }

  // D(m), normalised so that ∫ D(m) cos θm dωm = 1 ([H14], [W07] eqs. 25, 33).
  LUZ_INLINE float D(Vec3 m) const {
    if (m.z <= 0.f) return 0.f;
    float z2 = m.z * m.z;
    float e = (m.x * m.x / (alpha_u * alpha_u) + m.y * m.y / (alpha_v * alpha_v)) / z2;  // tan²θ / α(φ)²
    if (type == MicrofacetType::Beckmann) {
      float v = expf(-e) / (kPi * alpha_u * alpha_v * z2 * z2);
      return v > 1e-20f ? v : 0.f;
    }
    float d = 1.f + e;
    return 1.f / (kPi * alpha_u * alpha_v * z2 * z2 * d * d);
  }

  // Smith Λ(ω) ([H14]'s closed forms for Beckmann and GGX, eq. 72 for GGX;
  // anisotropic via the projected roughness α(φ)² tan²θ = (αu² x² + αv² y²) / z²).
  LUZ_INLINE float lambda(Vec3 w) const {
    float z2 = w.z * w.z;
    float a2t2 = (alpha_u * alpha_u * w.x * w.x + alpha_v * alpha_v * w.y * w.y);  // α² tan²θ · z²
    if (a2t2 <= 0.f) return 0.f;
    if (type == MicrofacetType::Beckmann) {
      float a = fabsf(w.z) / sqrtf(a2t2);  // 1 / (α tan θ)
      if (a > 6.f) return 0.f;             // Λ < 1e-17
      // Λ = (erf(a) - 1)/2 + exp(-a²) / (2 a sqrt(π))
      float l = 0.5f * (expf(-a * a) / (a * 1.7724538509055159f) - erfcf(a));
      return l > 0.f ? l : 0.f;
    }
    // Λ = (-1 + sqrt(1 + α² tan²θ)) / 2, written without cancellation.
    float t = a2t2 / z2;
    if (!(t < 1e30f)) return 0.5f * sqrtf(a2t2) / fabsf(w.z);  // grazing: sqrt(t)/2
    return t / (2.f * (1.f + sqrtf(1.f + t)));
  }

  // Smith masking G1(ω, m) = χ⁺(ω·m / ω·n) / (1 + Λ(ω)).
  LUZ_INLINE float G1(Vec3 w, Vec3 m) const {
    if (dot(w, m) * w.z <= 0.f) return 0.f;
    return 1.f / (1.f + lambda(w));
  }
  // Height-correlated masking-shadowing ([H14] eq. 99).
  LUZ_INLINE float G2(Vec3 wo, Vec3 wi, Vec3 m) const {
    if (dot(wo, m) * wo.z <= 0.f || dot(wi, m) * wi.z <= 0.f) return 0.f;
    return 1.f / (1.f + lambda(wo) + lambda(wi));
  }

  // Density of normals visible from w (w.z > 0), per unit solid angle of m
  // ([HD14]): D_w(m) = G1(w, m) max(0, w·m) D(m) / cos θ.
  LUZ_INLINE float pdf_visible(Vec3 w, Vec3 m) const {
    float wm = dot(w, m);
    if (w.z <= 0.f || wm <= 0.f) return 0.f;
    return wm * D(m) / ((1.f + lambda(w)) * w.z);
  }

  // Samples m from D_w(m), w.z > 0.
  LUZ_INLINE Vec3 sample_visible(Vec3 w, Vec2 u) const {
    if (type == MicrofacetType::GGX) return sample_visible_ggx(w, u);
    return sample_visible_beckmann(w, u);
  }

  // [H18] Listing 1: the exact GGX visible-normal sampler.
  LUZ_INLINE Vec3 sample_visible_ggx(Vec3 w, Vec2 u) const {
    // §3.2: to the hemisphere configuration (α = 1).
    Vec3 vh = normalize(Vec3{alpha_u * w.x, alpha_v * w.y, w.z});
    // §4.1: orthonormal basis around vh.
    float lensq = vh.x * vh.x + vh.y * vh.y;
    Vec3 t1 = lensq > 0.f ? Vec3{-vh.y, vh.x, 0.f} * (1.f / sqrtf(lensq)) : Vec3{1.f, 0.f, 0.f};
    Vec3 t2 = cross(vh, t1);
    // §4.2: uniform point on the projected hemisphere (a disk and a half-disk).
    float r = sqrtf(u.x), phi = 2.f * kPi * u.y;
    float p1 = r * cosf(phi), p2 = r * sinf(phi);
    float s = 0.5f * (1.f + vh.z);
    p2 = (1.f - s) * safe_sqrt(1.f - p1 * p1) + s * p2;
    // §4.3: reprojection onto the hemisphere.
    Vec3 nh = t1 * p1 + t2 * p2 + vh * safe_sqrt(1.f - p1 * p1 - p2 * p2);
    // §3.4: back to the ellipsoid configuration.
    return normalize(Vec3{alpha_u * nh.x, alpha_v * nh.y, max(0.f, nh.z)});
  }

  // Beckmann, after [HD14]: stretch w to α = 1, sample the visible slopes
  // (x̃, ỹ) for a view at polar angle θ in the xz plane, rotate by the view's
  // azimuth, unstretch, and turn the slope into a normal.
  //
  // Visible slopes at α = 1: the facet of slope (x̃, ỹ) (normal ∝ (-x̃, -ỹ, 1))
  // has projected area ∝ max(0, cos θ - x̃ sin θ) toward the view, so
  //   p(x̃, ỹ) ∝ (1 - x̃ tan θ)⁺ exp(-x̃²) exp(-ỹ²) / π:
  // ỹ is an independent unit Gaussian (ỹ = erfinv(2u - 1)), and x̃ ≤ cot θ has
  //   CDF(x̃) ∝ 1 + erf(x̃) + tan θ exp(-x̃²) / sqrt(π).
  // With b = erf(x̃) ∈ (-1, erf(cot θ)] the CDF reads
  //   C(b) = K (1 + b + tan θ exp(-erfinv(b)²) / sqrt(π)),  C'(b) = K (1 - x̃ tan θ),
  // monotone on a bounded interval: Newton safeguarded by bisection.
  LUZ_INLINE Vec3 sample_visible_beckmann(Vec3 w, Vec2 u) const {
    Vec3 ws = normalize(Vec3{alpha_u * w.x, alpha_v * w.y, w.z});
    float sin_t = safe_sqrt(1.f - ws.z * ws.z);
    float cos_phi = 1.f, sin_phi = 0.f;
    if (sin_t > 1e-7f) {
      cos_phi = ws.x / sin_t;
      sin_phi = ws.y / sin_t;
    }
    const float inv_sqrt_pi = 0.56418958354775628f;
    float ux = clamp(u.x, 1e-6f, 1.f - 1e-6f);
    float sx;
    if (sin_t < 1e-4f) {
      sx = erfinv(2.f * ux - 1.f);  // normal view: no slope is hidden
    } else {
      float tan_t = sin_t / ws.z, cot_t = ws.z / sin_t;
      float lo = -1.f, hi = erff(cot_t);
      float k = 1.f / (1.f + hi + tan_t * inv_sqrt_pi * expf(-cot_t * cot_t));
      float b = clamp(2.f * ux - 1.f, lo, hi);  // the normal-view solution as a start
      for (int it = 0; it < 64; ++it) {
        if (!(b > lo && b < hi)) b = 0.5f * (lo + hi);
        float x = erfinv(b);
        float value = k * (1.f + b + tan_t * inv_sqrt_pi * expf(-x * x)) - ux;
        float deriv = k * (1.f - x * tan_t);
        if (fabsf(value) < 1e-7f) break;
        if (value > 0.f)
          hi = b;
        else
          lo = b;
        if (hi - lo < 1e-7f) break;
        b -= value / deriv;
      }
      sx = erfinv(clamp(b, -1.f + 6e-8f, 1.f - 6e-8f));
    }
    float sy = erfinv(2.f * clamp(u.y, 1e-6f, 1.f - 1e-6f) - 1.f);
    // Rotate by the azimuth of the stretched view, unstretch.
    float x = (cos_phi * sx - sin_phi * sy) * alpha_u;
    float y = (sin_phi * sx + cos_phi * sy) * alpha_v;
    return normalize(Vec3{-x, -y, 1.f});
  }

  // Samples m ∝ D(m) cos θm (all normals, not only the visible ones; [W07]
  // eqs. 28 and 35 generalised to anisotropy): pdf = D(m) cos θm.
  LUZ_INLINE Vec3 sample_all(Vec2 u) const {
    float phi = 2.f * kPi * u.y;
    float r;  // stretched slope length
    float uu = min(u.x, kOneMinusEpsilon);
    if (type == MicrofacetType::Beckmann)
      r = sqrtf(-logf(1.f - uu));
    else
      r = sqrtf(uu / (1.f - uu));
    float x = r * cosf(phi) * alpha_u, y = r * sinf(phi) * alpha_v;
    return normalize(Vec3{-x, -y, 1.f});
  }
};

}  // namespace luz
