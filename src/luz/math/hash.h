// Integer hashing: every random number in Luz is a pure function of
// (seed, pixel, sample index, dimension), built from these mixers.
#pragma once

#include "luz/core/common.h"

namespace luz {

// 64-bit finaliser of MurmurHash3 / splitmix64 (Stafford's "Mix13").
LUZ_INLINE uint64_t mix64(uint64_t v) {
  v ^= v >> 30;
  v *= 0xbf58476d1ce4e5b9ull;
  v ^= v >> 27;
  v *= 0x94d049bb133111ebull;
  v ^= v >> 31;
  return v;
}

// 32-bit integer hash, C. Wellons' "lowbias32".
LUZ_INLINE uint32_t lowbias32(uint32_t k) {
  k ^= k >> 16;
  k *= 0x7feb352du;
  k ^= k >> 15;
  k *= 0x846ca68bu;
  k ^= k >> 16;
  return k;
}

LUZ_INLINE uint64_t hash_combine(uint64_t h, uint64_t v) {
  return mix64(h ^ (v + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2)));
}

LUZ_INLINE uint64_t hash4(uint64_t a, uint64_t b, uint64_t c, uint64_t d) {
  return hash_combine(hash_combine(hash_combine(mix64(a), b), c), d);
}

// Uniform float in [0,1) from the top 24 bits.
LUZ_INLINE float to_unit_float(uint64_t h) { return float(h >> 40) * 0x1p-24f; }
// Uniform float in [0,1) from the top 24 bits of a 32-bit value (exact: no
// rounding up to 1).
LUZ_INLINE float to_unit_float32(uint32_t h) { return float(h >> 8) * 0x1p-24f; }

#if !defined(__CUDA_ARCH__)
namespace detail {
// Bit-reversed bytes: x86 has no bit-reverse instruction and GCC no builtin;
// four table look-ups beat the shift-and-mask network (measured by callgrind).
struct ByteReverseTable {
  uint8_t v[256];
  constexpr ByteReverseTable() : v() {
    for (int i = 0; i < 256; ++i) {
      int r = 0;
      for (int b = 0; b < 8; ++b) r |= ((i >> b) & 1) << (7 - b);
      v[i] = uint8_t(r);
    }
  }
};
inline constexpr ByteReverseTable kByteReverse{};
}  // namespace detail
#endif

LUZ_INLINE uint32_t reverse_bits32(uint32_t v) {
#if defined(__CUDA_ARCH__)
  return __brev(v);
#else
  const uint8_t* t = detail::kByteReverse.v;
  return (uint32_t(t[v & 0xff]) << 24) | (uint32_t(t[(v >> 8) & 0xff]) << 16) | (uint32_t(t[(v >> 16) & 0xff]) << 8) |
         uint32_t(t[v >> 24]);
#endif
}

// Reverses all 64 bits: two 32-bit reversals in one, (hi, lo) -> (rev lo, rev hi).
LUZ_INLINE uint64_t reverse_bits64(uint64_t v) {
#if defined(__CUDA_ARCH__)
  return __brevll(v);
#else
  v = __builtin_bswap64(v);
  v = ((v >> 4) & 0x0f0f0f0f0f0f0f0full) | ((v & 0x0f0f0f0f0f0f0f0full) << 4);
  v = ((v >> 2) & 0x3333333333333333ull) | ((v & 0x3333333333333333ull) << 2);
  v = ((v >> 1) & 0x5555555555555555ull) | ((v & 0x5555555555555555ull) << 1);
  return v;
#endif
}

}  // namespace luz
