// Bitwise comparison of films: sums, sums of squares and counts.
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "luz/film/film.h"

inline void expect_same_film(const luz::Film& a, const luz::Film& b, const std::string& what) {
  ASSERT_EQ(a.width, b.width) << what;
  ASSERT_EQ(a.height, b.height) << what;
  size_t diff = 0;
  for (size_t i = 0; i < a.sum.size(); ++i)
    diff += a.sum[i] != b.sum[i] || a.sum_sq[i] != b.sum_sq[i] || a.count[i / 3] != b.count[i / 3];
  EXPECT_EQ(diff, 0u) << what << ": " << diff << " of " << a.sum.size() << " values differ";
}
