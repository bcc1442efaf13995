// Bitmap textures for both devices: one flat array of 8-bit RGBA texels
// (all textures back to back) and a small descriptor per texture, referenced
// by index. No containers, no virtuals: SceneView holds plain pointers that
// are valid on the CPU or copied to the GPU as they are.
//
// Texture coordinates follow Mitsuba: (0, 0) is the top-left corner of the
// image, u grows to the right, v downward (the OBJ loader flips OBJ's vt.v as
// Mitsuba's flipTexCoords, on by default, does). Addressing wraps around
// (Mitsuba's default wrap mode "repeat"). The bilinear filter interpolates
// between the four texel centres around the point, as Mitsuba's does
// (texel (i, j) has its centre at ((i + 0.5) / width, (j + 0.5) / height)).
#pragma once

#include "luz/math/vec.h"

namespace luz {

enum class TextureFilter : uint32_t { Bilinear, Nearest };

struct TextureDesc {
  uint32_t offset = 0;  // index of the texture's first texel (top-left) in the texel array
  uint32_t width = 0, height = 0;
  TextureFilter filter = TextureFilter::Bilinear;
  // Texels hold sRGB-encoded values (Mitsuba's default for 8-bit bitmaps),
  // decoded through the 256-entry table; otherwise linear values · 255.
  bool srgb = true;
  // uv' = uv · scale + offset (Mitsuba 0.5's uscale, vscale, uoffset, voffset).
  Vec2 scale{1.f, 1.f}, shift{0.f, 0.f};
};

// R in the low byte, then G, B, A.
LUZ_INLINE uint32_t pack_rgba8(uint32_t r, uint32_t g, uint32_t b, uint32_t a = 255) {
  return r | (g << 8) | (b << 16) | (a << 24);
}

// The standard sRGB decoding (IEC 61966-2-1) of a value in [0, 1], in double:
// for the loader (<srgb> colours) and the 256-entry table texels go through.
LUZ_INLINE double srgb_to_linear(double v) { return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4); }

// A coordinate brought to [0, 1) by wrapping; a non-finite one reads as 0
// (it would otherwise become an out-of-range index).
LUZ_INLINE float wrap_unit(float u) {
  u -= floorf(u);
  return u >= 0.f && u < 1.f ? u : 0.f;
}

// One texel as linear RGB.
LUZ_INLINE Color texel_color(uint32_t t, bool srgb, const float* srgb_table) {
  uint32_t r = t & 255u, g = (t >> 8) & 255u, b = (t >> 16) & 255u;
  if (srgb) return {srgb_table[r], srgb_table[g], srgb_table[b]};
  const float s = 1.f / 255.f;
  return {float(r) * s, float(g) * s, float(b) * s};
}

// uv with the texture's scale and shift applied, wrapped into [0, 1)².
LUZ_INLINE Vec2 texture_uv(const TextureDesc& tex, Vec2 uv) {
  return {wrap_unit(uv.x * tex.scale.x + tex.shift.x), wrap_unit(uv.y * tex.scale.y + tex.shift.y)};
}

// The bilinear filter's four texels around uv: columns i0, i1, rows j0, j1
// (wrapped around), and the weights fx, fy of i1 and j1.
struct BilinearTaps {
  uint32_t i0, i1, j0, j1;
  float fx, fy;
};

LUZ_INLINE BilinearTaps bilinear_taps(const TextureDesc& tex, Vec2 uv) {
  const Vec2 t01 = texture_uv(tex, uv);
  const uint32_t w = tex.width, h = tex.height;
  // Continuous texel coordinates: texel centres at integers. x in [-0.5, w - 0.5).
  const float x = t01.x * float(w) - 0.5f, y = t01.y * float(h) - 0.5f;
  const float x0f = floorf(x), y0f = floorf(y);
  // x0 in [-1, w - 1]: -1 wraps to the last column, x0 + 1 = w to the first.
  const int x0 = int(x0f), y0 = int(y0f);
  BilinearTaps t;
  t.fx = x - x0f, t.fy = y - y0f;
  t.i0 = x0 < 0 ? w - 1 : uint32_t(x0), t.i1 = uint32_t(x0 + 1) >= w ? 0u : uint32_t(x0 + 1);
  t.j0 = y0 < 0 ? h - 1 : uint32_t(y0), t.j1 = uint32_t(y0 + 1) >= h ? 0u : uint32_t(y0 + 1);
  return t;
}

// The texture's linear RGB value at uv. `texels` is the whole texel array,
// `srgb_table` the 256 decoded sRGB values (srgb_to_linear(k / 255)).
LUZ_INLINE Color texture_lookup(const TextureDesc& tex, const uint32_t* texels, const float* srgb_table, Vec2 uv) {
  const uint32_t w = tex.width, h = tex.height;
  const uint32_t* img = texels + tex.offset;
  if (tex.filter == TextureFilter::Nearest) {
    const Vec2 t01 = texture_uv(tex, uv);
    uint32_t i = uint32_t(t01.x * float(w)), j = uint32_t(t01.y * float(h));
    i = i < w ? i : w - 1;  // u · w may round up to w
    j = j < h ? j : h - 1;
    return texel_color(img[j * w + i], tex.srgb, srgb_table);
  }
  const BilinearTaps t = bilinear_taps(tex, uv);
  const float fx = t.fx, fy = t.fy;
  const Color c00 = texel_color(img[t.j0 * w + t.i0], tex.srgb, srgb_table);
  const Color c10 = texel_color(img[t.j0 * w + t.i1], tex.srgb, srgb_table);
  const Color c01 = texel_color(img[t.j1 * w + t.i0], tex.srgb, srgb_table);
  const Color c11 = texel_color(img[t.j1 * w + t.i1], tex.srgb, srgb_table);
  return (c00 * (1.f - fx) + c10 * fx) * (1.f - fy) + (c01 * (1.f - fx) + c11 * fx) * fy;
}

// Asks the CPU's caches for the texels texture_lookup will read at uv (the
// two rows of the bilinear taps; for the nearest filter, one of them): a
// hint with no effect on any result (the taps are always inside the
// texture). Nothing on the GPU. Forced inline, as SceneView::prefetch_texture.
LUZ_FORCE_INLINE void texture_prefetch(const TextureDesc& tex, const uint32_t* texels, Vec2 uv) {
#if !defined(__CUDA_ARCH__)
  const BilinearTaps t = bilinear_taps(tex, uv);
  const uint32_t* img = texels + tex.offset;
  __builtin_prefetch(img + t.j0 * tex.width + t.i0);
  __builtin_prefetch(img + t.j1 * tex.width + t.i0);
#else
  (void)tex, (void)texels, (void)uv;
#endif
}

}  // namespace luz
