// An 8-bit image through stb_image: PNG, JPEG, BMP or TGA (stb_image tells
// them by their bytes, whatever the extension), read as textures are
// (read_image8; environment maps add only a conversion to linear floats).
#include "fuzz_common.h"
#include "luz/io/image.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return luz::fuzz::read_file(data, size, "image.png", [](const std::string& path) { luz::read_image8(path); });
}
