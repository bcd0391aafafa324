// The optical highlight flag (estimation/highlight_flags.hpp) on synthetic
// surface maps with Gaussian noise of known σ: sheen-only skin, blocks of
// 1, 2, 4 and 10σ above the sheen, a map without a parallel capture's values.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

#include "chromo/estimation/highlight_flags.hpp"

namespace chromo::estimation {
namespace {

struct Map {
  int width = 200, height = 200;
  std::vector<float> surface, sigma, added_sigmas;
};

// Four 40×40 blocks at 1, 2, 4, 10σ above a sheen of 0.0272 (1:200's share of F), σ = 0.0015.
Map synthetic_map(std::uint64_t seed) {
  Map m;
  const double sigma = 0.0015, sheen = 0.0272;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, sigma);
  m.surface.resize(m.width * m.height), m.sigma.assign(m.width * m.height, sigma), m.added_sigmas.resize(m.width * m.height);
  const double strengths[4] = {1, 2, 4, 10};
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) {
      double n = 0;
      if (y >= 20 && y < 60 && x % 50 < 40) n = strengths[x / 50];
      const std::size_t i = static_cast<std::size_t>(y) * m.width + x;
      m.added_sigmas[i] = static_cast<float>(n);
      m.surface[i] = static_cast<float>(sheen + n * sigma + noise(rng));
    }
  return m;
}

TEST(HighlightFlags, FlagsFourSigmaHighlightsAndLeavesSheenOnlySkin) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const Map m = synthetic_map(seed);
    const HighlightFlags f = flag_highlights(m.surface, m.sigma, m.width, m.height);
    // The median sits above the sheen when 16% of the pixels are highlights: at the
    // 0.5/0.84 quantile of the skin's noise, +0.24σ = +0.00036.
    EXPECT_NEAR(f.sheen_reference, 0.0272 + 0.00036, 1e-4);
    std::size_t skin = 0, skin_flagged = 0, at[11] = {}, flagged_at[11] = {};
    for (std::size_t i = 0; i < m.surface.size(); ++i) {
      const int n = static_cast<int>(m.added_sigmas[i]);
      if (n == 0) ++skin, skin_flagged += f.flag[i];
      else ++at[n], flagged_at[n] += f.flag[i];
    }
    const double skin_rate = double(skin_flagged) / skin;
    EXPECT_LE(skin_rate, 0.01) << "seed " << seed;       // includes the 1-pixel rims around the blocks
    EXPECT_GE(double(flagged_at[4]) / at[4], 0.95) << "seed " << seed;
    EXPECT_GE(double(flagged_at[10]) / at[10], 0.999) << "seed " << seed;
    EXPECT_LT(double(flagged_at[1]) / at[1], 0.5) << "seed " << seed;
  }
}

TEST(HighlightFlags, AnOilyMajorityDoesNotRaiseTheSheenAboveFresnel) {
  Map m = synthetic_map(4);
  for (float& s : m.surface) s += 0.01f;  // every pixel oily: the median is 0.037
  const HighlightFlags f = flag_highlights(m.surface, m.sigma, m.width, m.height);
  EXPECT_DOUBLE_EQ(f.sheen_reference, kSheenAtNormal);
  EXPECT_GT(f.flagged, m.surface.size() * 9 / 10);
}

TEST(HighlightFlags, NaNIsNeverFlaggedAndBadInputIsRefused) {
  Map m = synthetic_map(5);
  for (std::size_t i = 0; i < m.surface.size(); i += 2) m.surface[i] = NAN;
  const HighlightFlags f = flag_highlights(m.surface, m.sigma, m.width, m.height);
  for (std::size_t i = 0; i < m.surface.size(); i += 2) EXPECT_EQ(f.flag[i], 0);
  EXPECT_GT(f.flagged, 1000u);
  EXPECT_THROW(flag_highlights(m.surface, m.sigma, m.width + 1, m.height), std::invalid_argument);
  HighlightFlagOptions bad;
  bad.window_sigmas = 0;
  EXPECT_THROW(flag_highlights(m.surface, m.sigma, m.width, m.height, bad), std::invalid_argument);
  const std::vector<float> none(m.surface.size(), NAN);
  EXPECT_EQ(flag_highlights(none, m.sigma, m.width, m.height).flagged, 0u);
}

}  // namespace
}  // namespace chromo::estimation
