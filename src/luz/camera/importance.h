// The camera seen from the scene, for light paths (light tracing, BDPT):
// which film position a point's light reaches through a given lens point,
// and with what importance (pbrt-v4's Camera::SampleWi and We).
//
// A pixel's value is I = ∫ F(q − c) ⟨L(ray(q, a))⟩_lens dq over film
// positions q in pixels, F the pixel filter's density (integral 1) and the
// lens average uniform over the aperture disk (camera_sample's rays). For a
// lens point a and a scene point x, the ray a → x crosses the film at q and
// dq = J dω with J = (W · H / (4 tan_x tan_y)) · |M (v / v_z)|³ / |det M|,
// where v is x − a in camera space (its z the depth along the axis) and M the
// camera frame's linear part (the ray direction through camera-plane point
// (p, 1) is M (p, 1)). The lens density 1 / (π r²) cancels the lens
// average, so light arriving at x from a light path of throughput β is
// measured by pixel c as
//     β · f · |cos θ_x| · (J / d²) · F(q − c),  d = |x − a|,
// per light path, for a render of N light paths divided by N. `importance`
// below is J / (W · H · d²), film-normalised (its integral over the directions
// through the whole film is 1, as pbrt's We): multiply by W · H for one pixel's
// filter. A pinhole (no lens) is the case a = the origin.
//
// The orthographic camera sees each point along one direction only (a
// delta in direction): no connection can reach it.
#pragma once

#include "luz/camera/camera.h"

namespace luz {

struct CameraConnection {
  bool valid = false;
  float fx = 0.f, fy = 0.f;  // film position, pixels from the top-left corner
  Vec3 p_lens;               // the lens point (the pinhole: the frame's origin)
  Vec3 wi;                   // unit direction from the scene point to p_lens
  float dist = 0.f;          // |x − p_lens|
  float importance = 0.f;    // film-normalised, per unit solid angle at the lens, over dist²
};

// The connection of scene point x to the camera through the lens point of
// lens sample u (camera_sample's lens sample; unused without a lens).
// Invalid for the orthographic camera, for a point not in front of the lens,
// and (importance 0) for one whose film position falls outside the film.
LUZ_INLINE CameraConnection camera_connect(const Camera& cam, Vec3 x, Vec2 u = {0.5f, 0.5f}) {
  CameraConnection c;
  if (cam.type == CameraType::Orthographic) return c;
  float ax = 0.f, ay = 0.f;  // the lens point in camera space (z = 0)
  if (cam.has_lens()) {
    const Vec2 disk = square_to_uniform_disk(u);
    ax = disk.x * cam.lens.aperture_radius;
    ay = disk.y * cam.lens.aperture_radius;
  }
  c.p_lens = cam.point(ax, ay);
  const Vec3 d = x - c.p_lens;
  // Camera-space v = M⁻¹ d by the rows of M's inverse (cross products of its columns).
  const Vec3 yz = cross(cam.y_axis, cam.z_axis);
  const float det = dot(cam.x_axis, yz);
  if (!(fabsf(det) > 0.f)) return c;
  const float vz = dot(cross(cam.x_axis, cam.y_axis), d) / det;
  if (!(vz > 0.f)) return c;
  const float vx = dot(yz, d) / det, vy = dot(cross(cam.z_axis, cam.x_axis), d) / det;
  // The film's camera-plane point: the ray meets the focal plane at
  // a + v · fd / v_z, which the pinhole sees through p = that / fd.
  const float inv_fd = cam.has_lens() ? 1.f / cam.lens.focus_distance : 0.f;
  const float px = vx / vz + ax * inv_fd, py = vy / vz + ay * inv_fd;
  c.fx = (cam.edge_x - px / cam.tan_half_x) * (0.5f * float(cam.width));
  c.fy = (cam.edge_y - py / cam.tan_half_y) * (0.5f * float(cam.height));
  c.dist = length(d);
  if (!(c.dist > 0.f)) return c;
  c.wi = d * (-1.f / c.dist);
  c.valid = true;
  if (c.fx < 0.f || c.fy < 0.f || c.fx >= float(cam.width) || c.fy >= float(cam.height)) return c;
  const float u3 = c.dist / vz;  // |M (v / v_z)|
  c.importance = u3 * u3 * u3 / (4.f * cam.tan_half_x * cam.tan_half_y * fabsf(det) * c.dist * c.dist);
  return c;
}

}  // namespace luz
