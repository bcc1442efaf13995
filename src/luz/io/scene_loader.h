// Scene loading: Mitsuba 3 XML (pugixml) and OBJ/MTL (tinyobjloader), chosen
// by extension. Errors are InputError: "file:line: problem".
#pragma once

#include <map>
#include <string>

#include "luz/scene/scene.h"

namespace luz {

using Defines = std::map<std::string, std::string>;

Scene load_scene(const std::string& path, const Defines& defines = {});
Scene load_mitsuba(const std::string& path, const Defines& defines = {});
Scene load_obj_scene(const std::string& path);

}  // namespace luz
