#include "luz/device/cpu/env_guide.h"

namespace luz {

EnvGuideData build_env_guide_embree(const SceneView& scene, const EmbreeTracer& tracer, const EnvGuideOptions& o) {
  return build_env_guide(scene, tracer, o);
}

}  // namespace luz
