// The camera: a type and the parameters the models share, one dispatch over
// the models (perspective.h, thin_lens.h, orthographic.h), and
// camera_sample(), the one function every device calls to turn a pixel's
// sample into a ray: pixel → filter → lens → ray. The reverse, a scene
// point's film position and importance for light paths: importance.h.
#pragma once

#include "luz/camera/frame.h"
#include "luz/camera/orthographic.h"
#include "luz/camera/perspective.h"
#include "luz/camera/thin_lens.h"
#include "luz/film/filter.h"
#include "luz/sampling/sampler.h"

namespace luz {

enum class CameraType : uint32_t { Perspective, ThinLens, Orthographic };

struct Camera : CameraFrame {
  CameraType type = CameraType::Perspective;
  // Half extents of the film in camera space, on the plane z = 1: the
  // tangents of the half fields of view (perspective, thin lens); for the
  // orthographic camera the half width and height (Mitsuba's 1 and 1/aspect).
  float tan_half_x = 0.5f, tan_half_y = 0.5f;
  // The film's left and top edges in those half extents: 1 − 2 · Mitsuba's
  // principal_point_offset_x/y (in film widths and heights); 1: centred.
  float edge_x = 1.f, edge_y = 1.f;
  int width = 256, height = 256;
  ThinLens lens;  // CameraType::ThinLens only

  // Keeps only the film's pixels [x0, x0 + w) × [y0, y0 + h) (a crop
  // window): a film of w × h whose pixels see what those pixels saw. Host only.
  void crop(int x0, int y0, int w, int h) {
    const float sx = float(w) / float(width), sy = float(h) / float(height);
    edge_x = (edge_x - 2.f * float(x0) / float(width)) / sx;
    edge_y = (edge_y - 2.f * float(y0) / float(height)) / sy;
    tan_half_x *= sx;
    tan_half_y *= sy;
    width = w;
    height = h;
  }

  // Whether camera_sample draws a lens sample: a thin lens of radius 0 is a
  // pinhole and draws none.
  LUZ_INLINE bool has_lens() const { return type == CameraType::ThinLens && lens.aperture_radius > 0.f; }

  // (fx, fy): continuous film position in pixels, (0,0) the top-left corner;
  // u: the lens sample, unused without a lens.
  LUZ_INLINE Ray generate_ray(float fx, float fy, Vec2 u = {0.5f, 0.5f}) const {
    // fx · (2 / width): the division is the same for every ray, so it leaves the per-sample loop.
    const Vec2 p{(edge_x - fx * (2.f / float(width))) * tan_half_x,
                 (edge_y - fy * (2.f / float(height))) * tan_half_y};
    switch (type) {
      case CameraType::ThinLens:
        return lens.ray(*this, p, u);
      case CameraType::Orthographic:
        return orthographic_ray(*this, p);
      default:
        return perspective_ray(*this, p);
    }
  }
};

// The camera ray of the sampler's current sample of pixel (x, y): the
// filter's 2D sample first (the sample's first dimension), then, with a lens,
// the lens sample as a second stream of that same dimension
// (Sampler::aux_2d), so that the path's dimensions do not depend on the
// camera and pinhole images are what they were before lenses existed.
LUZ_INLINE Ray camera_sample(const Camera& cam, uint32_t x, uint32_t y, Sampler& sampler, FilterKind filter) {
  const uint32_t d = sampler.dim;
  const Vec2 off = sample_filter(filter, sampler.next_2d());
  const Vec2 u = cam.has_lens() ? sampler.aux_2d(d) : Vec2{0.5f, 0.5f};
  return cam.generate_ray(float(x) + 0.5f + off.x, float(y) + 0.5f + off.y, u);
}

// Splatting's camera ray (film/splat.h): through film position (x, y) + at,
// `at` the sample's offset in the square of pixel (x, y) (the same in every
// square for one sample index: splat_offset), the square possibly outside
// the image. Dimension 0 is the offset's (drawn there); the lens sample as
// camera_sample's.
LUZ_INLINE Ray camera_sample_at(const Camera& cam, int x, int y, Sampler& sampler, Vec2 at) {
  const uint32_t d = sampler.dim++;
  const Vec2 u = cam.has_lens() ? sampler.aux_2d(d) : Vec2{0.5f, 0.5f};
  return cam.generate_ray(float(x) + at.x, float(y) + at.y, u);
}

}  // namespace luz
