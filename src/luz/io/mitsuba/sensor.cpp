// The Mitsuba reader's integrator, sensor, sampler and film (see parser.h).
#include <cmath>

#include "luz/io/mitsuba/parser.h"

namespace luz::mitsuba {

// Mitsuba's integrators by the nearest Luz estimator: path, bsdf and light
// as themselves; volpath and volpathmis as path (Luz has no media, and a
// scene with a <medium> is refused where it names one); direct as path with
// max_depth 2 (the same expectation: emitters seen directly plus one bounce
// of direct light, MIS-weighted); any other (irrcache, photonmapper, bdpt,
// a mirror's path_guiding_integrator, ...) as path with a warning, since
// every Mitsuba integrator estimates the same image, only with other noise.
void MitsubaParser::parse_integrator(pugi::xml_node n) {
  const std::string type = attr(n, "type");
  IntegratorParams& ip = builder_.settings().integrator;
  const bool known = type == "path" || type == "bsdf" || type == "light" || type == "volpath" ||
                     type == "volpathmis" || type == "direct";
  if (!known) {
    // Its parameters and nested integrators mean nothing to path: only a
    // max_depth and hide_emitters (its own or a nested integrator's) are kept.
    ip.type = IntegratorType::Path;
    ip.max_depth = -1;
    for (pugi::xml_node c = n; c; c = c.child("integrator")) {
      for (pugi::xml_node q : c.children("integer"))
        if (param_name(q) == "max_depth" && ip.max_depth == -1) {
          const double d = number(q, attr(q, "value"));
          if (d == std::floor(d) && (d == -1 || (d >= 1 && d <= 1e9))) ip.max_depth = int(d);
        }
      for (pugi::xml_node q : c.children("boolean"))
        if (param_name(q) == "hide_emitters") ip.hide_emitters |= attr(q, "value") == "true";
    }
    builder_.warn(loc(n), "integrator '" + type + "' is not supported: rendered with path (max_depth " +
                              std::to_string(ip.max_depth) + ")");
    return;
  }
  check_children(n, {});
  Props p(this, n);
  ip.type = type == "bsdf" ? IntegratorType::Bsdf : type == "light" ? IntegratorType::Light : IntegratorType::Path;
  if (type == "direct") {
    // Mitsuba's direct spends emitter_samples light samples and bsdf_samples
    // bsdf samples at each camera ray's hit; path with max_depth 2 takes one
    // of each per sample: the same expectation, the noise of fewer samples.
    const long emitter_samples = p.get_int("emitter_samples", 1), bsdf_samples = p.get_int("bsdf_samples", 1);
    p.get_int("shading_samples", 1);  // Mitsuba 0.5: both counts at once
    if (emitter_samples < 0 || bsdf_samples < 0) error(n, "emitter_samples and bsdf_samples must be ≥ 0");
    ip.max_depth = 2;
    ip.rr_depth = 5;
    if (emitter_samples != 1 || bsdf_samples != 1)
      builder_.warn(loc(n), "integrator 'direct' is rendered as path with max_depth 2: one emitter and one bsdf "
                            "sample per pixel sample instead of " +
                                std::to_string(emitter_samples) + " and " + std::to_string(bsdf_samples) +
                                " (the same image, noisier per sample)");
  } else {
    ip.max_depth = int(p.get_int("max_depth", -1, -1, kMaxDepthLimit));
    ip.rr_depth = int(p.get_int("rr_depth", 5));
  }
  if (ip.max_depth < -1 || ip.max_depth == 0)
    error(n, "max_depth must be -1 (unbounded) or from 1 to " + std::to_string(kMaxDepthLimit));
  if (ip.rr_depth < 1) error(n, "rr_depth must be ≥ 1");
  ip.hide_emitters = p.get_bool("hide_emitters", false);
  // Mitsuba 0.5's strictNormals drops light whose geometric and shading
  // sides disagree; Luz's path tracer always does (path.h: the geometric
  // side test beside the shading frame's), so either value means that.
  p.get_bool("strict_normals", false);
  p.check_all_used();
}

void MitsubaParser::parse_sensor(pugi::xml_node n) {
  std::string type = attr(n, "type");
  Camera cam;
  if (type == "perspective") cam.type = CameraType::Perspective;
  else if (type == "thinlens") cam.type = CameraType::ThinLens;
  else if (type == "orthographic") cam.type = CameraType::Orthographic;
  else error(n, "unknown sensor '" + type + "' (supported: perspective, thinlens, orthographic)");
  const bool projective = cam.type != CameraType::Orthographic;
  check_children(n, {"sampler", "film"});
  Props p(this, n);
  double fov = 30.0, ppx = 0.0, ppy = 0.0;
  std::string axis = "x";
  if (projective) {
    // Mitsuba 3's parse_fov: a fov along fov_axis, or else a focal_length
    // ("<x>mm", default 50mm) on a 36 × 24 mm film, a diagonal field of view.
    if (p.has("fov") && p.has("focal_length")) error(n, "give either fov or focal_length, not both");
    if (p.has("fov")) {
      fov = p.get_float("fov", 30.0);
      axis = p.get_string("fov_axis", "x");
    } else {
      if (p.has("fov_axis")) error(p.get("fov_axis", {"string"}), "fov_axis applies to a fov (a focal_length's is diagonal)");
      const pugi::xml_node at = p.has("focal_length") ? p.get("focal_length", {"string"}) : n;
      std::string f = p.get_string("focal_length", "50mm");
      if (f.size() > 2 && f.compare(f.size() - 2, 2, "mm") == 0) f.resize(f.size() - 2);
      const double mm = number(at, f);
      if (!(mm > 0)) error(at, "focal_length must be a positive length in mm, as \"35mm\"");
      fov = 2.0 * std::atan(std::sqrt(36.0 * 36.0 + 24.0 * 24.0) / (2.0 * mm)) * 180.0 / M_PI;
      axis = "diagonal";
    }
    ppx = p.get_float("principal_point_offset_x", 0.0);
    ppy = p.get_float("principal_point_offset_y", 0.0);
    // Far beyond any real lens shift; keeps the rays' directions finite.
    if (std::fabs(ppx) > 1e6 || std::fabs(ppy) > 1e6) error(n, "principal_point_offset_x/y must lie in [-1e6, 1e6]");
  }
  Matrix4 to_world = p.get_transform("to_world");
  double near_clip = p.get_float("near_clip", 1e-2), far_clip = p.get_float("far_clip", 1e4);
  if (!(near_clip > 0 && far_clip > near_clip)) error(n, "need 0 < near_clip < far_clip");
  if (!(fov > 0 && fov < 180)) error(n, "fov must be in (0, 180) degrees");
  // Mitsuba's projective cameras all take focus_distance (default far_clip);
  // only the thin lens uses it.
  double focus = p.get_float("focus_distance", far_clip);
  if (!(focus > 0)) error(n, "focus_distance must be > 0");
  if (cam.type == CameraType::ThinLens) {
    // Required, as in Mitsuba.
    if (!p.has("aperture_radius")) error(n, "a thinlens sensor needs an aperture_radius");
    double radius = p.get_float("aperture_radius", 0.0);
    if (!(radius >= 0)) error(n, "aperture_radius must be ≥ 0");
    cam.lens.aperture_radius = float(radius);
    cam.lens.focus_distance = float(focus);
  }
  p.check_all_used();

  int width = 768, height = 576;
  // Mitsuba's defaults when the sensor names no sampler or film: 4 samples,
  // a 768×576 hdrfilm, a gaussian rfilter; but Luz's best sampler (sobol)
  // where Mitsuba would take `independent`, which the scene did not ask for.
  builder_.settings().sampler = SamplerType::Sobol;
  builder_.settings().spp = 4;
  builder_.settings().filter = FilterKind::Gaussian;
  if (std::distance(n.children("sampler").begin(), n.children("sampler").end()) > 1)
    error(n, "a sensor takes one <sampler>");
  if (std::distance(n.children("film").begin(), n.children("film").end()) > 1) error(n, "a sensor takes one <film>");
  for (pugi::xml_node c : n.children("sampler")) parse_sampler(c);
  long crop[4] = {0, 0, 0, 0};
  pugi::xml_node film;
  for (pugi::xml_node c : n.children("film")) parse_film(film = c, width, height, crop);
  cam.width = width;
  cam.height = height;
  double aspect = double(width) / height, t = std::tan(fov * M_PI / 360.0), tx, ty;
  if (!projective) tx = 1, ty = 1 / aspect;  // Mitsuba's orthographic film: [-1, 1] × [-1/aspect, 1/aspect]
  else if (axis == "x") tx = t, ty = t / aspect;
  else if (axis == "y") ty = t, tx = t * aspect;
  else if (axis == "diagonal") {
    double d = t / std::sqrt(1 + 1 / (aspect * aspect));
    tx = d, ty = d / aspect;
  } else if (axis == "smaller") (aspect > 1 ? (ty = t, tx = t * aspect) : (tx = t, ty = t / aspect));
  else if (axis == "larger") (aspect > 1 ? (tx = t, ty = t / aspect) : (ty = t, tx = t * aspect));
  else error(n, "fov_axis must be x, y, diagonal, smaller or larger");
  cam.tan_half_x = float(tx);
  cam.tan_half_y = float(ty);
  cam.edge_x = float(1 - 2 * ppx);
  cam.edge_y = float(1 - 2 * ppy);
  cam.z_axis = normalize(to_world.vector({0, 0, 1}));
  if (projective) {
    cam.x_axis = normalize(to_world.vector({1, 0, 0}));
    cam.y_axis = normalize(to_world.vector({0, 1, 0}));
    cam.origin = to_world.point({0, 0, 0});
  } else {
    // to_world's x and y scale the view: kept (orthographic.h).
    cam.x_axis = to_world.vector({1, 0, 0});
    cam.y_axis = to_world.vector({0, 1, 0});
    cam.origin = to_world.point({0, 0, float(near_clip)});
  }
  const FovAxis fov_axis = !projective || axis == "x" ? FovAxis::X
                           : axis == "y"                ? FovAxis::Y
                           : axis == "diagonal"         ? FovAxis::Diagonal
                           : axis == "smaller"          ? FovAxis::Smaller
                                                        : FovAxis::Larger;
  builder_.set_camera(loc(n), cam, fov_axis);  // the checks every format shares
  if (film && (crop[0] != 0 || crop[1] != width || crop[2] != 0 || crop[3] != height))
    builder_.crop_camera(loc(film), crop[0], crop[1], crop[2], crop[3]);
}

void MitsubaParser::parse_sampler(pugi::xml_node n) {
  std::string type = attr(n, "type");
  RenderSettings& s = builder_.settings();
  if (type == "independent") s.sampler = SamplerType::Independent;
  else if (type == "stratified") s.sampler = SamplerType::Stratified;
  else if (type == "sobol" || type == "ldsampler") s.sampler = SamplerType::Sobol;
  else error(n, "unknown sampler '" + type + "' (supported: independent, stratified, sobol)");
  check_children(n, {});
  Props p(this, n);
  long spp = p.get_int("sample_count", 4);
  // The command line's --spp bound (2^24), so that a scene cannot ask for
  // what the flag may not.
  if (spp < 1 || spp > (1 << 24)) error(n, "sample_count must be between 1 and 16777216 (2^24)");
  s.spp = uint32_t(spp);
  long seed = p.get_int("seed", 0);
  s.seed = uint64_t(seed);
  p.get_bool("jitter", true);
  p.get_int("dimension", 4);  // Mitsuba 0.5 ldsampler's low-discrepancy dimensions: a strategy only
  p.check_all_used();
}

void MitsubaParser::parse_film(pugi::xml_node n, int& width, int& height, long crop[4]) {
  std::string type = attr(n, "type");
  // ldrfilm differs from hdrfilm only in how the file is written (tone
  // mapping, gamma, 8 bits), and Luz picks the output format from -o's
  // extension: its formatting parameters are accepted and have no effect.
  if (type != "hdrfilm" && type != "ldrfilm") error(n, "unknown film '" + type + "' (supported: hdrfilm, ldrfilm)");
  check_children(n, {"rfilter"});
  Props p(this, n);
  long w = p.get_int("width", 768), h = p.get_int("height", 576);
  if (w < 1 || h < 1 || w > 65536 || h > 65536) error(n, "film size must be between 1 and 65536");
  width = int(w);
  height = int(h);
  // The crop window: only those pixels are rendered and written (the
  // output is crop_width × crop_height).
  const long cx = p.get_int("crop_offset_x", 0, 0, 65536), cy = p.get_int("crop_offset_y", 0, 0, 65536);
  const long cw = p.get_int("crop_width", w - cx, 1, 65536), ch = p.get_int("crop_height", h - cy, 1, 65536);
  crop[0] = cx, crop[1] = cx + cw, crop[2] = cy, crop[3] = cy + ch;
  p.get_string("file_format", "openexr");
  // hdrfilm's pixel and component formats shape .exr outputs (ExrFormat);
  // when the film names neither, Luz writes 32-bit RGB. Luz's film has no
  // coverage: an alpha channel is left out, with a warning.
  ExrFormat& exr = builder_.settings().exr_format;
  if (pugi::xml_node f = p.get("pixel_format", {"string"})) {
    const std::string pf = attr(f, "value");
    const std::string base = pf.size() > 6 && pf.ends_with("_alpha") ? pf.substr(0, pf.size() - 6) : pf;
    if (base == "rgb" || base == "rgba") exr.channels = ExrChannels::Rgb;
    else if (base == "luminance") exr.channels = ExrChannels::Luminance;
    else if (base == "xyz" || base == "xyza") exr.channels = ExrChannels::Xyz;
    else error(f, "pixel_format '" + pf + "' is not supported (luminance, luminance_alpha, rgb, rgba, xyz, xyza)");
    if (type == "ldrfilm") exr.channels = ExrChannels::Rgb;  // a PNG's format: RGB
    else if (base != pf || pf == "rgba" || pf == "xyza")
      builder_.warn(loc(f), "pixel_format '" + pf + "': Luz's film has no alpha; outputs are written without it");
  }
  if (type == "hdrfilm") {
    const std::string cf = p.get_string("component_format", "float32");
    if (cf == "float16") exr.half = true;
    else if (cf != "float32") error(n, "component_format '" + cf + "' is not supported (float16, float32)");
  }
  if (type == "ldrfilm") p.get_float("gamma", -1.0);  // the PNG encoding's gamma (-1: sRGB)
  p.get_bool("banner", false);
  p.get_bool("high_quality_edges", false);
  p.check_all_used();
  if (std::distance(n.children("rfilter").begin(), n.children("rfilter").end()) > 1)
    error(n, "a film takes one <rfilter>");
  for (pugi::xml_node r : n.children("rfilter")) {
    std::string ft = attr(r, "type");
    check_children(r, {});
    Props rp(this, r);
    if (ft == "box") builder_.settings().filter = FilterKind::Box;
    else if (ft == "tent") builder_.settings().filter = FilterKind::Tent;
    else if (ft == "gaussian") {
      builder_.settings().filter = FilterKind::Gaussian;
      double sd = rp.get_float("stddev", 0.5);
      if (sd != 0.5) error(r, "only the default gaussian stddev 0.5 is supported");
    } else {
      error(r, "unknown rfilter '" + ft + "' (supported: box, tent, gaussian)");
    }
    rp.check_all_used();
  }
}

}  // namespace luz::mitsuba
