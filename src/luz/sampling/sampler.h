// Samplers. A sample value is a pure function of (seed, pixel, sample index,
// dimension): no state is carried between samples, so images do not depend on
// the thread count or on the order tiles are rendered in, and a render can
// resume at any sample index.
#pragma once

#include "luz/math/hash.h"
#include "luz/math/vec.h"

namespace luz {

enum class SamplerType : uint32_t { Independent, Stratified, Sobol };

struct SamplerDesc {
  SamplerType type = SamplerType::Independent;
  uint32_t spp = 16;
  uint64_t seed = 0;
  // Stratified: spp = strata_x * strata_y for 2D requests.
  uint32_t strata_x = 4, strata_y = 4;
};

// Kensler 2013 ("Correlated Multi-Jittered Sampling"), the hashed permutation of
// [0, n): element i of the permutation chosen by key p. Cycle-walks until < n.
LUZ_INLINE uint32_t permute(uint32_t i, uint32_t n, uint32_t p) {
  if (n <= 1) return 0;
  uint32_t w = n - 1;
  w |= w >> 1;
  w |= w >> 2;
  w |= w >> 4;
  w |= w >> 8;
  w |= w >> 16;
  do {
    i ^= p;
    i *= 0xe170893du;
    i ^= p >> 16;
    i ^= (i & w) >> 4;
    i ^= p >> 8;
    i *= 0x0929eb3fu;
    i ^= p >> 23;
    i ^= (i & w) >> 1;
    i *= 1u | p >> 27;
    i *= 0x6935fa69u;
    i ^= (i & w) >> 11;
    i *= 0x74dcb303u;
    i ^= (i & w) >> 2;
    i *= 0x9e501cc3u;
    i ^= (i & w) >> 2;
    i *= 0xc860a3dfu;
    i &= w;
    i ^= i >> 5;
  } while (i >= n);
  return (i + p) % n;
}

// Nested uniform (Owen) scrambling of a 32-bit fixed-point value, by the
// Laine-Karras construction with Vegdahl's improved hash (see Burley 2020,
// "Practical Hash-based Owen Scrambling", JCGT 9(4)).
LUZ_INLINE uint32_t laine_karras_permutation(uint32_t x, uint32_t seed) {
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return x;
}
LUZ_INLINE uint32_t owen_scramble(uint32_t x, uint32_t seed) {
  return reverse_bits32(laine_karras_permutation(reverse_bits32(x), seed));
}

// The first two Sobol dimensions. Dimension 0 is van der Corput: reverse(i).
// Dimension 1 (primitive polynomial x + 1) has the Pascal matrix mod 2 as its
// generator: output bit (31 - j) is the XOR of the index bits k ⊇ j (Lucas).
// That superset transform takes five shift-mask steps; the result is then
// bit-reversed. sobol_pascal() returns the value before that reversal, so the
// Owen-scrambled forms below need one reversal, not three. Written for each
// 32-bit lane of T: uint64_t transforms two values side by side (no step
// carries a bit across the lanes: each mask is zero where a shifted-in bit
// would land).
template <class T>
LUZ_INLINE T sobol_pascal_lanes(T x) {
  constexpr T k = T(~T(0)) / 0xffffffffu;  // 1 in each 32-bit lane
  x ^= (x >> 1) & (0x55555555u * k);
  x ^= (x >> 2) & (0x33333333u * k);
  x ^= (x >> 4) & (0x0f0f0f0fu * k);
  x ^= (x >> 8) & (0x00ff00ffu * k);
  x ^= (x >> 16) & (0x0000ffffu * k);
  return x;
}
LUZ_INLINE uint32_t sobol_pascal(uint32_t x) { return sobol_pascal_lanes(x); }
LUZ_INLINE uint32_t sobol_dim0(uint32_t i) { return reverse_bits32(i); }
LUZ_INLINE uint32_t sobol_dim1(uint32_t i) { return reverse_bits32(sobol_pascal(i)); }
// Owen-scrambled: owen_scramble(reverse(y), seed) = reverse(LK(y, seed)).
LUZ_INLINE uint32_t scrambled_sobol_dim0(uint32_t i, uint32_t seed) {
  return reverse_bits32(laine_karras_permutation(i, seed));
}
LUZ_INLINE uint32_t scrambled_sobol_dim1(uint32_t i, uint32_t seed) {
  return reverse_bits32(laine_karras_permutation(sobol_pascal(i), seed));
}

#if defined(__SSE2__) && !defined(__CUDA_ARCH__)
// Reverses the bits of each 32-bit lane whose bytes are already in reverse
// order: three mask-and-shift steps within the bytes.
inline __m128i reverse_bits_in_bytes(__m128i v) {
  const __m128i m4 = _mm_set1_epi8(0x0f), m2 = _mm_set1_epi8(0x33), m1 = _mm_set1_epi8(0x55);
  v = _mm_or_si128(_mm_and_si128(_mm_srli_epi32(v, 4), m4), _mm_slli_epi32(_mm_and_si128(v, m4), 4));
  v = _mm_or_si128(_mm_and_si128(_mm_srli_epi32(v, 2), m2), _mm_slli_epi32(_mm_and_si128(v, m2), 2));
  return _mm_or_si128(_mm_and_si128(_mm_srli_epi32(v, 1), m1), _mm_slli_epi32(_mm_and_si128(v, m1), 1));
}
// Each lane's top 24 bits as a float in [0,1): exact (below 2^24 the
// conversion does not round).
inline __m128 unit_floats(__m128i v) {
  return _mm_mul_ps(_mm_cvtepi32_ps(_mm_srli_epi32(v, 8)), _mm_set1_ps(0x1p-24f));
}
#endif

// {reverse(a), reverse(b)} as two [0,1) floats of 24 bits: the last steps of a
// scrambled 2D Sobol draw. On the CPU both in one SSE register: one byte swap
// of the pair, the bits within each byte reversed by three mask-and-shift
// steps on both lanes at once, and one exact int-to-float conversion for both
// (a value below 2^24 converts without rounding); the same numbers as the
// scalar form, in about half the instructions.
LUZ_INLINE Vec2 reversed_unit_pair(uint32_t a, uint32_t b) {
#if defined(__CUDA_ARCH__) || !defined(__SSE2__)
  return {to_unit_float32(reverse_bits32(a)), to_unit_float32(reverse_bits32(b))};
#else
  // bswap64 puts a's bytes, reversed, in the low lane and b's in the next.
  const __m128i v = _mm_cvtsi64_si128(int64_t(__builtin_bswap64(uint64_t(a) << 32 | b)));
  const __m128 f = unit_floats(reverse_bits_in_bytes(v));
  return {_mm_cvtss_f32(f), _mm_cvtss_f32(_mm_shuffle_ps(f, f, 1))};
#endif
}

// {reverse(a), reverse(b)} and {reverse(c), reverse(d)} as [0,1) floats: the
// last steps of two 2D draws, all four lanes in one register on the CPU.
LUZ_INLINE void reversed_unit_quad(uint32_t a, uint32_t b, uint32_t c, uint32_t d, Vec2& ab, Vec2& cd) {
#if defined(__CUDA_ARCH__) || !defined(__SSE2__)
  ab = reversed_unit_pair(a, b);
  cd = reversed_unit_pair(c, d);
#else
  const __m128i v = _mm_unpacklo_epi64(_mm_cvtsi64_si128(int64_t(__builtin_bswap64(uint64_t(a) << 32 | b))),
                                       _mm_cvtsi64_si128(int64_t(__builtin_bswap64(uint64_t(c) << 32 | d))));
  const __m128 f = unit_floats(reverse_bits_in_bytes(v));
  ab = {_mm_cvtss_f32(f), _mm_cvtss_f32(_mm_shuffle_ps(f, f, 1))};
  cd = {_mm_cvtss_f32(_mm_shuffle_ps(f, f, 2)), _mm_cvtss_f32(_mm_shuffle_ps(f, f, 3))};
#endif
}

// The scramble seeds of one (pixel, dimension): the same for every sample of
// the pixel. Computing them is a third of a Sobol draw's work, so the CPU
// renderer computes a pixel's first dimensions once (Sampler::cache_seeds)
// and its draws read them.
struct Seeds2 {
  uint32_t shuffle, x, y;  // a 2D draw: the index shuffle, dimension 0's and dimension 1's scrambles
};
struct Seeds1 {
  uint32_t shuffle, x;  // a 1D draw (kind 0)
};
struct DimSeeds {
  Seeds2 s2;
  Seeds1 s1;
};

// One sample's stream of numbers. Dimensions are requested in a fixed order by
// the integrator (it sets `dim` explicitly at each bounce); 1D and 2D requests
// each consume one dimension index.
struct Sampler {
  SamplerDesc desc;
  uint64_t pixel_key = 0;   // hash of (seed, pixel)
  uint64_t sample_key = 0;  // hash of (seed, pixel, sample index): independent sampler
  uint32_t index = 0;       // sample index within the pixel
  uint32_t index_reversed = 0;
  uint32_t dim = 0;
  // The pixel's cached seeds of dimensions [0, num_seeds) (CPU only; none on the GPU).
  const DimSeeds* seeds = nullptr;
  uint32_t num_seeds = 0;

  LUZ_INLINE void start(const SamplerDesc& d, uint32_t px, uint32_t py, uint32_t sample_index) {
    desc = d;
    pixel_key = hash4(d.seed, px, py, 0x5a3c1e9dull);
    seeds = nullptr;
    num_seeds = 0;
    set_sample(sample_index);
  }

  // Computes this pixel's Sobol seeds of dimensions [0, n) into `storage`
  // (which must outlive the pixel's draws) and draws from them from now on:
  // the same numbers, fewer instructions per draw. Worth it when the pixel
  // takes enough samples to amortise n · (two hashes). No effect for the
  // other samplers.
  LUZ_INLINE void cache_seeds(DimSeeds* storage, uint32_t n) {
    if (desc.type != SamplerType::Sobol) return;
    for (uint32_t d = 0; d < n; ++d) storage[d] = {compute_seeds_2d(pixel_key, d), compute_seeds_1d(pixel_key, d, 0)};
    seeds = storage;
    num_seeds = n;
  }

  // Next sample of the same pixel (the pixel's hash is kept).
  LUZ_INLINE void set_sample(uint32_t sample_index) {
    index = sample_index;
    index_reversed = reverse_bits32(sample_index);
    if (desc.type == SamplerType::Independent) sample_key = hash_combine(pixel_key, sample_index);
    dim = 0;
  }

  // One 64-bit hash per (base, dimension); 1D and 2D requests get distinct keys.
  LUZ_INLINE static uint64_t dim_key(uint64_t base, uint32_t d, uint64_t kind) {
    return mix64(base + (uint64_t(d) * 3 + kind + 1) * 0x9e3779b97f4a7c15ull);
  }

  // Padded Sobol (Burley 2020, §4): each dimension visits the sequence in its
  // own order, the sample index Owen-scrambled (nested uniform scramble). Output
  // bit k of that scramble depends only on input bits ≥ k, so the first 2^m
  // indices map onto one aligned block of 2^m Sobol points: a (0,m,2)-net, the
  // stratification kept for power-of-two spp, while dimensions decorrelate.
  LUZ_INLINE uint32_t shuffle(uint32_t key) const {
    return reverse_bits32(laine_karras_permutation(index_reversed, key));  // = owen_scramble(index, key)
  }

  // The stratified sampler's draws (out of line on the CPU: its hashed
  // permutation would bloat every call site of the Sobol and independent ones).
  LUZ_CPU_NOINLINE float stratified_1d(uint32_t d, uint64_t kind = 0) const {
    uint32_t n = desc.spp, pass = index / n, i = index % n;
    uint64_t key = hash_combine(dim_key(pixel_key, d, kind), pass);
    uint32_t stratum = permute(i, n, uint32_t(key));
    float jitter = to_unit_float(hash_combine(key, i + 1));
    return min((stratum + jitter) / float(n), kOneMinusEpsilon);
  }
  LUZ_CPU_NOINLINE Vec2 stratified_2d(uint32_t d, uint64_t kind = 1) const {
    uint32_t n = desc.spp, pass = index / n, i = index % n;
    uint64_t key = hash_combine(dim_key(pixel_key, d, kind), pass);
    uint32_t stratum = permute(i, n, uint32_t(key));
    uint32_t sx = stratum % desc.strata_x, sy = stratum / desc.strata_x;
    uint64_t h = hash_combine(key, i + 1);
    float jx = to_unit_float(h), jy = float(h & 0xffffffu) * 0x1p-24f;
    return {min((sx + jx) / float(desc.strata_x), kOneMinusEpsilon),
            min((sy + jy) / float(desc.strata_y), kOneMinusEpsilon)};
  }

  // A third 32-bit seed for a 2D draw's dimension 1: the key's two halves remixed.
  LUZ_INLINE static uint32_t third_seed(uint32_t lo, uint32_t hi) { return lowbias32(lo ^ (hi * 0x9e3779b9u)); }

  LUZ_INLINE static Seeds2 compute_seeds_2d(uint64_t pixel_key, uint32_t d, uint64_t kind = 1) {
    const uint64_t key = dim_key(pixel_key, d, kind);
    const uint32_t lo = uint32_t(key), hi = uint32_t(key >> 32);
    return {lo, hi, third_seed(lo, hi)};
  }
  LUZ_INLINE static Seeds1 compute_seeds_1d(uint64_t pixel_key, uint32_t d, uint64_t kind) {
    const uint64_t key = dim_key(pixel_key, d, kind);
    return {uint32_t(key), uint32_t(key >> 32)};
  }
  LUZ_INLINE Seeds2 seeds_2d(uint32_t d) const {
#if !defined(__CUDA_ARCH__)
    if (d < num_seeds) return seeds[d].s2;
#endif
    return compute_seeds_2d(pixel_key, d);
  }
  LUZ_INLINE Seeds1 seeds_1d(uint32_t d, uint64_t kind) const {
#if !defined(__CUDA_ARCH__)
    if (kind == 0 && d < num_seeds) return seeds[d].s1;
#endif
    return compute_seeds_1d(pixel_key, d, kind);
  }

  // A 1D value at dimension d; `kind` 0 for next_1d, 2 for aux_1d (1 is
  // next_2d's): the same dimension's kinds are independent streams.
  LUZ_FORCE_INLINE float draw_1d(uint32_t d, uint64_t kind) const {
    switch (desc.type) {
      case SamplerType::Stratified:
        return stratified_1d(d, kind);
      case SamplerType::Sobol: {
        const Seeds1 s = seeds_1d(d, kind);
        return to_unit_float32(scrambled_sobol_dim0(shuffle(s.shuffle), s.x));
      }
      default:
        return to_unit_float(dim_key(sample_key, d, kind));
    }
  }

  LUZ_INLINE float next_1d() { return draw_1d(dim++, 0); }

  // A second 1D stream at dimension d, beside that dimension's regular draw
  // (for a value that a 2D draw's reuse cannot give precisely enough); does
  // not advance `dim`.
  LUZ_INLINE float aux_1d(uint32_t d) const { return draw_1d(d, 2); }

  LUZ_INLINE Vec2 next_2d() { return draw_2d(dim++); }

  // The 2D point at dimension d, without touching `dim`: the integrator draws
  // a vertex's numbers up front, so that their independent hash chains (a few
  // dozen cycles of latency each) overlap instead of running one after another.
  LUZ_FORCE_INLINE Vec2 draw_2d(uint32_t d) const {
    switch (desc.type) {
      case SamplerType::Stratified:
        return stratified_2d(d);
      case SamplerType::Sobol:
        return sobol_2d(seeds_2d(d));
      default:
        return independent_2d(d, 1);
    }
  }

  // A second 2D stream at dimension d (kind 2, as aux_1d's), beside that
  // dimension's regular draw; does not advance `dim`. Its x equals aux_1d(d)
  // (the same key), so a dimension uses one or the other. The camera's lens
  // takes it at the film's dimension, whose kind-2 stream nothing else draws:
  // a lens adds no dimension, so the path's dimensions are the same whatever
  // the camera. Never cached: only thin-lens renders pay for its seeds.
  LUZ_INLINE Vec2 aux_2d(uint32_t d) const {
    switch (desc.type) {
      case SamplerType::Stratified:
        return stratified_2d(d, 2);
      case SamplerType::Sobol:
        return sobol_2d(compute_seeds_2d(pixel_key, d, 2));
      default:
        return independent_2d(d, 2);
    }
  }

  LUZ_FORCE_INLINE Vec2 sobol_2d(const Seeds2& s) const {
    const uint32_t i = shuffle(s.shuffle);
    // scrambled_sobol_dim0(i, s.x) and scrambled_sobol_dim1(i, s.y), their
    // two bit reversals and conversions done together.
    return reversed_unit_pair(laine_karras_permutation(i, s.x), laine_karras_permutation(sobol_pascal(i), s.y));
  }
  LUZ_FORCE_INLINE Vec2 independent_2d(uint32_t d, uint64_t kind) const {
    // One 64-bit hash, two 24-bit fractions from disjoint bits.
    const uint64_t h = dim_key(sample_key, d, kind);
    return {to_unit_float(h), float(h & 0xffffffu) * 0x1p-24f};
  }
  // The 2D points at dimensions d0 and d1 (a vertex's light and BSDF
  // samples): the same numbers as draw_2d(d0) and draw_2d(d1). For Sobol the
  // bit work of the two is done side by side: both index shuffles reversed
  // in one 64-bit reversal, both Pascal transforms in one 64-bit register,
  // the four final reversals and conversions in one SSE register.
  LUZ_FORCE_INLINE void draw_2d_pair(uint32_t d0, uint32_t d1, Vec2& p0, Vec2& p1) const {
    if (desc.type != SamplerType::Sobol) {
      p0 = draw_2d(d0);
      p1 = draw_2d(d1);
      return;
    }
    const Seeds2 s0 = seeds_2d(d0), s1 = seeds_2d(d1);
    // reverse_bits64(a << 32 | b) = reverse(b) << 32 | reverse(a).
    const uint64_t i01 = reverse_bits64(uint64_t(laine_karras_permutation(index_reversed, s0.shuffle)) << 32 |
                                        laine_karras_permutation(index_reversed, s1.shuffle));
    const uint32_t i0 = uint32_t(i01), i1 = uint32_t(i01 >> 32);
    const uint64_t pas = sobol_pascal_lanes(i01);
    reversed_unit_quad(laine_karras_permutation(i0, s0.x), laine_karras_permutation(uint32_t(pas), s0.y),
                       laine_karras_permutation(i1, s1.x), laine_karras_permutation(uint32_t(pas >> 32), s1.y), p0, p1);
  }
};

// Factor spp into strata_x * strata_y, as square as the divisors allow.
inline SamplerDesc make_sampler_desc(SamplerType type, uint32_t spp, uint64_t seed) {
  SamplerDesc d;
  d.type = type;
  d.spp = spp < 1 ? 1 : spp;
  d.seed = seed;
  uint32_t sx = 1;
  for (uint32_t k = 1; k * k <= d.spp; ++k)
    if (d.spp % k == 0) sx = k;
  d.strata_x = sx;
  d.strata_y = d.spp / sx;
  return d;
}

}  // namespace luz
