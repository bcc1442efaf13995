// The branch-free geometry helpers: the robust ray offset (Wächter & Binder)
// against a plain per-axis statement of the method and against its defining
// property (the moved point lies on n's side of p, a few ulps away), and
// select_lt and swap_unless_lt against the ternaries they replace; the
// ray-sphere test against the closed-form roots, for any direction length.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

#include "luz/geometry/shapes.h"
#include "luz/math/hash.h"

using namespace luz;

namespace {

// The method as Ray Tracing Gems ch. 6 writes it, one axis at a time, with
// branches: the reference for the vectorised CPU version.
float offset_reference(float p, float n) {
  constexpr float kOrigin = 1.f / 32.f, kFloatScale = 1.f / 65536.f, kIntScale = 256.f;
  if (std::fabs(p) < kOrigin) return p + kFloatScale * n;
  int32_t of = int32_t(kIntScale * n);
  int32_t bits;
  std::memcpy(&bits, &p, 4);
  bits += p < 0.f ? -of : of;
  float r;
  std::memcpy(&r, &bits, 4);
  return r;
}

uint32_t bits_of(float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

// A float of random sign and magnitude 2^[-12, 12) (a tenth of them near
// the origin, a few exactly ±0).
float random_coordinate(uint64_t key) {
  uint64_t h = mix64(key);
  float mag = std::ldexp(1.f + float(h & 0xffff) / 65536.f, int((h >> 16) % 24) - 12);
  if ((h >> 24) % 10 == 0) mag *= 1.f / 64.f;
  if ((h >> 32) % 97 == 0) mag = 0.f;
  return (h >> 40) & 1 ? -mag : mag;
}

Vec3 random_unit(uint64_t key) {
  for (uint64_t k = 0;; ++k) {
    uint64_t h = mix64(key * 7919 + k);
    Vec3 v{float(h & 0xffff) / 32768.f - 1.f, float((h >> 16) & 0xffff) / 32768.f - 1.f,
           float((h >> 32) & 0xffff) / 32768.f - 1.f};
    float l2 = dot(v, v);
    if (l2 > 1e-4f && l2 <= 1.f) return v * (1.f / std::sqrt(l2));
  }
}

}  // namespace

TEST(Geometry, OffsetRayOriginMatchesTheReferenceBitForBit) {
  for (uint64_t i = 0; i < 200000; ++i) {
    Vec3 p{random_coordinate(3 * i), random_coordinate(3 * i + 1), random_coordinate(3 * i + 2)};
    Vec3 n = random_unit(i);
    Vec3 r = offset_ray_origin(p, n);
    for (int a = 0; a < 3; ++a)
      ASSERT_EQ(bits_of(r[a]), bits_of(offset_reference(p[a], n[a])))
          << "axis " << a << " p " << p[a] << " n " << n[a] << " (sample " << i << ")";
  }
}

TEST(Geometry, OffsetRayOriginMovesToTheNormalsSideByFewUlps) {
  int moved_wrong_way = 0;
  for (uint64_t i = 0; i < 200000; ++i) {
    Vec3 p{random_coordinate(3 * i + 7), random_coordinate(3 * i + 8), random_coordinate(3 * i + 9)};
    Vec3 n = random_unit(i + 999);
    Vec3 r = offset_ray_origin(p, n);
    double along = 0, scale = 0;
    for (int a = 0; a < 3; ++a) {
      double d = double(r[a]) - double(p[a]);
      along += d * n[a];
      // Each axis moves by at most 256 steps of p's bits (under 2·257 ulps of p,
      // should it cross a power of two), or 2^-16 near the origin,
      // and never against n's component on that axis.
      double ulp = std::max(double(std::nextafter(std::fabs(p[a]), 1e30f) - std::fabs(p[a])), 0x1p-149);
      ASSERT_LE(std::fabs(d), std::max(2 * 257 * ulp, 0x1p-16 * 1.001)) << "axis " << a << " sample " << i;
      ASSERT_GE(d * n[a], 0.0) << "axis " << a << " sample " << i;
      scale += std::fabs(d);
    }
    if (!(along > 0) && scale > 0) ++moved_wrong_way;
  }
  EXPECT_EQ(moved_wrong_way, 0);
}

TEST(Geometry, SelectLtIsTheTernary) {
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  const float xs[] = {-inf, -2.f, -0.f, 0.f, 1e-40f, 0.5f, 1.f, 3.f, inf, nan};
  for (float x : xs)
    for (float y : xs) {
      EXPECT_EQ(bits_of(select_lt(x, y, 1.25f, -7.f)), bits_of(x < y ? 1.25f : -7.f)) << x << " < " << y;
      EXPECT_EQ(bits_of(select_lt(x, y, -0.f, nan)), bits_of(x < y ? -0.f : nan)) << x << " < " << y;
      for (auto [a, b] : {std::pair{1.25f, -7.f}, std::pair{-0.f, nan}, std::pair{inf, 0.f}}) {
        float p, q;
        swap_unless_lt(x, y, a, b, p, q);
        EXPECT_EQ(bits_of(p), bits_of(x < y ? a : b)) << x << " < " << y;
        EXPECT_EQ(bits_of(q), bits_of(x < y ? b : a)) << x << " < " << y;
      }
    }
}

// intersect_sphere(o, d) for a direction of any length (shadow rays run
// along the unnormalised segment, t in (0, 1)): the roots of |o + t d - c|² =
// r², in double, for a unit d and the same d scaled; tmax clips either.
TEST(Geometry, SphereHitsAtTheRootsForAnyDirectionLength) {
  const Vec3 c{0.3f, -0.2f, 5.f};
  const float r = 1.5f;
  int hits = 0;
  for (int k = 0; k < 200; ++k) {
    const float a = 0.02f * float(k), b = 0.013f * float(k);
    const Vec3 o{std::sin(a) * 3.f, std::cos(b) * 2.f, -1.f + 0.05f * float(k)};
    const Vec3 unit =
        normalize(Vec3{c.x - o.x + 0.9f * std::sin(3.f * a), c.y - o.y + 0.8f * std::cos(5.f * b), c.z - o.z});
    for (float scale : {1.f, 0.01f, 7.3f, 300.f}) {
      const Vec3 d = unit * scale;
      // Roots in double: A t² + 2 B t + C = 0.
      const double A = double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z;
      const double fx = double(o.x) - c.x, fy = double(o.y) - c.y, fz = double(o.z) - c.z;
      const double B = fx * d.x + fy * d.y + fz * d.z, C = fx * fx + fy * fy + fz * fz - double(r) * r;
      const double disc = B * B - A * C;
      const float t = intersect_sphere(c, r, o, d, kInfinity);
      const double t0 = (-B - std::sqrt(std::max(disc, 0.0))) / A, t1 = (-B + std::sqrt(std::max(disc, 0.0))) / A;
      const double expect = disc < 0.0 ? -1.0 : t0 > 0.0 ? t0 : t1 > 0.0 ? t1 : -1.0;
      if (expect < 0.0) {
        EXPECT_LT(t, 0.f) << k << " " << scale;
        continue;
      }
      ++hits;
      // Compared in scene units (t · |d|): the rounding of o and d.
      EXPECT_NEAR(double(t) * scale, expect * scale, 1e-5 * (1.0 + expect * scale)) << k << " " << scale;
      EXPECT_LT(intersect_sphere(c, r, o, d, float(expect) * 0.999f), float(expect) * 0.999f) << k << " " << scale;
    }
  }
  EXPECT_GT(hits, 400);
}
