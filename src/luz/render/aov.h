// Auxiliary images for denoisers and analysis, of the first surface each
// camera ray meets: albedo and shading normal as Intel Open Image Denoise
// expects them, and camera depth. Each pixel's value is the mean over its
// first samples' camera rays (the render's own filter positions), so edges
// are antialiased as the beauty image is. Host only, on the CPU (Embree).
#pragma once

#include <cstdint>
#include <vector>

#include "luz/scene/scene.h"

namespace luz {

struct AovImages {
  int width = 0, height = 0;
  // RGB, 3 per pixel: the directional albedo ∫ f(wo, wi) |cos θi| dwi at the
  // hit (the reflectance of a Lambertian surface; about 1 for a clear mirror
  // or glass), estimated from BSDF samples; 0 where the ray leaves the scene.
  std::vector<float> albedo;
  // XYZ, 3 per pixel: the unit shading normal (normal and bump maps applied)
  // in world space, facing the camera; 0 where the ray leaves the scene.
  std::vector<float> normal;
  // 1 per pixel: the hit's distance along the camera's viewing axis (the
  // mean over the rays that hit), +inf where none did.
  std::vector<float> depth;
};

// Samples [0, samples) of each pixel, with `bsdf_samples` BSDF samples per
// hit for the albedo; threads 0: all cores.
AovImages render_aovs(const Scene& scene, uint32_t samples, uint32_t bsdf_samples = 16, int threads = 0);

}  // namespace luz
