// A Mitsuba XML scene, read as `luz render` reads it (load_scene).
#include "fuzz_common.h"
#include "luz/io/load.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return luz::fuzz::read_file(data, size, "scene.xml", [](const std::string& path) { luz::load_scene(path); });
}
