// `chromo maps compare` on the virtual lab's skin scene measured twice (two
// draws of the camera noise), the second time with Ch × 1.5 in a known
// rectangle. Per pixel that change is a quarter of the difference's σ
// (undetectable: the per-pixel count is only printed); per region it is
// found: the rectangle's median difference is beyond 3σ of the median, and
// of every other window of the same size over the skin (sliding by 2
// pixels) at most 1% is. The maps are made per pixel (--skin-denoise off):
// the region's σ of the median assumes independent pixels, which the
// multi-pixel estimate's maps are not (each averages ~85 neighbours' colour);
// on them 154 of 292 windows away from the flush were beyond 3σ
// (docs/maps.md "Two sessions side by side").
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "chromo/files/float_image.hpp"
#include "chromo/maps/session_difference.hpp"
#include "run_chromo.hpp"

namespace fs = std::filesystem;
using ::testing::HasSubstr;

namespace {

TEST(MapsCompare, FindsAChFlushOfOneAndAHalfTimesInItsRegionAndNotElsewhere) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("chromo-maps-compare-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string d = dir.string();
  const std::string scene = " --width 96 --height 72 --camera-noise 1";
  const chromo::maps::PixelRectangle flushed{6, 6, 36, 28};  // in map pixels
  ASSERT_EQ(run_chromo("make-maps-test-data --out " + d + "/before" + scene).exit_status, 0);
  const Result after = run_chromo("make-maps-test-data --out " + d + "/after" + scene +
                                  " --noise-seed 2 --ch-factor 1.5 --ch-change 6,6,36,28");
  ASSERT_EQ(after.exit_status, 0) << after.output;
  for (const char* session : {"before", "after"}) {
    const Result r = run_chromo("estimate " + d + "/" + session + "/MEASUREMENT.json --out " + d + "/" + session +
                                "/results --cache-dir " + d + "/cache --skin-denoise off");
    ASSERT_EQ(r.exit_status, 0) << r.output;
  }
  const Result compared = run_chromo("maps compare " + d + "/before " + d + "/after --channel Ch --region 6,6,36,28 --out " +
                                     d + "/difference");
  ASSERT_EQ(compared.exit_status, 0) << compared.output;
  const auto summary = nlohmann::json::parse(compared.output);
  const auto& change = summary["region"]["change"];
  std::printf("Ch x1.5 in 36x28 px: mean Ch %.4f -> %.4f, median Ch %.4f -> %.4f; median difference %.4f, its sigma "
              "%.4f, z %.2f (mean difference %.4f, sigma of the mean from the sigma maps %.4f); per pixel %lld of %lld "
              "compared pixels beyond 3 sigma\n",
              summary["region"]["before"]["mean"].get<double>(), summary["region"]["after"]["mean"].get<double>(),
              summary["region"]["before"]["median"].get<double>(), summary["region"]["after"]["median"].get<double>(),
              change["median_difference"].get<double>(), change["sigma_of_median"].get<double>(),
              change["z"].get<double>(), change["mean_difference"].get<double>(),
              change["sigma_of_mean_from_sigma_maps"].get<double>(), summary["significant_pixels"].get<long long>(),
              summary["compared_pixels"].get<long long>());
  EXPECT_GT(change["pixels"].get<long>(), 36 * 28 * 3 / 4);  // most of the rectangle is skin in both sessions
  EXPECT_TRUE(change["significant"].get<bool>());
  EXPECT_GT(change["z"].get<double>(), 3.0);
  EXPECT_FALSE(summary["registration"]["warped"].get<bool>());  // one set-up, a still subject: no warp
  EXPECT_TRUE(fs::exists(dir / "difference" / "difference.png"));

  // Every other window of the rectangle's size, mostly skin, away from it.
  const chromo::files::FloatImage maps = chromo::files::read_exr(dir / "difference" / "difference.exr");
  chromo::maps::SessionDifference difference;
  difference.width = maps.width, difference.height = maps.height;
  difference.difference = maps.channel("difference"), difference.sigma = maps.channel("sigma_difference");
  long windows = 0, significant = 0;
  for (int y = 0; y + flushed.height <= maps.height; y += 2)
    for (int x = 0; x + flushed.width <= maps.width; x += 2) {
      const bool apart = x + flushed.width <= flushed.x || x >= flushed.x + flushed.width ||
                         y + flushed.height <= flushed.y || y >= flushed.y + flushed.height;
      if (!apart) continue;
      const auto r = chromo::maps::region_difference(difference, {x, y, flushed.width, flushed.height}, 3.0);
      if (r.pixels < flushed.width * flushed.height * 3 / 4) continue;
      ++windows, significant += r.significant;
    }
  std::printf("elsewhere: %ld of %ld windows of 36x28 px beyond 3 sigma of their median\n", significant, windows);
  EXPECT_GT(windows, 50);
  EXPECT_LE(static_cast<double>(significant), 0.01 * static_cast<double>(windows));

  // Bad input changes nothing and names the problem.
  const Result missing_sigma = run_chromo("maps compare " + d + "/before " + d + "/after --channel residual --out " + d + "/bad");
  EXPECT_EQ(missing_sigma.exit_status, 2);
  EXPECT_THAT(missing_sigma.output, HasSubstr("before: the maps have no channel \"sigma_residual\""));
  EXPECT_FALSE(fs::exists(dir / "bad"));
  const Result outside = run_chromo("maps compare " + d + "/before " + d + "/after --region 90,60,20,14");
  EXPECT_EQ(outside.exit_status, 2);
  EXPECT_THAT(outside.output, HasSubstr("region")) << outside.output;
  fs::remove_all(dir);
}

}  // namespace
