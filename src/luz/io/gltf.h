// glTF 2.0 scenes (.gltf with external or embedded buffers and images, and
// binary .glb), read with Debian's tinygltf. What is read and how it maps
// onto Luz is listed at the top of gltf.cpp. Errors are InputError naming
// the file and the glTF object ("file: meshes[2].primitives[0]: problem").
#pragma once

#include <string>

#include "luz/scene/scene.h"

namespace luz {

Scene load_gltf(const std::string& path, const std::string& camera = "");

}  // namespace luz
