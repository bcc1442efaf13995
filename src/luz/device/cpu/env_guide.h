// The CPU device's environment guide (light/env_guide_build.h), built
// through Embree in a translation unit of its own: instantiated in
// render.cpp, the pilot's copy of the path code took from the inlining
// budget of the render loop's (callgrind, bundled box: +6.5% instructions in
// path_li, which has no guide to build).
#pragma once

#include "luz/accel/embree_tracer.h"
#include "luz/light/env_guide_build.h"

namespace luz {

EnvGuideData build_env_guide_embree(const SceneView& scene, const EmbreeTracer& tracer, const EnvGuideOptions& o);

}  // namespace luz
