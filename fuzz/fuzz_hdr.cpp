// A Radiance HDR image (stb_image), read as textures and environment maps are (read_image_linear).
#include "fuzz_common.h"
#include "luz/io/image.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return luz::fuzz::read_file(data, size, "image.hdr", [](const std::string& path) { luz::read_image_linear(path); });
}
