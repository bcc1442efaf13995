// The Mitsuba reader's top-level emitters (see parser.h).
#include <algorithm>
#include <cmath>

#include "luz/io/image.h"
#include "luz/io/mitsuba/parser.h"

namespace luz::mitsuba {

namespace {

// Embree's limit on a ray's origin and direction components (FLT_LARGE, 1.844e18).
// The rows of the inverse of m's linear part, (b × c, c × a, a × b) / det for
// its columns a, b, c (world -> local directions); false if it is degenerate.
bool inverse_rows(const Matrix4& m, Vec3& x, Vec3& y, Vec3& z) {
  const Vec3 a = m.vector({1, 0, 0}), b = m.vector({0, 1, 0}), c = m.vector({0, 0, 1});
  const float det = dot(a, cross(b, c));
  if (!(std::fabs(det) > 0.f) || !std::isfinite(det)) return false;
  x = cross(b, c) / det;
  y = cross(c, a) / det;
  z = cross(a, b) / det;
  return is_finite(x) && is_finite(y) && is_finite(z);
}

}  // namespace

void MitsubaParser::parse_emitter(pugi::xml_node n) {
  std::string type = attr(n, "type");
  check_children(n, {});
  Props p(this, n);
  auto non_negative = [&](Color c, const char* what) {
    for (int k = 0; k < 3; ++k)
      if (!(c[k] >= 0.f) || !std::isfinite(c[k])) error(n, std::string(what) + " must be finite and not negative");
    return c;
  };
  // A light's placement: `position` (point) or `direction` (directional),
  // or to_world; not both.
  auto placement = [&](const char* alternative) {
    if (p.has(alternative) && p.has("to_world"))
      error(n, std::string("give either '") + alternative + "' or 'to_world', not both");
    return p.get_transform("to_world");
  };
  auto finite_place = [&](Vec3 v, const char* what) {
    if (!is_finite(v) || max_abs(v) > kMaxCoordinate)
      error(n, std::string("the light's ") + what + " is not finite or lies beyond 1e18");
    return v;
  };
  if (type == "constant") {
    Color L = non_negative(p.get_color("radiance", {1, 1, 1}), "radiance");
    p.check_all_used();
    ConstantLight c;
    c.radiance = L;
    builder_.add_light(loc(n), c);
  } else if (type == "point") {
    PointLight l;
    l.intensity = non_negative(p.get_color("intensity", {1, 1, 1}), "intensity");
    Matrix4 to_world = placement("position");
    l.position = finite_place(p.has("position") ? p.get_point("position", {}) : to_world.point({0, 0, 0}), "position");
    p.check_all_used();
    builder_.add_light(loc(n), l);
  } else if (type == "spot") {
    SpotLight l;
    l.intensity = non_negative(p.get_color("intensity", {1, 1, 1}), "intensity");
    const double cutoff = p.get_float("cutoff_angle", 20.0);
    const double beam = p.get_float("beam_width", cutoff * 3.0 / 4.0);
    l.texture = texture_param(p, "texture");  // projected over the cutoff cone
    if (l.texture < 0 && p.has("texture")) p.get("texture", {"texture", "ref"});  // names the wrong type
    Matrix4 to_world = p.get_transform("to_world");
    p.check_all_used();
    if (!(cutoff > 0.0 && cutoff <= 90.0)) error(n, "cutoff_angle must be in (0, 90] degrees");
    if (!(beam > 0.0 && beam <= cutoff)) error(n, "beam_width must be in (0, cutoff_angle] degrees");
    l.position = finite_place(to_world.point({0, 0, 0}), "position");
    if (!inverse_rows(to_world, l.inv_x, l.inv_y, l.inv_z)) error(n, "the spot light's to_world is degenerate");
    l.set_cone(cutoff * M_PI / 180.0, beam * M_PI / 180.0, SpotFalloff::LinearAngle);
    builder_.add_light(loc(n), l);
  } else if (type == "directional") {
    DirectionalLight l;
    l.irradiance = non_negative(p.get_color("irradiance", {1, 1, 1}), "irradiance");
    Matrix4 to_world = placement("direction");
    Vec3 d = p.has("direction") ? p.get_point("direction", {}) : to_world.vector({0, 0, 1});
    p.check_all_used();
    const float len = length(d);
    if (!(len > 0.f) || !std::isfinite(len)) error(n, "the directional light's direction is zero or not finite");
    l.direction = d / len;
    builder_.add_light(loc(n), l);
  } else if (type == "envmap") {
    parse_envmap(n, p);
  } else {
    error(n, "unknown top-level emitter '" + type + "' (supported: constant, envmap, point, spot, directional)");
  }
}

void MitsubaParser::parse_envmap(pugi::xml_node n, Props& p) {
  const std::string file = p.get_string("filename", "");
  if (file.empty()) error(n, "envmap needs a 'filename'");
  const double scale = p.get_float("scale", 1.0);
  Matrix4 to_world = p.get_transform("to_world");
  p.check_all_used();
  if (!(scale >= 0.0) || !std::isfinite(scale)) error(n, "scale must be finite and not negative");
  const fs::path full = resolve_file(n, file, "envmap");
  Image img;
  try {
    img = read_image_linear(full.string());
  } catch (const InputError& e) {
    error(n, e.what());
  }
  EnvmapLight l;
  l.scale = float(scale);
  l.to_world_x = to_world.vector({1, 0, 0});
  l.to_world_y = to_world.vector({0, 1, 0});
  l.to_world_z = to_world.vector({0, 0, 1});
  if (!inverse_rows(to_world, l.to_local_x, l.to_local_y, l.to_local_z))
    error(n, "the envmap's to_world is degenerate");
  builder_.add_envmap(loc(n), l, img, file);
}

}  // namespace luz::mitsuba
