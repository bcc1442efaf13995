// What a loaded scene holds, as `luz info` prints it: shapes, triangles,
// instances, lights and materials by type, the camera, film, integrator,
// sampler and every warning of the loader.
#pragma once

#include <string>

#include "luz/scene/scene.h"

namespace luz {

std::string describe_scene(const Scene& scene);

}  // namespace luz
