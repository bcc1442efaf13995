// The progress report (device/progress.h): h:mm:ss times, every field while
// the width allows, never wider than the terminal (a bar filling the rest),
// fields dropped in order when narrow.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "luz/device/progress.h"

namespace {

using luz::hms;
using luz::progress_text;

TEST(Progress, HoursMinutesSeconds) {
  EXPECT_EQ(hms(0), "0:00:00");
  EXPECT_EQ(hms(59.4), "0:00:59");
  EXPECT_EQ(hms(61), "0:01:01");
  EXPECT_EQ(hms(3600 * 27 + 62), "27:01:02");
  EXPECT_EQ(hms(-1), "--:--:--");
  EXPECT_EQ(hms(std::nan("")), "--:--:--");
}

TEST(Progress, FitsTheWidthWithTheFieldsThatFit) {
  // 1/4 done in 100 s: ETA 300 s; 256 of 1024 spp; 1e6 samples in 100 s.
  const uint64_t total = 4000000, done = 1000000;
  const std::string wide = progress_text(done, total, 256, 1024, 100, 200, true);
  EXPECT_EQ(wide.size(), 200u);
  for (const char* f : {" 25.0%", "0:01:40 elapsed", "ETA 0:05:00", "256/1024 spp", "0.01 Msamples/s"})
    EXPECT_NE(wide.find(f), std::string::npos) << f << " in " << wide;
  EXPECT_EQ(wide.rfind("[", 0), 0u);
  // A quarter of the bar's cells filled.
  const size_t close = wide.find(']');
  const size_t hashes = std::count(wide.begin(), wide.begin() + long(close), '#');
  EXPECT_EQ(hashes, (close - 1) / 4);
  for (int width : {120, 80, 50, 40, 30, 20, 10, 0}) {
    const std::string t = progress_text(done, total, 256, 1024, 100, width, true);
    EXPECT_LE(int(t.size()), width) << t;
    if (width >= 50) {
      EXPECT_NE(t.find("ETA 0:05:00"), std::string::npos) << width << ": " << t;
      EXPECT_NE(t.find("25.0%"), std::string::npos) << width << ": " << t;
    }
  }
  const std::string line = progress_text(done, total, 256, 1024, 100, 1 << 20, false);
  EXPECT_EQ(line, " 25.0%  0:01:40 elapsed  ETA 0:05:00  256/1024 spp  0.01 Msamples/s");
  // Nothing done yet: no ETA to tell.
  EXPECT_NE(progress_text(0, total, 0, 1024, 0, 1 << 20, false).find("ETA --:--:--"), std::string::npos);
}

}  // namespace
