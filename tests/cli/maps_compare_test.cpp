// `chromo maps compare` on the virtual lab's skin scene measured twice (two
// draws of the camera noise), the second time with Ch × 1.5 in a known
// rectangle: the difference map finds the rectangle (≥ 95% of its compared
// pixels beyond 3σ) and nothing else (≤ 1% of the other skin), with the σ of
// both sessions' σ maps.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "chromo/files/float_image.hpp"
#include "run_chromo.hpp"

namespace fs = std::filesystem;
using ::testing::HasSubstr;

namespace {

TEST(MapsCompare, FindsAChFlushOfOneAndAHalfTimesAndNothingElse) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("chromo-maps-compare-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string d = dir.string();
  const std::string scene = " --width 96 --height 72 --camera-noise 1";
  const int x0 = 38, y0 = 32, w = 20, h = 14;  // the flushed rectangle, in map pixels
  ASSERT_EQ(run_chromo("make-maps-test-data --out " + d + "/before" + scene).exit_status, 0);
  const Result after = run_chromo("make-maps-test-data --out " + d + "/after" + scene +
                                  " --noise-seed 2 --ch-factor 1.5 --ch-change 38,32,20,14");
  ASSERT_EQ(after.exit_status, 0) << after.output;
  for (const char* session : {"before", "after"}) {
    const Result r = run_chromo("estimate " + d + "/" + session + "/MEASUREMENT.json --out " + d + "/" + session +
                                "/results --cache-dir " + d + "/cache");
    ASSERT_EQ(r.exit_status, 0) << r.output;
  }
  const Result compared = run_chromo("maps compare " + d + "/before " + d + "/after --channel Ch --region 38,32,20,14 --out " +
                                     d + "/difference");
  ASSERT_EQ(compared.exit_status, 0) << compared.output;
  const auto summary = nlohmann::json::parse(compared.output);
  const chromo::files::FloatImage maps = chromo::files::read_exr(dir / "difference" / "difference.exr");
  const auto& z = maps.channel("z");
  const auto& significant = maps.channel("significant");
  long inside = 0, inside_found = 0, outside = 0, outside_found = 0;
  for (int y = 0; y < maps.height; ++y)
    for (int x = 0; x < maps.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * maps.width + x;
      if (!std::isfinite(z[i])) continue;  // not skin in both sessions
      const bool in = x >= x0 && x < x0 + w && y >= y0 && y < y0 + h;
      (in ? inside : outside) += 1;
      (in ? inside_found : outside_found) += significant[i] > 0.5f;
    }
  const double found_share = static_cast<double>(inside_found) / static_cast<double>(inside);
  const double false_share = static_cast<double>(outside_found) / static_cast<double>(outside);
  std::printf("Ch x1.5 in %dx%d px: %ld of %ld compared pixels found beyond 3 sigma (%.1f%%); elsewhere %ld of %ld (%.2f%%); "
              "mean Ch %.4f -> %.4f; registration motion %.3f px\n",
              w, h, inside_found, inside, 100 * found_share, outside_found, outside, 100 * false_share,
              summary["region"]["before"]["mean"].get<double>(), summary["region"]["after"]["mean"].get<double>(),
              summary["registration"]["motion_px"].get<double>());
  EXPECT_GT(inside, w * h * 3 / 4);  // most of the rectangle is skin compared in both sessions
  EXPECT_GE(found_share, 0.95);
  EXPECT_LE(false_share, 0.01);
  EXPECT_NEAR(summary["region"]["after"]["mean"].get<double>() / summary["region"]["before"]["mean"].get<double>(), 1.5, 0.1);
  EXPECT_FALSE(summary["registration"]["warped"].get<bool>());  // one set-up, a still subject: no warp
  EXPECT_TRUE(fs::exists(dir / "difference" / "difference.png"));

  // Bad input changes nothing and names the problem.
  const Result missing_sigma = run_chromo("maps compare " + d + "/before " + d + "/after --channel residual --out " + d + "/bad");
  EXPECT_EQ(missing_sigma.exit_status, 2);
  EXPECT_THAT(missing_sigma.output, HasSubstr("before: the maps have no channel \"sigma_residual\""));
  EXPECT_FALSE(fs::exists(dir / "bad"));
  fs::remove_all(dir);
}

}  // namespace
