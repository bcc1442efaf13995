// 4×4 affine transforms, host only (the loaders bake them into the geometry).
#pragma once

#include <cmath>

#include "luz/math/vec.h"

namespace luz {

struct Matrix4 {
  double m[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};

  static Matrix4 translate(Vec3 t) {
    Matrix4 r;
    r.m[0][3] = t.x;
    r.m[1][3] = t.y;
    r.m[2][3] = t.z;
    return r;
  }
  static Matrix4 scale(Vec3 s) {
    Matrix4 r;
    r.m[0][0] = s.x;
    r.m[1][1] = s.y;
    r.m[2][2] = s.z;
    return r;
  }
  // Rotation by angle (degrees) about axis (Rodrigues).
  static Matrix4 rotate(Vec3 axis, double degrees) {
    double len = std::sqrt(double(axis.x) * axis.x + double(axis.y) * axis.y + double(axis.z) * axis.z);
    double x = axis.x / len, y = axis.y / len, z = axis.z / len;
    double a = degrees * M_PI / 180.0, c = std::cos(a), s = std::sin(a), t = 1 - c;
    Matrix4 r;
    r.m[0][0] = t * x * x + c;
    r.m[0][1] = t * x * y - s * z;
    r.m[0][2] = t * x * z + s * y;
    r.m[1][0] = t * x * y + s * z;
    r.m[1][1] = t * y * y + c;
    r.m[1][2] = t * y * z - s * x;
    r.m[2][0] = t * x * z - s * y;
    r.m[2][1] = t * y * z + s * x;
    r.m[2][2] = t * z * z + c;
    return r;
  }
  // Mitsuba's lookat: columns (left, up, dir, origin), left = up × dir.
  static Matrix4 look_at(Vec3 origin, Vec3 target, Vec3 up) {
    Vec3 dir = normalize(target - origin);
    Vec3 left = normalize(cross(normalize(up), dir));
    Vec3 new_up = cross(dir, left);
    Matrix4 r;
    for (int i = 0; i < 3; ++i) {
      r.m[i][0] = left[i];
      r.m[i][1] = new_up[i];
      r.m[i][2] = dir[i];
      r.m[i][3] = origin[i];
    }
    return r;
  }

  Matrix4 operator*(const Matrix4& b) const {
    Matrix4 r;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        double s = 0;
        for (int k = 0; k < 4; ++k) s += m[i][k] * b.m[k][j];
        r.m[i][j] = s;
      }
    return r;
  }

  Vec3 point(Vec3 p) const {
    double v[3];
    for (int i = 0; i < 3; ++i) v[i] = m[i][0] * p.x + m[i][1] * p.y + m[i][2] * p.z + m[i][3];
    return {float(v[0]), float(v[1]), float(v[2])};
  }
  Vec3 vector(Vec3 d) const {
    double v[3];
    for (int i = 0; i < 3; ++i) v[i] = m[i][0] * d.x + m[i][1] * d.y + m[i][2] * d.z;
    return {float(v[0]), float(v[1]), float(v[2])};
  }
  double det3() const {
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  }
  // Normal transform: inverse transpose of the linear part (by cofactors;
  // the determinant's magnitude is irrelevant after normalisation, its sign is kept).
  Vec3 normal(Vec3 n) const {
    double c[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
        c[i][j] = m[i1][j1] * m[i2][j2] - m[i1][j2] * m[i2][j1];
      }
    double s = det3() < 0 ? -1 : 1;
    Vec3 r{float(s * (c[0][0] * n.x + c[0][1] * n.y + c[0][2] * n.z)),
           float(s * (c[1][0] * n.x + c[1][1] * n.y + c[1][2] * n.z)),
           float(s * (c[2][0] * n.x + c[2][1] * n.y + c[2][2] * n.z))};
    return normalize(r);
  }
};

}  // namespace luz
