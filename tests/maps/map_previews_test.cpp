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
