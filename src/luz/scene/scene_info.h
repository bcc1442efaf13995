// What a loaded scene holds, as `luz info` prints it: shapes, triangles,
// instances, lights and materials by type, the camera, film, integrator,
// sampler and every warning of the loader.
#pragma once

#include <string>

#include "luz/scene/scene.h"

namespace luz {

std::string describe_scene(const Scene& scene);

// The names the CLI and scene files use.
const char* filter_name(FilterKind k);
const char* integrator_name(IntegratorType t);
const char* sampler_name(SamplerType t);
const char* light_sampler_name(LightSamplerType t);

}  // namespace luz
