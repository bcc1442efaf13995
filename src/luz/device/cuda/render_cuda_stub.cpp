// The CUDA backend in a build without CUDA (LUZ_CUDA=OFF, or AUTO on a
// machine without nvcc): the same interface, so the CLI and the tests always
// link; there is never a device.
#include "luz/device/cuda/render_cuda.h"

#include "luz/io/error.h"

namespace luz {

namespace {
constexpr const char* kWhy = "built without CUDA (configure with -DLUZ_CUDA=ON on a machine with nvcc)";
}

CudaError::CudaError(Kind kind, const std::string& message)
    : std::runtime_error(InputError::one_line(message)), kind_(kind) {}

bool cuda_available(std::string* why) {
  if (why) *why = kWhy;
  return false;
}

std::string cuda_device_name() { return ""; }

Film render_cuda(const Scene&, const CudaRenderOptions&, RenderStats&) {
  throw CudaError(CudaError::Kind::Unavailable, kWhy);
}

void sample_bsdf_cuda(const Bsdf&, Vec3, uint64_t, uint32_t, std::vector<Vec3>&, std::vector<uint8_t>&) {
  throw CudaError(CudaError::Kind::Unavailable, kWhy);
}

double trace_rays_cuda(const Scene&, const std::vector<Ray>&, const std::vector<uint8_t>&, int, uint64_t*) {
  throw CudaError(CudaError::Kind::Unavailable, kWhy);
}

}  // namespace luz
