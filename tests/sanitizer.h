// Whether the test runs under AddressSanitizer (scripts/sanitize's build).
#pragma once

namespace luz_test {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kAsan = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kAsan = true;
#else
inline constexpr bool kAsan = false;
#endif
#else
inline constexpr bool kAsan = false;
#endif

// The sample count of a statistical test whose threshold follows from the
// count or the measured variance: a quarter under the sanitizers, which look
// for memory errors and UB (found as well in fewer samples, at -O1 and 3-10x
// the cost); the Release run keeps the full count and power. Not for
// negative controls, whose power is what they test.
template <class T>
constexpr T sanitized_count(T n) {
  return kAsan ? n / 4 : n;
}

// Skips, under the sanitizers only, a test that repeats on the Wooden
// Staircase (5-12 s a load under ASan) code that other sanitized tests run
// on it or on smaller scenes: reported as skipped there, with `why`; the
// Release run keeps it. The first statement of a test body (GTEST_SKIP).
#define LUZ_SKIP_UNDER_SANITIZERS(why) \
  if (::luz_test::kAsan) GTEST_SKIP() << "under the sanitizers: " << (why)

}  // namespace luz_test
