// The CPU's path loop (integrator/path.h through Embree) in two variants,
// each in a translation unit of its own: one for any scene, one for scenes
// without normal or bump maps (path_vertex's kMaps). Instantiated together
// in render.cpp, each took from the other's inlining budget (the frame's
// rotations, the warps and the light's sampling called out of line:
// bench/RESULTS.md, the bundled box against 951a034).
#pragma once

#include "luz/accel/embree_tracer.h"
#include "luz/integrator/path.h"

namespace luz {

Color path_li_cpu(const SceneView& scene, const EmbreeTracer& tracer, const Ray& ray, Sampler& sampler,
                  const IntegratorParams& params, uint64_t& rays);
// The same where MaterialsView::mapped is false.
Color path_li_cpu_unmapped(const SceneView& scene, const EmbreeTracer& tracer, const Ray& ray, Sampler& sampler,
                           const IntegratorParams& params, uint64_t& rays);

}  // namespace luz
