// Scene loading: the format follows the extension (load.cpp); each reader
// calls a SceneBuilder (scene/scene_builder.h). Errors are InputError:
// "file:line: problem".
#pragma once

#include <map>
#include <string>
#include <vector>

#include "luz/scene/scene.h"

namespace luz {

using Defines = std::map<std::string, std::string>;

// By extension: .xml (Mitsuba), .pbrt (pbrt-v4), .gltf and .glb (glTF 2.0: io/gltf.h), .obj (OBJ/MTL), .ply.
// `search_paths`: folders where files a Mitsuba scene names are looked for
// when they are not beside it (Mitsuba's -a).
// `camera`: the camera to render by name (glTF files name theirs); "": the file's first.
Scene load_scene(const std::string& path, const Defines& defines = {}, const std::vector<std::string>& search_paths = {},
                 const std::string& camera = "");
Scene load_mitsuba(const std::string& path, const Defines& defines = {},
                   const std::vector<std::string>& search_paths = {});
// A mesh file as a scene (mesh_scene.cpp).
Scene load_obj_scene(const std::string& path);
Scene load_ply_scene(const std::string& path);
Scene load_pbrt(const std::string& path);

}  // namespace luz
