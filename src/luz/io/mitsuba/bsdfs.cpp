// The Mitsuba reader's bsdfs: every model, its parameters and the adapters (twosided, blendbsdf, mask, normalmap, bumpmap) (see parser.h).
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "luz/io/mitsuba/parser.h"

namespace luz::mitsuba {

Color MitsubaParser::checked_reflectance(pugi::xml_node n, Props& p, const char* name, Color def) {
  Color c = p.get_color(name, def);
  for (int k = 0; k < 3; ++k)
    if (c[k] < 0.f || c[k] > 1.f) error(n, std::string("'") + name + "' must lie in [0, 1]");
  return c;
}

MicrofacetType MitsubaParser::distribution(pugi::xml_node n, Props& p) {
  std::string d = p.get_string("distribution", "beckmann");
  if (d == "beckmann") return MicrofacetType::Beckmann;
  if (d == "ggx") return MicrofacetType::GGX;
  error(n, "unknown distribution '" + d + "' (supported: beckmann, ggx)");
}

void MitsubaParser::roughness(pugi::xml_node n, Props& p, float& au, float& av, std::vector<TextureBinding>* tb) {
  p.get_bool("sample_visible", true);  // a sampling strategy only: the image's expectation is the same
  bool iso = p.has("alpha"), aniso = p.has("alpha_u") || p.has("alpha_v");
  if (iso && aniso) error(n, "give either 'alpha' or 'alpha_u' and 'alpha_v', not both");
  if (aniso && !(p.has("alpha_u") && p.has("alpha_v"))) error(n, "'alpha_u' and 'alpha_v' must be given together");
  for (const char* name : {"alpha", "alpha_u", "alpha_v"}) {
    auto it = p.by_name.find(name);
    if (!tb && it != p.by_name.end() && (std::string(it->second.name()) == "texture" || std::string(it->second.name()) == "ref"))
      error(it->second, std::string("'") + name + "' cannot take a texture here (a constant roughness, as in Mitsuba 3)");
  }
  std::vector<TextureBinding> none;
  std::vector<TextureBinding>& b = tb ? *tb : none;
  const size_t before = b.size();
  float a = float_param(p, "alpha", 0.1f, {BsdfParam::AlphaU, BsdfParam::AlphaV}, b);
  au = iso ? a : float_param(p, "alpha_u", 0.1f, {BsdfParam::AlphaU}, b);
  av = iso ? a : float_param(p, "alpha_v", 0.1f, {BsdfParam::AlphaV}, b);
  if (b.size() == before && (!(au > 0.f) || !(av > 0.f)))
    error(n, "roughness (alpha, alpha_u, alpha_v) must be positive");
}

float MitsubaParser::ior(pugi::xml_node n, Props& p, const char* name, const char* def) {
  pugi::xml_node c = p.get(name, {"float", "integer", "string"});
  float v = 0.f;
  if (!c) {
    find_ior_preset(def, v);
    return v;
  }
  std::string text = attr(c, "value");
  if (std::string(c.name()) == "string") {
    if (!find_ior_preset(text.c_str(), v)) error(c, "unknown index of refraction preset '" + text + "'");
  } else {
    v = float(number(c, text));
  }
  // Real dielectrics lie within about [1, 4]; far outside, the models'
  // Fresnel terms overflow (plastic's internal reflectance reaches 1 at a
  // ratio near 1000: every sample NaN).
  if (!(v >= 0.1f && v <= 10.f)) error(n, std::string("'") + name + "' must lie in [0.1, 10] (an index of refraction)");
  return v;
}

void MitsubaParser::conductor_ior(pugi::xml_node n, Props& p, Color& eta, Color& k, std::vector<TextureBinding>& tb) {
  bool explicit_ior = p.has("eta") || p.has("k");
  if (explicit_ior && p.has("material")) error(n, "give either 'material' or 'eta' and 'k', not both");
  if (explicit_ior) {
    eta = color_param(n, p, "eta", {0.f, 0.f, 0.f}, BsdfParam::Eta, false, tb);
    k = color_param(n, p, "k", {1.f, 1.f, 1.f}, BsdfParam::K, false, tb);
    for (int c = 0; c < 3; ++c)
      if (eta[c] < 0.f || k[c] < 0.f) error(n, "conductor 'eta' and 'k' must not be negative");
    return;
  }
  std::string m = p.get_string("material", "none");
  if (!find_conductor_preset(m.c_str(), eta, k)) {
    std::string names;
    for (const ConductorPreset& c : kConductorPresets) names += std::string(names.empty() ? "" : ", ") + c.name;
    error(n, "unknown conductor material '" + m + "' (supported: " + names + ")");
  }
}

ParsedBsdf MitsubaParser::nested_bsdf(pugi::xml_node c) {
  if (std::string(c.name()) != "ref") return parse_bsdf_value(c);
  return builder_.material(resolve_ref(c));
}

std::vector<pugi::xml_node> MitsubaParser::nested_bsdf_nodes(pugi::xml_node n) {
  std::vector<pugi::xml_node> inner;
  for (pugi::xml_node c : n.children())
    if (c.type() == pugi::node_element &&
        (std::string(c.name()) == "bsdf" || (std::string(c.name()) == "ref" && !is_texture_ref(c))))
      inner.push_back(c);
  return inner;
}

void MitsubaParser::move_part(std::vector<TextureBinding>& b, BsdfPart from, BsdfPart to) {
  for (TextureBinding& t : b)
    if (t.part == from) t.part = to;
}

ParsedBsdf MitsubaParser::parse_bsdf_element(pugi::xml_node n) {
  // Nested bsdfs (bumpmap, twosided, blendbsdf) recurse: bound the depth so
  // that a deep nesting is an error rather than a stack overflow.
  struct Depth {
    int& d;
    explicit Depth(int& depth) : d(++depth) {}
    ~Depth() { --d; }
  } depth(bsdf_depth_);
  if (bsdf_depth_ > kMaxBsdfNesting) error(n, "bsdfs nested more than " + std::to_string(kMaxBsdfNesting) + " deep");
  std::string type = attr(n, "type");
  if (type == "normalmap" || type == "bumpmap") {
    // Mitsuba 3's adapters: a texture perturbs the shading frame, one nested
    // bsdf is evaluated in the perturbed frame (SceneView::perturbed_frame).
    // normalmap: the texture `normalmap`, raw (its texels are vectors);
    // bumpmap: one texture of any name (the height: its luminance) and
    // `scale`. Luz holds one map per material, around the whole of it: the
    // map may wrap any bsdf, twosided and blendbsdf included, but a map
    // inside a twosided, a blendbsdf or another map is refused below.
    const bool bump = type == "bumpmap";
    check_children(n, {"bsdf", "ref"});
    Props p(this, n);
    std::string map = "normalmap";
    if (bump) {
      std::vector<std::string> names;
      for (const auto& [name, c] : p.by_name)
        if (std::string(c.name()) == "texture" || std::string(c.name()) == "ref") names.push_back(name);
      if (names.size() != 1) error(n, "bumpmap needs exactly one nested texture (the height map)");
      map = names[0];
    }
    const int32_t t = texture_param(p, map.c_str());
    if (t < 0) error(n, type + " needs a <texture name=\"" + map + "\">");
    const float scale = bump ? float(p.get_float("scale", 1.0)) : 1.f;
    p.check_all_used();
    if (!std::isfinite(scale)) error(n, "bumpmap 'scale' must be finite");
    const Texture& tex = builder_.scene().textures[size_t(t)];
    if (!bump && tex.type == TextureType::Bitmap && !tex.bitmap.is_float && tex.bitmap.srgb)
      error(n, "the normalmap bitmap must be raw (<boolean name=\"raw\" value=\"true\"/>): its texels are "
               "vectors, not sRGB colours");
    if (bump && tex.type != TextureType::Bitmap)
      error(n, "bumpmap needs a bitmap height map (a checkerboard has no gradient)");
    std::vector<pugi::xml_node> inner = nested_bsdf_nodes(n);
    if (inner.size() != 1) error(n, type + " needs exactly one nested bsdf");
    ParsedBsdf b = nested_bsdf(inner[0]);
    if (b.has_map()) error(inner[0], "a normalmap or bumpmap inside another is not supported");
    (bump ? b.bump_map : b.normal_map) = t;
    b.bump_scale = scale;
    return b;
  }
  if (type == "coating") return parse_coating(n);
  if (type == "mask") {
    // Mitsuba 3's mask: `opacity` (a number or a texture's luminance, in
    // [0, 1]) over one nested bsdf, traced as alpha-tested geometry
    // (material/opacity.h). A mask wraps any bsdf (twosided, blendbsdf);
    // inside a blendbsdf, a two-sided twosided or another mask it is
    // refused (an opacity per part is not an alpha test).
    check_children(n, {"bsdf", "ref"});
    Props p(this, n);
    int32_t t = -1;
    const float a = unit_param(n, p, "mask", "opacity", 0.5f, t);
    p.check_all_used();
    std::vector<pugi::xml_node> inner = nested_bsdf_nodes(n);
    if (inner.size() != 1) error(n, "mask needs exactly one nested bsdf");
    ParsedBsdf out = nested_bsdf(inner[0]);
    if (out.masked()) error(inner[0], "a mask inside a mask is not supported");
    out.opacity = a;
    out.opacity_texture = t;
    return out;
  }
  if (type == "twosided") {
    // Mitsuba 3: one nested bsdf for both sides, or two: the first for the
    // front, the second for the back.
    check_children(n, {"bsdf", "ref"});
    Props p(this, n);
    p.check_all_used();
    std::vector<pugi::xml_node> inner = nested_bsdf_nodes(n);
    if (inner.size() != 1 && inner.size() != 2) error(n, "twosided needs one or two nested bsdfs");
    ParsedBsdf sides[2];
    for (size_t i = 0; i < inner.size(); ++i) {
      if (std::string(inner[i].name()) == "bsdf" && attr(inner[i], "type") == "twosided")
        error(inner[i], "twosided cannot wrap another twosided");
      sides[i] = nested_bsdf(inner[i]);
      if (sides[i].bsdf.has_back) error(inner[i], "twosided cannot wrap another twosided");
      // One map per material, on both sides: Mitsuba's twosided would
      // mirror a map inside it on the back, Luz's map outside does not.
      if (sides[i].has_map())
        error(inner[i], "a normalmap or bumpmap inside a twosided is not supported (put the twosided inside the map)");
      // Mitsuba 3's twosided refuses transmissive materials ("Only materials
      // without a transmission component can be nested!"): dielectrics are
      // two-sided by nature.
      if (sides[i].bsdf.has_transmission())
        error(inner[i], "twosided cannot wrap a material that transmits light (a dielectric)");
      if (inner.size() == 2 && sides[i].masked())
        error(inner[i], "a mask as one side of a twosided is not supported (wrap the twosided in the mask)");
    }
    if (inner.size() == 1) {
      sides[0].bsdf.two_sided = true;
      return sides[0];
    }
    if (sides[1].bsdf.blend)
      error(inner[1], "a blendbsdf as the back side of a twosided is not supported (only as the front)");
    ParsedBsdf out{Bsdf::make_two_sided(sides[0].bsdf, sides[1].bsdf), sides[0].bindings};
    move_part(sides[1].bindings, BsdfPart::Front, BsdfPart::Back);
    out.bindings.insert(out.bindings.end(), sides[1].bindings.begin(), sides[1].bindings.end());
    return out;
  }
  if (type == "blendbsdf") {
    check_children(n, {"bsdf", "ref"});
    Props p(this, n);
    int32_t weight_texture = -1;
    const float w = unit_param(n, p, "blendbsdf", "weight", 0.5f, weight_texture);
    p.check_all_used();
    std::vector<pugi::xml_node> inner = nested_bsdf_nodes(n);
    if (inner.size() != 2) error(n, "blendbsdf needs exactly two nested bsdfs");
    ParsedBsdf a = nested_bsdf(inner[0]), b = nested_bsdf(inner[1]);
    if (a.masked() || b.masked()) error(n, "a mask inside a blendbsdf is not supported (wrap the blend in the mask)");
    if (a.bsdf.blend || b.bsdf.blend) error(n, "a blendbsdf inside a blendbsdf is not supported");
    if (a.has_map() || b.has_map())
      error(n, "a normalmap or bumpmap inside a blendbsdf is not supported (put the blendbsdf inside the map)");
    if (a.bsdf.has_back || b.bsdf.has_back)
      error(n, "a twosided with two different bsdfs inside a blendbsdf is not supported");
    if (a.bsdf.two_sided != b.bsdf.two_sided)
      error(n, "the two bsdfs of a blendbsdf must both be twosided or both not (wrap the blend in twosided)");
    ParsedBsdf out{Bsdf::make_blend(a.bsdf, b.bsdf, w), a.bindings};
    move_part(b.bindings, BsdfPart::Front, BsdfPart::Second);
    out.bindings.insert(out.bindings.end(), b.bindings.begin(), b.bindings.end());
    if (weight_texture >= 0) out.bindings.push_back({weight_texture, BsdfPart::BlendWeight});
    return out;
  }
  check_children(n, {});
  Props p(this, n);
  ParsedBsdf out;
  std::vector<TextureBinding>& tb = out.bindings;
  Bsdf& b = out.bsdf;
  auto reflectance = [&](const char* name, Color def, BsdfParam param) {
    return color_param(n, p, name, def, param, true, tb);
  };
  // Phong-like sums: k_d + k_s ≤ 1 wherever the textures reach (their maxima).
  auto check_sum = [&](Color kd, Color ks) {
    const Color dmax = texture_max(tb, BsdfParam::DiffuseReflectance, kd),
                smax = texture_max(tb, BsdfParam::SpecularReflectance, ks);
    for (int k = 0; k < 3; ++k)
      if (dmax[k] + smax[k] > 1.f)
        error(n, "diffuse_reflectance + specular_reflectance > 1: the material would create energy");
  };
  if (type == "diffuse") {
    b = Bsdf::make_diffuse(reflectance("reflectance", {0.5f, 0.5f, 0.5f}, BsdfParam::Reflectance), false);
  } else if (type == "phong" || type == "blinnphong") {  // the same parameters (Mitsuba 0.6's)
    Color kd = reflectance("diffuse_reflectance", {0.5f, 0.5f, 0.5f}, BsdfParam::DiffuseReflectance);
    Color ks = reflectance("specular_reflectance", {0.2f, 0.2f, 0.2f}, BsdfParam::SpecularReflectance);
    float e = float_param(p, "exponent", 30.f, {BsdfParam::Exponent}, tb);
    if (!(e >= 0.f)) error(n, "exponent must be ≥ 0");
    check_sum(kd, ks);
    b = type == "phong" ? Bsdf::make_phong(kd, ks, e, false) : Bsdf::make_blinn_phong(kd, ks, e, false);
  } else if (type == "conductor" || type == "roughconductor") {
    Color eta, k;
    conductor_ior(n, p, eta, k, tb);
    // Mitsuba 0.5's extEta: the exterior medium's index; eta and k are relative to it.
    float ext_eta = legacy_names_ ? ior(n, p, "ext_eta", "vacuum") : 1.f;  // not a Mitsuba 3 parameter
    if (ext_eta != 1.f && !tb.empty()) error(n, "textured 'eta' or 'k' with 'ext_eta' is not supported");
    eta = eta / ext_eta;
    k = k / ext_eta;
    Color spec = reflectance("specular_reflectance", {1.f, 1.f, 1.f}, BsdfParam::SpecularReflectance);
    if (type == "conductor") {
      b = Bsdf::make_smooth_conductor(eta, k, spec, false);
    } else {
      MicrofacetType d = distribution(n, p);
      float au, av;
      roughness(n, p, au, av, &tb);
      b = Bsdf::make_rough_conductor(d, au, av, eta, k, spec, false);
    }
  } else if (type == "dielectric" || type == "roughdielectric" || type == "thindielectric") {
    float int_ior = ior(n, p, "int_ior", "bk7"), ext_ior = ior(n, p, "ext_ior", "air");
    Color r = reflectance("specular_reflectance", {1.f, 1.f, 1.f}, BsdfParam::SpecularReflectance);
    Color t = reflectance("specular_transmittance", {1.f, 1.f, 1.f}, BsdfParam::SpecularTransmittance);
    if (type == "dielectric") {
      b = Bsdf::make_smooth_dielectric(int_ior, ext_ior, r, t);
    } else if (type == "thindielectric") {
      b = Bsdf::make_thin_dielectric(int_ior, ext_ior, r, t);
    } else {
      MicrofacetType d = distribution(n, p);
      float au, av;
      roughness(n, p, au, av, &tb);
      if (int_ior == ext_ior) error(n, "roughdielectric needs int_ior != ext_ior (nothing would refract)");
      b = Bsdf::make_rough_dielectric(d, au, av, int_ior, ext_ior, r, t);
    }
  } else if (type == "plastic") {
    Color kd = reflectance("diffuse_reflectance", {0.5f, 0.5f, 0.5f}, BsdfParam::DiffuseReflectance);
    Color ks = reflectance("specular_reflectance", {1.f, 1.f, 1.f}, BsdfParam::SpecularReflectance);
    float int_ior = ior(n, p, "int_ior", "polypropylene"), ext_ior = ior(n, p, "ext_ior", "air");
    bool nonlinear = p.get_bool("nonlinear", false);
    b = Bsdf::make_smooth_plastic(kd, ks, int_ior, ext_ior, false, nonlinear);
  } else if (type == "roughplastic") {
    Color kd = reflectance("diffuse_reflectance", {0.5f, 0.5f, 0.5f}, BsdfParam::DiffuseReflectance);
    Color ks = reflectance("specular_reflectance", {1.f, 1.f, 1.f}, BsdfParam::SpecularReflectance);
    float int_ior = ior(n, p, "int_ior", "polypropylene"), ext_ior = ior(n, p, "ext_ior", "air");
    bool nonlinear = p.get_bool("nonlinear", false);
    MicrofacetType d = distribution(n, p);
    float au, av;
    // As Mitsuba 3: a constant roughness (the coat's tables depend on it),
    // isotropic, and two indices that differ.
    roughness(n, p, au, av, nullptr);
    if (au != av) error(n, "roughplastic supports isotropic roughness only (alpha_u = alpha_v)");
    if (int_ior == ext_ior) error(n, "roughplastic needs int_ior != ext_ior");
    b = Bsdf::make_rough_plastic(d, au, kd, ks, int_ior, ext_ior, nonlinear, false);
  } else if (type == "ward") {
    std::string v = p.get_string("variant", "balanced");
    WardVariant variant = WardVariant::Balanced;
    if (v == "ward") variant = WardVariant::Ward;
    else if (v == "ward-duer") variant = WardVariant::WardDuer;
    else if (v != "balanced") error(n, "unknown ward variant '" + v + "' (supported: ward, ward-duer, balanced)");
    float au = float_param(p, "alpha_u", 0.1f, {BsdfParam::AlphaU}, tb);
    float av = float_param(p, "alpha_v", 0.1f, {BsdfParam::AlphaV}, tb);
    if (!(au > 0.f) || !(av > 0.f)) error(n, "roughness (alpha_u, alpha_v) must be positive");
    Color kd = reflectance("diffuse_reflectance", {0.5f, 0.5f, 0.5f}, BsdfParam::DiffuseReflectance);
    Color ks = reflectance("specular_reflectance", {0.2f, 0.2f, 0.2f}, BsdfParam::SpecularReflectance);
    check_sum(kd, ks);
    b = Bsdf::make_ward(variant, kd, ks, au, av, false);
  } else if (type == "principled" || type == "principledthin") {
    b = principled(n, p, tb, type == "principledthin");
  } else {
    error(n, "unknown bsdf '" + type +
                 "' (supported: diffuse, phong, blinnphong, conductor, roughconductor, dielectric, "
                 "roughdielectric, thindielectric, plastic, roughplastic, ward, principled, principledthin, blendbsdf, "
                 "twosided, mask, normalmap, bumpmap)");
  }
  p.check_all_used();
  return out;
}

// Mitsuba 3's principled and principledthin (principled.h): every parameter
// but eta, specular and the sampling rates a number or a texture, in [0, 1]
// as Mitsuba 3's documentation asks (principledthin's diff_trans in
// [0, 2]); a float texture straying outside [0, 1] is clamped there, with
// a warning (Mitsuba uses such texels as they are). principled: spec_trans given as a texture or a non-zero number
// makes the material transmissive (Mitsuba's m_has_spec_trans), and then an
// eta of 1 becomes 1.001 and a specular of 0 becomes 1e-3, as there.
// principledthin: eta a number or a texture. Sampling rates of 0 become
// 0.01: Mitsuba 3 would leave a lobe unsampled (principled's refraction:
// light through the surface lost), or divide by 0.
Bsdf MitsubaParser::principled(pugi::xml_node n, Props& p, std::vector<TextureBinding>& tb, bool thin) {
  const char* plugin = thin ? "principledthin" : "principled";
  // A float parameter in [0, 1]: a number (outside it: an error), or a
  // texture bound to `param`, whose texels are clamped to [0, 1] where they
  // stray (float images of roughness or metal, a warning says so).
  auto unit = [&](const char* name, float def, BsdfParam param, bool* given = nullptr) {
    const int32_t t = texture_param(p, name);
    if (given) *given = t >= 0;
    if (t < 0) {
      const float v = float(p.get_float(name, def));
      if (!(v >= 0.f && v <= 1.f)) error(n, std::string(plugin) + " '" + name + "' must lie in [0, 1]");
      if (given) *given = v != 0.f;
      return v;
    }
    const TextureStats& st = builder_.texture_stats(t);
    const bool outside = std::min({st.min.x, st.min.y, st.min.z}) < 0.f || max_component(st.max) > 1.f;
    if (outside)
      builder_.warn(loc(n), std::string(plugin) + " '" + name +
                                "' texture has texels outside [0, 1]: clamped to [0, 1] where looked up");
    tb.push_back({t, BsdfPart::Front, param, outside ? TextureMap::Clamp01 : TextureMap::Identity});
    return std::clamp(luminance(st.mean), 0.f, 1.f);
  };
  // Sampling weights: they change the noise, not the image.
  auto rate = [&](const char* name, float& r) {
    const double v = p.get_float(name, 1.0);
    if (!(v >= 0.0 && v < 1e6)) error(n, std::string(plugin) + " '" + name + "' must be a finite number ≥ 0");
    r = v > 0.0 ? float(v) : 1e-2f;
    if (v == 0.0) builder_.warn(loc(n), std::string(plugin) + " '" + name + "' 0: the lobe is still sampled, at weight 0.01");
  };
  // A float parameter in [lo, hi]: a number, or a texture bound to `param`.
  auto ranged = [&](const char* name, float def, float lo, float hi, BsdfParam param) {
    const int32_t t = texture_param(p, name);
    const std::string what = std::string(plugin) + " '" + name + "'";
    char range[48];
    std::snprintf(range, sizeof range, " must lie in [%g, %g]", double(lo), double(hi));
    if (t < 0) {
      const float v = float(p.get_float(name, def));
      if (!(v >= lo && v <= hi)) error(n, what + range);
      return v;
    }
    const TextureStats& st = builder_.texture_stats(t);
    if (!(std::min({st.min.x, st.min.y, st.min.z}) >= lo && max_component(st.max) <= hi))
      error(n, what + " texture's texels" + range);
    tb.push_back({t, BsdfPart::Front, param});
    return luminance(st.mean);
  };
  PrincipledThinBsdf q;
  q.base_color = color_param(n, p, "base_color", {.5f, .5f, .5f}, BsdfParam::BaseColor, true, tb);
  q.roughness = unit("roughness", .5f, BsdfParam::Roughness);
  q.anisotropic = unit("anisotropic", 0.f, BsdfParam::Anisotropic);
  bool transmits = false;
  q.spec_trans = unit("spec_trans", 0.f, BsdfParam::Transmission, &transmits);
  q.spec_tint = unit("spec_tint", 0.f, BsdfParam::SpecularTint);
  q.sheen = unit("sheen", 0.f, BsdfParam::Sheen);
  q.sheen_tint = unit("sheen_tint", 0.f, BsdfParam::SheenTint);
  q.flatness = unit("flatness", 0.f, BsdfParam::Flatness);
  if (thin) {
    q.diff_trans = ranged("diff_trans", 0.f, 0.f, 2.f, BsdfParam::DiffuseTransmission);
    q.eta = ranged("eta", 1.5f, 0.1f, 10.f, BsdfParam::Eta);
    rate("specular_reflectance_sampling_rate", q.spec_rate);
    rate("specular_transmittance_sampling_rate", q.spec_trans_rate);
    rate("diffuse_reflectance_sampling_rate", q.diffuse_rate);
    rate("diffuse_transmittance_sampling_rate", q.diff_trans_rate);
    return Bsdf::make_principled_thin(q);
  }
  q.metallic = unit("metallic", 0.f, BsdfParam::Metallic);
  q.clearcoat = unit("clearcoat", 0.f, BsdfParam::Clearcoat);
  q.clearcoat_gloss = unit("clearcoat_gloss", 0.f, BsdfParam::ClearcoatGloss);
  if (p.has("eta") && p.has("specular")) error(n, "principled takes either 'eta' or 'specular', not both");
  if (p.has("eta")) {
    q.eta = float(p.get_float("eta", 1.5));
    if (!(q.eta >= 0.1f && q.eta <= 10.f)) error(n, "principled 'eta' must lie in [0.1, 10] (a relative index of refraction)");
    // Mitsuba raises 1 to 1.001; Luz also moves what lies within 1e-3 of 1
    // there (or to 1/1.001), where refraction nearly straight through has
    // an unbounded density and NaN sample weights in float.
    if (transmits && std::fabs(q.eta - 1.f) < 1e-3f) q.eta = q.eta >= 1.f ? 1.001f : 1.f / 1.001f;
  } else {
    float specular = float(p.get_float("specular", 0.5));
    if (!(specular >= 0.f && specular <= 1.f)) error(n, "principled 'specular' must lie in [0, 1]");
    if (transmits && specular == 0.f) specular = 1e-3f;
    q.eta = PrincipledParams::specular_to_eta(specular);
  }
  rate("main_specular_sampling_rate", q.spec_rate);
  rate("clearcoat_sampling_rate", q.clearcoat_rate);
  rate("diffuse_reflectance_sampling_rate", q.diffuse_rate);
  return Bsdf::make_principled(q, transmits);
}

// Mitsuba 0.5's coating: a smooth dielectric layer (int_ior, ext_ior,
// thickness, sigma_a, specular_reflectance) over one nested bsdf. Luz has no
// layered model; the nearest one is taken:
//  - over diffuse: plastic, which is that layer without absorption (the
//    diffuse reflectance tinted by the absorption of a normal-incidence
//    crossing, in and out: exp(-2 sigma_a thickness));
//  - over a conductor or roughconductor: that conductor, its
//    specular_reflectance scaled by the light that crosses the coat twice at
//    normal incidence, (1 - F0)^2 exp(-2 sigma_a thickness). The coat's own
//    mirror reflection (F0, 6.7% for an index of 1.7) and the narrowing of the
//    lobe by refraction are missing: a warning says so.
ParsedBsdf MitsubaParser::parse_coating(pugi::xml_node n) {
  check_children(n, {"bsdf", "ref"});
  Props p(this, n);
  const float int_ior = ior(n, p, "int_ior", "bk7"), ext_ior = ior(n, p, "ext_ior", "air");
  const double thickness = p.get_float("thickness", 1.0);
  const Color sigma_a = p.get_color("sigma_a", {0, 0, 0});
  const Color spec = checked_reflectance(n, p, "specular_reflectance", {1, 1, 1});
  p.check_all_used();
  if (!(thickness >= 0.0)) error(n, "coating thickness must be ≥ 0");
  for (int k = 0; k < 3; ++k)
    if (!(sigma_a[k] >= 0.f)) error(n, "coating sigma_a must be ≥ 0");
  std::vector<pugi::xml_node> inner = nested_bsdf_nodes(n);
  if (inner.size() != 1) error(n, "coating needs exactly one nested bsdf");
  ParsedBsdf b = nested_bsdf(inner[0]);
  Color tint;
  for (int k = 0; k < 3; ++k) tint[k] = float(std::exp(-2.0 * sigma_a[k] * thickness));
  if (b.bsdf.blend || b.bsdf.has_back || b.masked() || b.has_map())
    error(inner[0], "a coating over a blendbsdf, a two-sided pair, a mask or a map is not supported");
  if (b.bsdf.type == BsdfType::Diffuse) {
    for (const TextureBinding& t : b.bindings)
      if (t.param == BsdfParam::Reflectance && max_component(sigma_a) > 0.f)
        error(inner[0], "a coating with sigma_a over a textured diffuse is not supported");
    for (TextureBinding& t : b.bindings)
      if (t.param == BsdfParam::Reflectance) t.param = BsdfParam::DiffuseReflectance;
    b.bsdf = Bsdf::make_smooth_plastic(b.bsdf.diffuse.reflectance * tint, spec, int_ior, ext_ior, b.bsdf.two_sided);
    return b;
  }
  if (b.bsdf.type != BsdfType::SmoothConductor && b.bsdf.type != BsdfType::RoughConductor)
    error(inner[0], "a coating is supported over diffuse, conductor and roughconductor only");
  for (const TextureBinding& t : b.bindings)
    if (t.param == BsdfParam::SpecularReflectance)
      error(inner[0], "a coating over a textured specular_reflectance is not supported");
  const double f0 = std::pow((int_ior - ext_ior) / (int_ior + ext_ior), 2.0);
  Color& r = b.bsdf.type == BsdfType::SmoothConductor ? b.bsdf.smooth_conductor.specular_reflectance
                                                       : b.bsdf.rough_conductor.specular_reflectance;
  r = r * tint * float((1.0 - f0) * (1.0 - f0));
  char percent[32];
  std::snprintf(percent, sizeof percent, "%.1f%%", 100.0 * f0);
  builder_.warn(loc(n), std::string("coating over a conductor is rendered as the conductor seen through the coat at "
                                    "normal incidence (the coat's own reflection, ") +
                            percent + " at normal incidence, is missing)");
  return b;
}

ParsedBsdf MitsubaParser::parse_bsdf_value(pugi::xml_node n) {
  ParsedBsdf b = parse_bsdf_element(n);
  std::string id = n.attribute("id").value();
  if (!id.empty()) {
    if (bsdfs_.count(id)) error(n, "duplicate id '" + id + "'");
    bsdfs_[id] = add_material(n, b);
  }
  return b;
}

uint32_t MitsubaParser::parse_bsdf(pugi::xml_node n) {
  ParsedBsdf b = parse_bsdf_value(n);
  std::string id = n.attribute("id").value();
  return id.empty() ? add_material(n, b) : bsdfs_[id];
}

std::string MitsubaParser::above_one(int32_t t) const {
  // Vertex colours are known to lie in [0, 1] only: their scale bounds them.
  return texture_reads_vertex_color(builder_.scene().textures.data(), uint32_t(t))
             ? "texture reads vertex colours times a scale above 1"
             : "texture has texels above 1";
}

Color MitsubaParser::color_param(pugi::xml_node n, Props& p, const char* name, Color def, BsdfParam param, bool is_reflectance, std::vector<TextureBinding>& tb) {
  const int32_t t = texture_param(p, name);
  if (t < 0) {
    if (is_reflectance) return checked_reflectance(n, p, name, def);
    return p.get_color(name, def);
  }
  const TextureStats& info = builder_.texture_stats(t);
  if (is_reflectance && max_component(info.max) > 1.f)
    error(n, std::string("'") + name + "' " + above_one(t) + " (a reflectance lies in [0, 1])");
  tb.push_back({t, BsdfPart::Front, param});
  return info.mean;
}

float MitsubaParser::float_param(Props& p, const char* name, float def, std::initializer_list<BsdfParam> params, std::vector<TextureBinding>& tb) {
  const int32_t t = texture_param(p, name);
  if (t < 0) return float(p.get_float(name, def));
  for (BsdfParam q : params) tb.push_back({t, BsdfPart::Front, q});
  return luminance(builder_.texture_stats(t).mean);
}

float MitsubaParser::unit_param(pugi::xml_node n, Props& p, const char* plugin, const char* name, float def, int32_t& texture) {
  texture = texture_param(p, name);
  const std::string what = std::string(plugin) + " '" + name + "'";
  if (texture >= 0) {
    if (max_component(builder_.texture_stats(texture).max) > 1.f) error(n, what + " " + above_one(texture) + " (it lies in [0, 1])");
    return luminance(builder_.texture_stats(texture).mean);
  }
  const float v = float(p.get_float(name, def));
  if (!(v >= 0.f && v <= 1.f)) error(n, what + " must lie in [0, 1]");
  return v;
}

Color MitsubaParser::texture_max(const std::vector<TextureBinding>& tb, BsdfParam param, Color v) const {
  for (const TextureBinding& t : tb)
    if (t.part == BsdfPart::Front && t.param == param) return builder_.texture_stats(t.texture).max;
  return v;
}

uint32_t MitsubaParser::resolve_ref(pugi::xml_node r) {
  std::string id = attr(r, "id");
  auto it = bsdfs_.find(id);
  if (it == bsdfs_.end()) error(r, "no bsdf with id '" + id + "' defined before this point");
  return it->second;
}

}  // namespace luz::mitsuba
