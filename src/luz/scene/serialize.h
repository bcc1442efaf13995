// A loaded Scene as bytes and back: what an MPI job's rank 0 sends the
// other ranks when the scene's files exist only on its machine
// (luz render --broadcast). The same machine kind on both ends (the bytes
// are the host's own layout); host only.
#pragma once

#include <string>

#include "luz/scene/scene.h"

namespace luz {

std::string serialize_scene(const Scene& scene);
// Throws std::runtime_error for bytes that are not a whole serialized scene.
Scene deserialize_scene(const std::string& bytes);

}  // namespace luz
