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

LUZ_INLINE uint64_t hash_combine(uint64_t h, uint64_t v) {
  return mix64(h ^ (v + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2)));
}

LUZ_INLINE uint64_t hash4(uint64_t a, uint64_t b, uint64_t c, uint64_t d) {
  return hash_combine(hash_combine(hash_combine(mix64(a), b), c), d);
}

// Uniform float in [0,1) from the top 24 bits.
LUZ_INLINE float to_unit_float(uint64_t h) { return float(h >> 40) * 0x1p-24f; }
LUZ_INLINE float to_unit_float32(uint32_t h) { return min(float(h) * 0x1p-32f, kOneMinusEpsilon); }

LUZ_INLINE uint32_t reverse_bits32(uint32_t v) {
#if defined(__CUDA_ARCH__)
  return __brev(v);
#else
  v = ((v >> 1) & 0x55555555u) | ((v & 0x55555555u) << 1);
  v = ((v >> 2) & 0x33333333u) | ((v & 0x33333333u) << 2);
  v = ((v >> 4) & 0x0f0f0f0fu) | ((v & 0x0f0f0f0fu) << 4);
  return __builtin_bswap32(v);
#endif
}

}  // namespace luz
