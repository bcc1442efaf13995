// Textures for both devices: a tagged union over the models (a bitmap of
// 8-bit or float texels, a checkerboard, the vertex colours), the texel arrays they address by
// offset, and the texture-or-constant parameter that materials and lights
// hold. No containers, no virtuals: TextureView holds plain pointers that are
// valid on the CPU or copied to the GPU as they are.
//
// Texture coordinates follow Mitsuba: (0, 0) is the top-left corner of the
// image, u grows to the right, v downward (the OBJ loader flips OBJ's vt.v as
// Mitsuba's flipTexCoords, on by default, does). A texture's `to_uv` (an
// affine map, Mitsuba's `to_uv`) is applied first. The bilinear filter
// interpolates between the four texel centres around the point (texel (i, j)
// has its centre at ((i + 0.5) / width, (j + 0.5) / height)), the nearest
// filter takes the texel containing it; texel indices outside the image wrap
// by the texture's mode (repeat, mirror, clamp), as Mitsuba 3's bitmap does.
#pragma once

#include "luz/math/vec.h"

namespace luz {

enum class TextureFilter : uint32_t { Bilinear, Nearest };
enum class WrapMode : uint32_t { Repeat, Mirror, Clamp };
// What a bitmap's texel reads: its RGB, or one channel as a grey (R, G, B
// decoded as the bitmap says; A always linear, 1 for float bitmaps). glTF
// packs parameters in channels (metallic-roughness: roughness in G, metallic
// in B; opacity in the base colour's A); a grey's luminance is that channel.
enum class TextureChannel : uint32_t { Rgb, R, G, B, A };

// uv' = (a u + b v + c, d u + e v + f).
struct UvTransform {
  float a = 1.f, b = 0.f, c = 0.f, d = 0.f, e = 1.f, f = 0.f;
  LUZ_INLINE Vec2 apply(Vec2 uv) const { return {a * uv.x + b * uv.y + c, d * uv.x + e * uv.y + f}; }
};

struct BitmapTexture {
  uint32_t offset = 0;  // the first (top-left) texel's index in its texel array
  uint32_t width = 0, height = 0;
  TextureFilter filter = TextureFilter::Bilinear;
  WrapMode wrap = WrapMode::Repeat;
  // Float RGB texels (OpenEXR, HDR, PFM: TextureView::texelsf, 3 floats
  // each); otherwise packed 8-bit RGBA (TextureView::texels8), sRGB-encoded
  // (Mitsuba's default, decoded through the 256-entry table) or, with `raw`,
  // linear values · 255.
  bool is_float = false;
  bool srgb = true;
  uint8_t zero_[2] = {};  // not padding: checkpoints hash a texture's bytes (render/checkpoint.cpp)
  TextureChannel channel = TextureChannel::Rgb;
};

// Mitsuba's `checkerboard`: color0 where exactly one of frac(u), frac(v)
// exceeds 1/2, color1 elsewhere.
struct CheckerboardTexture {
  Color color0{0.4f, 0.4f, 0.4f}, color1{0.2f, 0.2f, 0.2f};
};

// pbrt-v4's `mix` and `scale` of textures: (1 - w) a + w b, or a b, where a,
// b and w are each a leaf texture (a bitmap, a checkerboard or the vertex
// colours: a, b its colour, w its luminance) or, at index -1, a constant. One level only: the
// loader refuses a mix of mixes, so evaluation needs no recursion.
enum class MixOp : uint32_t { Lerp, Product };
struct MixTexture {
  int32_t a = -1, b = -1, amount = -1;
  MixOp op = MixOp::Lerp;
  float w = 0.5f;
  Color ca, cb;
};

// Mitsuba's `mesh_attribute` of name vertex_color (glTF's COLOR_0): the
// surface's vertex colours, interpolated at the hit (SceneView::hit_color;
// white where the hit's mesh has none).
struct VertexColorTexture {};

enum class TextureType : uint32_t { Bitmap, Checkerboard, Mix, VertexColor };

struct Texture {
  TextureType type = TextureType::Bitmap;
  UvTransform to_uv;           // a mix's own is unused: its leaves have theirs
  Color scale{1.f, 1.f, 1.f};  // multiplies every value (glTF's factors times their textures)
  Color offset{0.f, 0.f, 0.f};  // then added (pbrt's invert, 1 - v: scale -1, offset 1)
  union {
    BitmapTexture bitmap;
    CheckerboardTexture checkerboard;
    MixTexture mix;
    VertexColorTexture vertex_color;
  };
  LUZ_INLINE Texture() : bitmap() {}
  LUZ_INLINE Texture(const BitmapTexture& m) : type(TextureType::Bitmap), bitmap(m) {}
  LUZ_INLINE Texture(const CheckerboardTexture& m) : type(TextureType::Checkerboard), checkerboard(m) {}
  LUZ_INLINE Texture(const MixTexture& m) : type(TextureType::Mix), mix(m) {}
  LUZ_INLINE Texture(const VertexColorTexture& m) : type(TextureType::VertexColor), bitmap() { (void)m; }
};

// R in the low byte, then G, B, A.
LUZ_INLINE uint32_t pack_rgba8(uint32_t r, uint32_t g, uint32_t b, uint32_t a = 255) {
  return r | (g << 8) | (b << 16) | (a << 24);
}

// The standard sRGB decoding (IEC 61966-2-1) of a value in [0, 1], in double:
// for the loader (<srgb> colours) and the 256-entry table texels go through.
LUZ_INLINE double srgb_to_linear(double v) { return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4); }

// One 8-bit texel as linear RGB.
LUZ_INLINE Color texel_color(uint32_t t, bool srgb, const float* srgb_table) {
  uint32_t r = t & 255u, g = (t >> 8) & 255u, b = (t >> 16) & 255u;
  if (srgb) return {srgb_table[r], srgb_table[g], srgb_table[b]};
  const float s = 1.f / 255.f;
  return {float(r) * s, float(g) * s, float(b) * s};
}

// One channel (not Rgb) of an 8-bit texel, as a grey.
LUZ_INLINE Color texel_channel(uint32_t t, TextureChannel c, bool srgb, const float* srgb_table) {
  const uint32_t k = uint32_t(c) - 1u, v = (t >> (8u * k)) & 255u;
  const float x = srgb && c != TextureChannel::A ? srgb_table[v] : float(v) * (1.f / 255.f);
  return {x, x, x};
}

// A coordinate brought to where the wrap mode keeps texel indices small:
// [0, 1) for repeat, [0, 2) for mirror (its period), [0, 1] for clamp. A
// non-finite one reads as 0 (it would otherwise become an out-of-range index).
LUZ_INLINE float reduce_coordinate(float u, WrapMode m) {
  if (m == WrapMode::Clamp) return u > 0.f ? (u < 1.f ? u : 1.f) : 0.f;  // NaN -> 0
  const float period = m == WrapMode::Mirror ? 2.f : 1.f;
  u -= floorf(u / period) * period;
  return u >= 0.f && u < period ? u : 0.f;
}

// A texel index in [-1, 2n] brought into [0, n) by the wrap mode.
LUZ_INLINE uint32_t wrap_index(int i, uint32_t n, WrapMode m) {
  const int ni = int(n);
  if (m == WrapMode::Clamp) return uint32_t(i < 0 ? 0 : (i >= ni ? ni - 1 : i));
  if (m == WrapMode::Mirror) {
    int p = i < 0 ? i + 2 * ni : (i >= 2 * ni ? i - 2 * ni : i);
    return uint32_t(p < ni ? p : 2 * ni - 1 - p);
  }
  return uint32_t(i < 0 ? i + ni : (i >= ni ? i - ni : i));
}

// The bilinear filter's four texels around uv (after to_uv): columns i0, i1,
// rows j0, j1, and the weights fx, fy of i1 and j1.
struct BilinearTaps {
  uint32_t i0, i1, j0, j1;
  float fx, fy;
};

LUZ_INLINE BilinearTaps bilinear_taps(const BitmapTexture& tex, Vec2 uv) {
  const uint32_t w = tex.width, h = tex.height;
  // Continuous texel coordinates: texel centres at integers.
  const float x = reduce_coordinate(uv.x, tex.wrap) * float(w) - 0.5f;
  const float y = reduce_coordinate(uv.y, tex.wrap) * float(h) - 0.5f;
  const float x0f = floorf(x), y0f = floorf(y);
  const int x0 = int(x0f), y0 = int(y0f);
  BilinearTaps t;
  t.fx = x - x0f, t.fy = y - y0f;
  t.i0 = wrap_index(x0, w, tex.wrap), t.i1 = wrap_index(x0 + 1, w, tex.wrap);
  t.j0 = wrap_index(y0, h, tex.wrap), t.j1 = wrap_index(y0 + 1, h, tex.wrap);
  return t;
}

// The texel containing uv (the nearest filter).
LUZ_INLINE uint32_t nearest_texel(const BitmapTexture& tex, Vec2 uv) {
  const uint32_t w = tex.width, h = tex.height;
  const int i = int(floorf(reduce_coordinate(uv.x, tex.wrap) * float(w)));
  const int j = int(floorf(reduce_coordinate(uv.y, tex.wrap) * float(h)));
  return wrap_index(j, h, tex.wrap) * w + wrap_index(i, w, tex.wrap);
}

// Every texture, and the texels bitmaps address.
struct TextureView {
  const Texture* list = nullptr;
  const uint32_t* texels8 = nullptr;  // packed RGBA8
  const float* texelsf = nullptr;     // RGB floats
  const float* srgb_table = nullptr;  // 256 entries: srgb_to_linear(k / 255)
  uint32_t count = 0;

  LUZ_INLINE Color texel(const BitmapTexture& tex, uint32_t k) const {
    if (tex.is_float) {
      const float* p = texelsf + 3 * (size_t(tex.offset) + k);
      if (__builtin_expect(tex.channel != TextureChannel::Rgb, 0)) {
        const float x = tex.channel == TextureChannel::A ? 1.f : p[uint32_t(tex.channel) - 1u];
        return {x, x, x};
      }
      return {p[0], p[1], p[2]};
    }
    if (__builtin_expect(tex.channel != TextureChannel::Rgb, 0))
      return texel_channel(texels8[tex.offset + k], tex.channel, tex.srgb, srgb_table);
    return texel_color(texels8[tex.offset + k], tex.srgb, srgb_table);
  }

  // The bitmap's linear RGB value at uv (after to_uv).
  LUZ_INLINE Color bitmap(const BitmapTexture& tex, Vec2 uv) const {
    if (tex.filter == TextureFilter::Nearest) return texel(tex, nearest_texel(tex, uv));
    const BilinearTaps t = bilinear_taps(tex, uv);
    const uint32_t w = tex.width;
    const float fx = t.fx, fy = t.fy;
    const Color c00 = texel(tex, t.j0 * w + t.i0), c10 = texel(tex, t.j0 * w + t.i1);
    const Color c01 = texel(tex, t.j1 * w + t.i0), c11 = texel(tex, t.j1 * w + t.i1);
    return (c00 * (1.f - fx) + c10 * fx) * (1.f - fy) + (c01 * (1.f - fx) + c11 * fx) * fy;
  }

  // A leaf's (a bitmap's, checkerboard's or the vertex colours') linear RGB
  // value at a point of texture coordinates uv and vertex colour vc.
  LUZ_INLINE Color leaf(const Texture& tex, Vec2 uv, Color vc) const {
    if (__builtin_expect(tex.type == TextureType::VertexColor, 0)) return tex.scale * vc + tex.offset;
    const Vec2 st = tex.to_uv.apply(uv);
    if (tex.type == TextureType::Checkerboard) {
      const bool a = st.x - floorf(st.x) > 0.5f, b = st.y - floorf(st.y) > 0.5f;
      return tex.scale * (a != b ? tex.checkerboard.color0 : tex.checkerboard.color1) + tex.offset;
    }
    return tex.scale * bitmap(tex.bitmap, st) + tex.offset;
  }

  // Texture t's linear RGB value at the surface point of texture coordinates
  // uv and vertex colour vc (white where there is none: lights' textures)
  // (texture_eval: out of line on the GPU).
  LUZ_INLINE Color eval(uint32_t t, Vec2 uv, Color vc = {1.f, 1.f, 1.f}) const;
  LUZ_INLINE Color eval_inline(uint32_t t, Vec2 uv, Color vc) const {
    const Texture& tex = list[t];
    if (__builtin_expect(tex.type != TextureType::Mix, 1)) return leaf(tex, uv, vc);
    const MixTexture& m = tex.mix;
    const Color a = m.a < 0 ? m.ca : leaf(list[m.a], uv, vc);
    const Color b = m.b < 0 ? m.cb : leaf(list[m.b], uv, vc);
    if (m.op == MixOp::Product) return tex.scale * (a * b) + tex.offset;
    const float w = m.amount < 0 ? m.w : luminance(leaf(list[m.amount], uv, vc));
    return tex.scale * (a * (1.f - w) + b * w) + tex.offset;
  }

  // The gradient (d/du, d/dv) of texture t's luminance at uv, the bilinear
  // lookup differentiated exactly within its cell, chained through to_uv
  // (Mitsuba 3's eval_1_grad; Mitsuba applies the resolution after to_uv's
  // transpose, which differs only for a rotating to_uv on a non-square
  // image). Zero for the nearest filter and the checkerboard (piecewise
  // constant), as Mitsuba's nearest bitmap, and for a mix (the loaders
  // refuse one as a height map).
  LUZ_INLINE Vec2 eval_1_grad(uint32_t t, Vec2 uv) const {
    const Texture& tex = list[t];
    if (tex.type != TextureType::Bitmap || tex.bitmap.filter == TextureFilter::Nearest) return {};
    const BitmapTexture& bm = tex.bitmap;
    const BilinearTaps b = bilinear_taps(bm, tex.to_uv.apply(uv));
    const uint32_t w = bm.width;
    const Color s = tex.scale;
    const float f00 = luminance(s * texel(bm, b.j0 * w + b.i0)), f10 = luminance(s * texel(bm, b.j0 * w + b.i1));
    const float f01 = luminance(s * texel(bm, b.j1 * w + b.i0)), f11 = luminance(s * texel(bm, b.j1 * w + b.i1));
    // Per unit of the image's own coordinates (texel units times the size);
    // a clamped coordinate outside [0, 1] reads a constant: no gradient there.
    const UvTransform& m = tex.to_uv;
    const Vec2 st = m.apply(uv);
    const bool clamp_x = bm.wrap == WrapMode::Clamp && !(st.x > 0.f && st.x < 1.f);
    const bool clamp_y = bm.wrap == WrapMode::Clamp && !(st.y > 0.f && st.y < 1.f);
    // (Mirror needs no sign: its taps already read the texels backwards.)
    const float gx = clamp_x ? 0.f : float(w) * ((1.f - b.fy) * (f10 - f00) + b.fy * (f11 - f01));
    const float gy = clamp_y ? 0.f : float(bm.height) * ((1.f - b.fx) * (f01 - f00) + b.fx * (f11 - f10));
    return {m.a * gx + m.d * gy, m.b * gx + m.e * gy};
  }

  // Asks the CPU's caches for the texels eval() will read at uv (the two rows
  // of the bilinear taps; for the nearest filter, one of them; of a mix's
  // first operand): a hint with no effect on any result. Nothing on the GPU. Forced inline: GCC 12 finds a
  // function whose only effect is a prefetch free of side effects and drops
  // calls to it.
  LUZ_FORCE_INLINE void prefetch(uint32_t t, Vec2 uv) const {
#if !defined(__CUDA_ARCH__)
    if (list[t].type == TextureType::Mix && list[t].mix.a >= 0) t = uint32_t(list[t].mix.a);  // its first operand's
    const Texture& tex = list[t];
    if (tex.type != TextureType::Bitmap) return;
    const BilinearTaps b = bilinear_taps(tex.bitmap, tex.to_uv.apply(uv));
    const size_t row0 = size_t(tex.bitmap.offset) + b.j0 * tex.bitmap.width + b.i0;
    const size_t row1 = size_t(tex.bitmap.offset) + b.j1 * tex.bitmap.width + b.i0;
    if (tex.bitmap.is_float) {
      __builtin_prefetch(texelsf + 3 * row0);
      __builtin_prefetch(texelsf + 3 * row1);
    } else {
      __builtin_prefetch(texels8 + row0);
      __builtin_prefetch(texels8 + row1);
    }
#else
    (void)t, (void)uv;
#endif
  }
};

// Whether texture t reads texture coordinates, and whether it reads vertex
// colours (itself or one of a mix's operands).
inline bool texture_reads_uv(const Texture* list, uint32_t t) {
  const Texture& x = list[t];
  if (x.type != TextureType::Mix) return x.type != TextureType::VertexColor;
  const MixTexture& m = x.mix;
  for (int32_t k : {m.a, m.b, m.amount})
    if (k >= 0 && list[k].type != TextureType::VertexColor) return true;
  return false;
}
inline bool texture_reads_vertex_color(const Texture* list, uint32_t t) {
  const Texture& x = list[t];
  if (x.type != TextureType::Mix) return x.type == TextureType::VertexColor;
  const MixTexture& m = x.mix;
  for (int32_t k : {m.a, m.b, m.amount})
    if (k >= 0 && list[k].type == TextureType::VertexColor) return true;
  return false;
}

// TextureView::eval's one copy in a CUDA kernel (inline on the CPU); the
// view by value, so a kernel's parameters need no local copy for an address.
LUZ_DEVICE_NOINLINE Color texture_eval(TextureView v, uint32_t t, Vec2 uv, Color vc) { return v.eval_inline(t, uv, vc); }
LUZ_INLINE Color TextureView::eval(uint32_t t, Vec2 uv, Color vc) const { return texture_eval(*this, t, uv, vc); }

// A texture-or-constant colour: `value` where texture < 0 (and, for a
// texture, its mean: what lobe-sampling weights use, as Mitsuba's mean()).
struct ColorTexture {
  Color value;
  int32_t texture = -1;
  LUZ_INLINE Color eval(const TextureView& v, Vec2 uv) const { return texture < 0 ? value : v.eval(uint32_t(texture), uv); }
};

}  // namespace luz
