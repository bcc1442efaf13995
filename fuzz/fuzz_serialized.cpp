// A Mitsuba .serialized mesh file: its first and second shapes.
#include "fuzz_common.h"
#include "luz/io/mesh_serialized.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  for (uint32_t shape : {0u, 1u})
    luz::fuzz::expect_input_error([&] { luz::read_serialized_memory("mesh.serialized", data, size, shape); });
  return 0;
}
