// Materials: what a surface is made of, as the scene describes it. A
// material holds a BSDF with its constant parameters and the textures that
// drive the others; at a hit it returns the BSDF with every textured
// parameter evaluated there (pbrt-v4's Material::GetBxDF), so the BSDF
// models stay plain math over constants.
#pragma once

#include "luz/bsdf/bsdf.h"
#include "luz/texture/texture.h"

namespace luz {

// Which part of a Bsdf a texture drives: a component (bsdf.h: the front,
// the blend's second, the two-sided back) or the blend weight.
enum class BsdfPart : uint8_t { Front, Second, Back, BlendWeight };

// What a parameter takes of its texture's value v (a float one: of its
// luminance): v; sqrt(v) (pbrt-v4's remaproughness: alpha = sqrt(roughness)
// at each lookup); or v clamped to [0, 1] (pbrt-v4's reflectances).
enum class TextureMap : uint8_t { Identity, Sqrt, Clamp01 };

// Texture `texture` drives parameter `param` of `part`. A colour parameter
// takes the texture's RGB value, a float one its luminance (Mitsuba's eval_1)
// through `map`.
struct TextureBinding {
  int32_t texture = 0;
  BsdfPart part = BsdfPart::Front;
  BsdfParam param = BsdfParam::Reflectance;
  TextureMap map = TextureMap::Identity;
  uint8_t zero_ = 0;  // not padding: checkpoints hash the bindings' bytes (render/checkpoint.cpp)
};

struct Material {
  // Its bindings: MaterialsView::bindings[first_binding, + num_bindings)
  // (first: read at every hit, beside the BSDF's type).
  uint32_t num_bindings = 0, first_binding = 0;
  // The constant parameters; a textured one holds the texture's mean, which
  // host-side set-up (lobe sampling weights) uses, as Mitsuba's mean().
  Bsdf bsdf;
  // Opacity (Mitsuba's mask): the chance that a ray meeting the surface stops
  // there (material/opacity.h's alpha test); the texture's luminance when
  // opacity_texture >= 0, else the constant. 1: opaque, no test.
  float opacity = 1.f;
  int32_t opacity_texture = -1;
  // glTF's alphaMode MASK: the texture's value a becomes opacity 1 where
  // a >= alpha_cutoff, else 0. Negative: none (a is the opacity itself).
  float alpha_cutoff = -1.f;

  LUZ_INLINE bool masked() const { return opacity_texture >= 0 || opacity < 1.f; }
  LUZ_INLINE bool mapped() const { return normal_map >= 0 || bump_map >= 0; }

  // Mitsuba's normalmap / bumpmap around the whole material (the textures,
  // or -1; at most one is set): SceneView::shading_frame perturbs the
  // shading frame by them, and the BSDF is evaluated in the perturbed frame.
  int32_t normal_map = -1, bump_map = -1;
  float bump_scale = 1.f;  // bumpmap's `scale`: multiplies the height's gradient
  // glTF's normal textures: `scale` multiplies the map's x and y, and the
  // map's y points along -dp/dv (glTF's v runs down the image), so that it
  // flips where the uv layout is mirrored (MikkTSpace's bitangent sign).
  float normal_scale = 1.f;
  bool normal_y_by_uv = false;
};

struct MaterialsView {
  const Material* list = nullptr;
  const TextureBinding* bindings = nullptr;
  uint32_t count = 0;
  bool masked = false;  // some material has an opacity below 1 (Material::masked): tracers run the alpha test
  bool mapped = false;  // some material has a normal or bump map (Material::mapped)

  // The BSDF of material m at a surface point of texture coordinates uv and
  // vertex colour vc.
  LUZ_INLINE Bsdf bsdf(uint32_t m, const TextureView& tex, Vec2 uv, Color vc = {1.f, 1.f, 1.f}) const {
    Bsdf b = list[m].bsdf;
    apply_textures(b, list[m], tex, uv, vc);
    return b;
  }

  // Sets b's textured parameters (b: a copy of mat.bsdf) to their values at
  // (uv, vc).
  LUZ_INLINE void apply_textures(Bsdf& b, const Material& mat, const TextureView& tex, Vec2 uv, Color vc) const {
    for (uint32_t k = 0; k < mat.num_bindings; ++k) apply(b, bindings[mat.first_binding + k], tex, uv, vc);
  }

  // The first textured parameter's texture, or -1: the texels a hit will read
  // first (SceneView::prefetch_texture).
  LUZ_FORCE_INLINE int32_t first_texture(uint32_t m) const {
    const Material& mat = list[m];
    return mat.num_bindings > 0 ? bindings[mat.first_binding].texture : -1;
  }

  LUZ_INLINE static void apply(Bsdf& b, const TextureBinding& t, const TextureView& tex, Vec2 uv, Color vc) {
    const Color v = tex.eval(uint32_t(t.texture), uv, vc);
    if (t.part == BsdfPart::BlendWeight) {
      b.blend_weight = clamp(luminance(v), 0.f, 1.f);
      return;
    }
    BsdfComponent& c = t.part == BsdfPart::Front ? b : (t.part == BsdfPart::Second ? b.second : b.back);
    if (Color* p = color_param(c, t.param)) {
      *p = t.map == TextureMap::Clamp01 ? Color{clamp(v.x, 0.f, 1.f), clamp(v.y, 0.f, 1.f), clamp(v.z, 0.f, 1.f)} : v;
    } else if (float* f = float_param(c, t.param)) {
      const float l = luminance(v);
      *f = t.map == TextureMap::Sqrt ? sqrtf(max(l, 0.f)) : t.map == TextureMap::Clamp01 ? clamp(l, 0.f, 1.f) : l;
    }
  }
};

}  // namespace luz
