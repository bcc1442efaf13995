// Scene loading: Mitsuba 3 XML (pugixml) and OBJ/MTL (tinyobjloader), chosen
// by extension. Errors are InputError: "file:line: problem".
#pragma once

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "luz/scene/scene.h"

namespace luz {

using Defines = std::map<std::string, std::string>;

// Embree's limit on a ray's origin and direction components (FLT_LARGE,
// 1.844e18): what loaders hold positions, cameras and lights to.
constexpr float kMaxCoordinate = 1e18f;
inline float max_abs(Vec3 v) { return std::max({std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)}); }

Scene load_scene(const std::string& path, const Defines& defines = {});
Scene load_mitsuba(const std::string& path, const Defines& defines = {});
Scene load_obj_scene(const std::string& path);
// Compiles the scene and sets a 512² camera that frames its bounds from +z
// (loaders of formats without a camera); path names the file in errors.
void frame_bounds(Scene& scene, const std::string& path);

}  // namespace luz
