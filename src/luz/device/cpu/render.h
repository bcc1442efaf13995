// Rendering on all CPU cores: TBB over 16×16 tiles, Embree for ray queries,
// the shared integrator for the rest.
#pragma once

#include <cstdint>

#include "luz/film/film.h"
#include "luz/scene/scene.h"

namespace luz {

struct RenderStats {
  double seconds = 0;
  uint64_t samples = 0, rays = 0, discarded = 0;
};

struct CpuRenderOptions {
  int threads = 0;        // 0: all cores
  bool progress = false;  // progress bar on stderr
};

Film render_cpu(const Scene& scene, const CpuRenderOptions& options, RenderStats& stats);

}  // namespace luz
