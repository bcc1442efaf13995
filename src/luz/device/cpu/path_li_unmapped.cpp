#include "luz/device/cpu/path_li.h"

namespace luz {

Color path_li_cpu_unmapped(const SceneView& scene, const EmbreeTracer& tracer, const Ray& ray, Sampler& sampler,
                           const IntegratorParams& params, uint64_t& rays) {
  return path_li<EmbreeTracer, NoPathProbe, false>(scene, tracer, ray, sampler, params, rays);
}

}  // namespace luz
