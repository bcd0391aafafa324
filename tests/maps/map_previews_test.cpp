// The preview PNGs (maps/map_previews.hpp) decoded again: masked pixels grey,
// pixels outside the field black, the contrast's ends at viridis' ends; the
// subject's percentile range from the shown pixels only.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/imgcodecs.hpp>

#include "chromo/maps/map_previews.hpp"

using namespace chromo;

namespace {

TEST(MapPreviews, MaskedAndOutsideTheFieldAreDrawnApart) {
  const int width = 4, height = 2;
  const std::vector<float> values = {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, std::numeric_limits<float>::quiet_NaN(), 0.0f, 1.0f};
  std::vector<std::uint8_t> hide(8, maps::kPreviewShown);
  hide[1] = maps::kPreviewMasked;
  hide[5] = maps::kPreviewOutsideField;
  const std::vector<std::uint8_t> png = maps::encode_map_png(values, width, height, 0.0, 1.0, false, "Cm\nvolume fraction", hide);
  const cv::Mat image = cv::imdecode(png, cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.at<cv::Vec3b>(0, 1), cv::Vec3b(150, 150, 150));  // masked: grey
  EXPECT_EQ(image.at<cv::Vec3b>(1, 1), cv::Vec3b(0, 0, 0));        // outside the field: black
  const cv::Vec3b low = image.at<cv::Vec3b>(1, 2), high = image.at<cv::Vec3b>(1, 3);  // viridis: purple → yellow (BGR)
  EXPECT_GT(low[0], low[1]);
  EXPECT_GT(high[2], 200);
  EXPECT_LT(high[0], 100);
}

// The scale bar (docs/maps.md "Scale bar"): the longest 1-2-5 mm length
// within a quarter of the map, drawn as that many white map pixels; none
// when the pixel size is unknown.
TEST(MapPreviews, TheScaleBarIsItsLengthInMapPixels) {
  EXPECT_EQ(maps::scale_bar_for(320, 0.25).mm, 20);   // 80 mm across: a quarter is 20 mm
  EXPECT_EQ(maps::scale_bar_for(320, 0.25).px, 80);
  EXPECT_EQ(maps::scale_bar_for(200, 0.25).mm, 10);   // 50 mm across: 12.5 → 10 mm
  EXPECT_EQ(maps::scale_bar_for(200, 0.25).px, 40);
  EXPECT_EQ(maps::scale_bar_for(160, 0.5175).mm, 20); // 82.8 mm across: 20.7 → 20 mm, 38.6 → 39 px
  EXPECT_EQ(maps::scale_bar_for(160, 0.5175).px, 39);
  EXPECT_EQ(maps::scale_bar_for(320, 0).px, 0);
  const int width = 200, height = 100;
  const std::vector<float> values(static_cast<std::size_t>(width) * height, 0.5f);
  const auto white_in_row = [&](double map_pixel_mm) {
    const cv::Mat image = cv::imdecode(maps::encode_map_png(values, width, height, 0, 1, false, "Cm", {}, map_pixel_mm),
                                       cv::IMREAD_COLOR);
    int white = 0;
    for (int x = 0; x < width; ++x) white += image.at<cv::Vec3b>(height - 10, x) == cv::Vec3b(255, 255, 255);
    return white;
  };
  EXPECT_EQ(white_in_row(0.25), 40);  // 10 mm of 0.25 mm pixels
  EXPECT_EQ(white_in_row(0.2), 50);   // 40 mm across: 10 mm of 0.2 mm pixels
  EXPECT_EQ(white_in_row(0), 0);      // unknown: no bar
}

TEST(MapPreviews, PercentileRangeComesFromTheShownPixelsOnly) {
  std::vector<float> values(101);
  for (int i = 0; i <= 100; ++i) values[i] = static_cast<float>(i);
  std::vector<std::uint8_t> hide(101, maps::kPreviewShown);
  auto range = maps::shown_percentile_range(values, hide, 1, 99);
  ASSERT_TRUE(range);
  EXPECT_EQ(range->first, 1.0);
  EXPECT_EQ(range->second, 99.0);
  for (int i = 50; i <= 100; ++i) hide[i] = maps::kPreviewMasked;  // only 0-49 shown
  range = maps::shown_percentile_range(values, hide, 0, 100);
  ASSERT_TRUE(range);
  EXPECT_EQ(range->second, 49.0);
  std::fill(hide.begin(), hide.end(), maps::kPreviewOutsideField);
  EXPECT_FALSE(maps::shown_percentile_range(values, hide, 1, 99));
  EXPECT_EQ(maps::model_display_range("Cm")->high, 0.5);
  EXPECT_TRUE(maps::model_display_range("Cm")->log_scale);
  EXPECT_FALSE(maps::model_display_range("residual"));
}

}  // namespace
