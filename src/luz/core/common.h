// Luz: definitions shared by host and device code.
#pragma once

#include <cstdint>
#if defined(__SSE2__) && !defined(__CUDA_ARCH__)
#include <emmintrin.h>
#endif

#if defined(__CUDACC__)
#define LUZ_HOST_DEVICE __host__ __device__
#define LUZ_DEVICE_CODE 1
#else
#define LUZ_HOST_DEVICE
#endif

#define LUZ_INLINE LUZ_HOST_DEVICE inline
// For the few hot functions the CPU compiler would otherwise call out of line
// (measured: SceneView::interaction inlined saves 2.4% of the instructions).
#if defined(__CUDACC__)
#define LUZ_FORCE_INLINE LUZ_HOST_DEVICE __forceinline__
#else
#define LUZ_FORCE_INLINE inline __attribute__((always_inline))
#endif
// The same for a lambda (after its parameter list).
#define LUZ_LAMBDA_FORCE_INLINE __attribute__((always_inline))
// Forced inline in CUDA, the compiler's choice on the CPU (for function
// templates, which need no `inline`). The path loop: nvcc's inliner would
// leave it out of the kernels (an ABI call, its state through local
// memory); on the CPU its translation units are chosen (device/cpu/path_li.cpp).
#if defined(__CUDACC__)
#define LUZ_DEVICE_FORCE_INLINE LUZ_HOST_DEVICE __forceinline__
#else
#define LUZ_DEVICE_FORCE_INLINE
#endif
// Out of line on both: a function with one copy that its callers call.
#if defined(__CUDACC__)
#define LUZ_NOINLINE LUZ_HOST_DEVICE __noinline__
#else
#define LUZ_NOINLINE LUZ_HOST_DEVICE __attribute__((noinline))
#endif
// Out of line in CUDA, inline on the CPU: code every kernel would otherwise
// hold many copies of (a texture lookup at each textured parameter), whose
// registers and instructions a kernel pays for wherever they sit, run or not.
#if defined(__CUDACC__)
#define LUZ_DEVICE_NOINLINE LUZ_HOST_DEVICE __noinline__
#else
#define LUZ_DEVICE_NOINLINE inline
#endif
// Code paths the CPU's hot loops should call rather than inline (a rarely
// chosen variant that would bloat them); inlined on the GPU.
#if defined(__CUDA_ARCH__)
#define LUZ_CPU_NOINLINE LUZ_INLINE
#else
#define LUZ_CPU_NOINLINE LUZ_HOST_DEVICE __attribute__((noinline))
#endif

namespace luz {

inline constexpr float kPi = 3.14159265358979323846f;
inline constexpr float kInvPi = 0.31830988618379067154f;
inline constexpr float kInv2Pi = 0.15915494309189533577f;
inline constexpr float kInv4Pi = 0.07957747154594766788f;
inline constexpr float kInfinity = __builtin_huge_valf();
// Largest float strictly below one: what a [0,1) sample never exceeds.
inline constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;

// x < y ? a : b without a branch, for conditions that are a coin toss per
// sample (a mispredicted branch costs more than computing both sides). GCC
// turns a plain float ?: into a branch on x86-64's SSE2 baseline; written on
// one SSE lane, the compare gives a mask and the select is and/andnot/or in
// the same registers. The GPU has a select instruction.
LUZ_INLINE float select_lt(float x, float y, float a, float b) {
#if defined(__CUDA_ARCH__) || !defined(__SSE2__)
  return x < y ? a : b;
#else
  const __m128 m = _mm_cmplt_ss(_mm_set_ss(x), _mm_set_ss(y));
  return _mm_cvtss_f32(_mm_or_ps(_mm_and_ps(m, _mm_set_ss(a)), _mm_andnot_ps(m, _mm_set_ss(b))));
#endif
}

// Both selects of a conditional swap from one compare: p = x < y ? a : b and
// q = x < y ? b : a. On the CPU the pair sits in one SSE register and its
// swapped copy is one shuffle away: half the instructions of two select_lt.
LUZ_INLINE void swap_unless_lt(float x, float y, float a, float b, float& p, float& q) {
#if defined(__CUDA_ARCH__) || !defined(__SSE2__)
  const bool lt = x < y;
  p = lt ? a : b;
  q = lt ? b : a;
#else
  const __m128 c = _mm_cmplt_ss(_mm_set_ss(x), _mm_set_ss(y));
  const __m128 m = _mm_shuffle_ps(c, c, 0);  // the mask in every lane
  const __m128 ab = _mm_unpacklo_ps(_mm_set_ss(a), _mm_set_ss(b));
  const __m128 ba = _mm_shuffle_ps(ab, ab, _MM_SHUFFLE(3, 2, 0, 1));
  const __m128 r = _mm_or_ps(_mm_and_ps(m, ab), _mm_andnot_ps(m, ba));
  p = _mm_cvtss_f32(r);
  q = _mm_cvtss_f32(_mm_shuffle_ps(r, r, 1));
#endif
}

LUZ_INLINE float min(float a, float b) { return a < b ? a : b; }
LUZ_INLINE float max(float a, float b) { return a > b ? a : b; }
LUZ_INLINE float clamp(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }
LUZ_INLINE int min(int a, int b) { return a < b ? a : b; }
LUZ_INLINE int max(int a, int b) { return a > b ? a : b; }
LUZ_INLINE uint32_t min(uint32_t a, uint32_t b) { return a < b ? a : b; }
LUZ_INLINE float sqr(float v) { return v * v; }
LUZ_INLINE float safe_sqrt(float v) { return __builtin_sqrtf(v > 0.f ? v : 0.f); }
LUZ_INLINE bool is_finite(float v) { return v - v == 0.f; }

}  // namespace luz
