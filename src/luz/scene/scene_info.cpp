#include "luz/scene/scene_info.h"

#include <cmath>
#include <cstdio>
#include <map>

namespace luz {

namespace {

const char* light_name(LightType t) {
  switch (t) {
    case LightType::Triangle: return "area (triangle)";
    case LightType::Parallelogram: return "area (parallelogram)";
    case LightType::Sphere: return "area (sphere)";
    case LightType::Constant: return "constant environment";
    case LightType::Point: return "point";
    case LightType::Spot: return "spot";
    case LightType::Directional: return "directional";
    case LightType::Envmap: return "envmap";
  }
  return "?";
}

const char* bsdf_name(BsdfType t) {
  switch (t) {
    case BsdfType::Diffuse: return "diffuse";
    case BsdfType::Phong: return "phong";
    case BsdfType::SmoothConductor: return "conductor";
    case BsdfType::RoughConductor: return "roughconductor";
    case BsdfType::SmoothDielectric: return "dielectric";
    case BsdfType::RoughDielectric: return "roughdielectric";
    case BsdfType::ThinDielectric: return "thindielectric";
    case BsdfType::SmoothPlastic: return "plastic";
    case BsdfType::BlinnPhong: return "blinnphong";
    case BsdfType::Ward: return "ward";
    case BsdfType::RoughPlastic: return "roughplastic";
    case BsdfType::GltfPbr: return "gltf metallic-roughness";
    case BsdfType::GltfPbrTransmission: return "gltf metallic-roughness transmission";
    case BsdfType::Principled: return "principled";
    case BsdfType::PrincipledTransmission: return "principled (spec_trans)";
    case BsdfType::DiffuseTransmission: return "diffusetransmission";
    case BsdfType::PrincipledThin: return "principledthin";
  }
  return "?";
}

// "3 diffuse, 1 conductor" from counts by name.
std::string by_type(const std::map<std::string, size_t>& counts) {
  std::string s;
  for (const auto& [name, n] : counts) s += (s.empty() ? "" : ", ") + std::to_string(n) + " " + name;
  return s.empty() ? "none" : s;
}

std::string fmt(const char* f, double a, double b = 0, double c = 0) {
  char buf[128];
  std::snprintf(buf, sizeof buf, f, a, b, c);
  return buf;
}

}  // namespace

const char* filter_name(FilterKind k) { return k == FilterKind::Box ? "box" : k == FilterKind::Tent ? "tent" : "gaussian"; }
const char* integrator_name(IntegratorType t) {
  return t == IntegratorType::Path ? "path" : t == IntegratorType::Bsdf ? "bsdf" : "light";
}
const char* sampler_name(SamplerType t) {
  return t == SamplerType::Independent ? "independent" : t == SamplerType::Stratified ? "stratified" : "sobol";
}
const char* light_sampler_name(LightSamplerType t) { return t == LightSamplerType::Power ? "power" : "bvh"; }

// "1 sphere", "2 spheres", "0 spheres".
static std::string counted(uint64_t n, const char* what) { return std::to_string(n) + " " + what + (n == 1 ? "" : "s"); }

std::string describe_scene(const Scene& s) {
  std::string out;
  auto line = [&](const std::string& key, const std::string& value) { out += key + ": " + value + "\n"; };
  line("shapes", counted(s.num_triangles(), "triangle") + ", " + counted(s.spheres.size(), "sphere") + ", " +
                     counted(s.instances.size() + s.flattened_instances, "instance") +
                     (s.colors.empty() ? "" : ", with vertex colours"));
  if (!s.objects.empty() || s.flattened_instances > 0) {
    uint64_t stored = 0;
    for (const SceneObject& o : s.objects) stored += o.num_triangles;
    line("instancing", std::to_string(s.objects.size()) + " objects (" + std::to_string(stored) + " triangles) placed by " +
                           std::to_string(s.instances.size()) + " instances (" +
                           std::to_string(s.num_instanced_triangles()) + " triangles placed); " +
                           std::to_string(s.flattened_instances) + " placements flattened");
  }
  line("bounds", fmt("(%g, %g, %g)", s.bounds_min.x, s.bounds_min.y, s.bounds_min.z) + " to " +
                     fmt("(%g, %g, %g)", s.bounds_max.x, s.bounds_max.y, s.bounds_max.z));
  std::map<std::string, size_t> lights, materials;
  for (const Light& l : s.lights) {
    const bool two_sided = (l.type == LightType::Triangle && l.triangle.two_sided) ||
                           (l.type == LightType::Parallelogram && l.parallelogram.two_sided);
    std::string name = light_name(l.type);
    if (two_sided) name.insert(name.size() - 1, ", two-sided");  // "area (triangle, two-sided)"
    ++lights[name];
  }
  for (const Material& m : s.materials) {
    std::string name = bsdf_name(m.bsdf.type);
    if (m.bsdf.blend) name = "blend";
    else if (m.bsdf.two_sided) name += " (two-sided)";
    if (m.num_bindings > 0) name += " (textured)";
    if (m.masked()) name += " (masked)";
    ++materials[name];
  }
  line("lights", std::to_string(s.lights.size()) + ": " + by_type(lights));
  line("materials", std::to_string(s.materials.size()) + ": " + by_type(materials));
  line("textures", std::to_string(s.textures.size()));
  const Camera& c = s.camera;
  const char* cam = c.type == CameraType::ThinLens ? "thin lens" : c.type == CameraType::Orthographic ? "orthographic" : "perspective";
  std::string camera = std::string(cam) + fmt(" at (%g, %g, %g)", c.origin.x, c.origin.y, c.origin.z) +
                       fmt(" looking along (%g, %g, %g)", c.z_axis.x, c.z_axis.y, c.z_axis.z);
  if (c.type != CameraType::Orthographic)
    camera += fmt(", field of view %.4g° × %.4g°", 2 * std::atan(c.tan_half_x) * 180 / M_PI,
                  2 * std::atan(c.tan_half_y) * 180 / M_PI);
  if (c.type == CameraType::ThinLens)
    camera += fmt(", aperture radius %g, focus distance %g", c.lens.aperture_radius, c.lens.focus_distance);
  line("camera", camera);
  const RenderSettings& r = s.settings;
  const char* filter = filter_name(r.filter);
  line("film", std::to_string(c.width) + "×" + std::to_string(c.height) + ", " + filter + " filter" +
                   (splats(r.reconstruction, r.filter) ? ", splatted" : ""));
  const char* integ = integrator_name(r.integrator.type);
  line("integrator", std::string(integ) + ", max depth " +
                         (r.integrator.max_depth < 0 ? std::string("unbounded") : std::to_string(r.integrator.max_depth)) +
                         (r.integrator.hide_emitters ? ", emitters hidden from the camera (hide_emitters)" : ""));
  const char* sampler = sampler_name(r.sampler);
  line("sampler", std::string(sampler) + ", " + std::to_string(r.spp) + " spp, seed " + std::to_string(r.seed));
  line("warnings", std::to_string(s.warnings.size()));
  for (const std::string& w : s.warnings) out += "  " + w + "\n";
  return out;
}

}  // namespace luz
