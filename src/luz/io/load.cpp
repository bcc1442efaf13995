#include "luz/io/load.h"

#include <filesystem>

#include "luz/io/error.h"
#include "luz/io/image.h"
#include "luz/io/gltf.h"

namespace luz {

Scene load_scene(const std::string& path, const Defines& defines, const std::vector<std::string>& search_paths,
                 const std::string& camera) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(path, 0, "cannot open file: no such file");
  const std::string e = lower_extension(path);
  if (!camera.empty() && e != ".gltf" && e != ".glb")
    throw InputError(path, 0, "--camera " + camera + ": only glTF files name their cameras; this file has one");
  if (e == ".xml") return load_mitsuba(path, defines, search_paths);
  if (!defines.empty()) throw InputError(path, 0, "-D applies to Mitsuba XML scenes only");
  if (!search_paths.empty()) throw InputError(path, 0, "-a applies to Mitsuba XML scenes only");
  if (e == ".obj") return load_obj_scene(path);
  if (e == ".ply") return load_ply_scene(path);
  if (e == ".pbrt") return load_pbrt(path);
  if (e == ".gltf" || e == ".glb") return load_gltf(path, camera);
  throw InputError(path, 0, "unknown scene format '" + e + "' (supported: .xml, .pbrt, .gltf, .glb, .obj, .ply)");
}

}  // namespace luz
