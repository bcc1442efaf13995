// An MTL file, named by an OBJ that uses its materials, read by load_scene.
#include "fuzz_common.h"
#include "luz/io/load.h"

namespace {

const char kObj[] =
    "mtllib scene.mtl\n"
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\n"
    "usemtl a\nf 1/1/1 2/2/1 3/3/1\nusemtl b\nf 2/2/1 4/1/1 3/3/1\n";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string obj =
      luz::fuzz::write_file("scene.obj", reinterpret_cast<const uint8_t*>(kObj), sizeof(kObj) - 1);
  luz::fuzz::write_file("scene.mtl", data, size);
  luz::fuzz::expect_input_error([&] { luz::load_scene(obj); });
  return 0;
}
