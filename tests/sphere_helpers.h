// Spheres in double for the texture-coordinate tests: an affine to_world
// written as Mitsuba's <matrix>, points of a sphere by their object-space
// angles, and the closed forms of Mitsuba 3's and pbrt-v4's sphere uv and
// dp/du, dp/dv (src/shapes/sphere.cpp; pbrt-v4's Sphere::InteractionFromIntersection).
#pragma once

#include <cmath>
#include <cstdio>
#include <string>

#include "luz/geometry/shapes.h"

namespace luz_test {

struct Dvec {
  double x = 0, y = 0, z = 0;
};
inline Dvec operator+(Dvec a, Dvec b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Dvec operator-(Dvec a, Dvec b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Dvec operator*(double s, Dvec a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(Dvec a, Dvec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Dvec cross(Dvec a, Dvec b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline Dvec unit(Dvec a) { return (1.0 / std::sqrt(dot(a, a))) * a; }
inline luz::Vec3 vec3(Dvec a) { return {float(a.x), float(a.y), float(a.z)}; }
inline Dvec dvec(luz::Vec3 a) { return {a.x, a.y, a.z}; }

// x ↦ A x + b.
struct Affine {
  double a[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  Dvec b;

  // About the unit axis (Rodrigues), counter-clockwise.
  static Affine rotate(Dvec axis, double degrees) {
    const Dvec k = unit(axis);
    const double t = degrees * M_PI / 180.0, c = std::cos(t), s = std::sin(t);
    const double kk[3] = {k.x, k.y, k.z};
    Affine r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r.a[i][j] = (i == j ? c : 0.0) + (1 - c) * kk[i] * kk[j];
    r.a[0][1] -= s * k.z, r.a[0][2] += s * k.y, r.a[1][0] += s * k.z;
    r.a[1][2] -= s * k.x, r.a[2][0] -= s * k.y, r.a[2][1] += s * k.x;
    return r;
  }
  static Affine scale(Dvec s) {
    Affine r;
    r.a[0][0] = s.x, r.a[1][1] = s.y, r.a[2][2] = s.z;
    return r;
  }
  static Affine translate(Dvec t) {
    Affine r;
    r.b = t;
    return r;
  }
  Affine operator*(const Affine& o) const {
    Affine r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r.a[i][j] = a[i][0] * o.a[0][j] + a[i][1] * o.a[1][j] + a[i][2] * o.a[2][j];
    r.b = point(o.b);
    return r;
  }
  Dvec vector(Dvec v) const {
    return {a[0][0] * v.x + a[0][1] * v.y + a[0][2] * v.z, a[1][0] * v.x + a[1][1] * v.y + a[1][2] * v.z,
            a[2][0] * v.x + a[2][1] * v.y + a[2][2] * v.z};
  }
  Dvec point(Dvec p) const { return vector(p) + b; }
  // Mitsuba's <transform name="to_world"> of this map (row-major <matrix>).
  std::string mitsuba() const {
    std::string s = "<transform name=\"to_world\"><matrix value=\"";
    char buf[64];
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        const double v = i < 3 ? (j < 3 ? a[i][j] : (i == 0 ? b.x : i == 1 ? b.y : b.z)) : (j == 3 ? 1.0 : 0.0);
        std::snprintf(buf, sizeof buf, "%.17g ", v);
        s += buf;
      }
    return s + "\"/></transform>";
  }
};

// The object-space unit direction of angles θ (from +z) and φ (from +x toward +y).
inline Dvec sphere_dir(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// Mitsuba 3's uv of the object-space unit direction l: (φ / 2π, θ / π).
struct Duv {
  double u, v;
};
inline Duv mitsuba_sphere_uv(Dvec l) {
  double phi = std::atan2(l.y, l.x);
  if (phi < 0) phi += 2 * M_PI;
  return {phi / (2 * M_PI), std::acos(std::fmax(-1.0, std::fmin(1.0, l.z))) / M_PI};
}

// pbrt-v4's for a full sphere: u = φ / φmax, v = (θ − θzmin) / (θzmax − θzmin)
// with θzmin = acos(zmin / r) = π and θzmax = acos(zmax / r) = 0.
inline Duv pbrt_sphere_uv(Dvec l) {
  double phi = std::atan2(l.y, l.x);
  if (phi < 0) phi += 2 * M_PI;
  const double theta = std::acos(std::fmax(-1.0, std::fmin(1.0, l.z))), zmin = M_PI, zmax = 0.0;
  return {phi / (2 * M_PI), (theta - zmin) / (zmax - zmin)};
}

// A hit on sphere `prim` at world point p seen from outside along -n (n the
// outward unit normal there), as a tracer reports it.
inline void sphere_hit_at(uint32_t prim, Dvec p, Dvec n, luz::Ray& ray, luz::Hit& hit) {
  ray.o = vec3(p + 2.0 * n);
  ray.d = vec3(-1.0 * n);
  hit = luz::Hit{};
  hit.t = 2.f;
  hit.prim = prim;
  hit.kind = luz::PrimKind::Sphere;
}

}  // namespace luz_test
