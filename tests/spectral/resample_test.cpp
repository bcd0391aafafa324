#include "chromo/spectral/resample.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <vector>

using namespace chromo::spectral;
using ::testing::HasSubstr;

namespace {

TEST(Resample, CoarseTableIsInterpolatedLinearly) {
  // 10 nm table y = λ² : grid points between samples get the chord value.
  std::vector<double> wl, v;
  for (double w = 370; w <= 790; w += 10) {
    wl.push_back(w);
    v.push_back(w * w);
  }
  const Spectrum s = resample_to_grid(wl, v, "square");
  EXPECT_DOUBLE_EQ(s[0], 380.0 * 380.0);                          // 380 nm is a sample
  EXPECT_DOUBLE_EQ(s[1], (380.0 * 380.0 + 390.0 * 390.0) / 2.0);  // 385 nm: chord midpoint
}

TEST(Resample, FineTableIsAveragedOverEachBin) {
  // 2 nm samples: the 380 nm bin [377.5, 382.5) holds 378, 380, 382; the
  // 385 nm bin holds 384, 386. Values = wavelength, so means are exact.
  std::vector<double> wl, v;
  for (double w = 360; w <= 800; w += 2) {
    wl.push_back(w);
    v.push_back(w == 380 ? 1000.0 : w);
  }
  const Spectrum s = resample_to_grid(wl, v, "ramp");
  EXPECT_DOUBLE_EQ(s[0], (378.0 + 1000.0 + 382.0) / 3.0);
  EXPECT_DOUBLE_EQ(s[1], (384.0 + 386.0) / 2.0);
  EXPECT_DOUBLE_EQ(s[80], (778.0 + 780.0 + 782.0) / 3.0);
}

TEST(Resample, IrregularFineTableWithGapFallsBackToInterpolation) {
  std::vector<double> wl{379.0, 380.5, 381.0, 382.0, 390.0, 781.0};
  std::vector<double> v{1.0, 2.0, 3.0, 4.0, 12.0, 1.0};
  // Median spacing is 1 nm (fine). 385 nm bin [382.5, 387.5) is empty:
  // interpolate between 382 (4) and 390 (12) → 7.
  const Spectrum s = resample_to_grid(wl, v, "irregular");
  EXPECT_DOUBLE_EQ(s[0], (1.0 + 2.0 + 3.0 + 4.0) / 4.0);
  EXPECT_DOUBLE_EQ(s[1], 7.0);
}

TEST(Resample, OutsideCoveredRangeIsAnErrorUnlessZeroRequested) {
  std::vector<double> wl{400, 405, 410, 700}, v{1, 1, 1, 1};
  try {
    resample_to_grid(wl, v, "short table");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("short table: covers 400"));
    EXPECT_THAT(e.what(), HasSubstr("needs 380-780 nm"));
  }
  const Spectrum s = resample_to_grid(wl, v, "filter", OutsideRange::kZero);
  EXPECT_EQ(s[0], 0.0);   // 380 nm: outside
  EXPECT_EQ(s[4], 1.0);   // 400 nm
  EXPECT_EQ(s[80], 0.0);  // 780 nm: outside
}

TEST(Resample, RejectsUnsortedMismatchedAndNonFinite) {
  EXPECT_THROW(resample_to_grid(std::vector<double>{380, 380, 780}, std::vector<double>{1, 1, 1}, "dup"), DataError);
  EXPECT_THROW(resample_to_grid(std::vector<double>{780, 380}, std::vector<double>{1, 1}, "desc"), DataError);
  EXPECT_THROW(resample_to_grid(std::vector<double>{380, 780}, std::vector<double>{1}, "size"), DataError);
  EXPECT_THROW(resample_to_grid(std::vector<double>{380, 780}, std::vector<double>{1, INFINITY}, "inf"), DataError);
}

}  // namespace
