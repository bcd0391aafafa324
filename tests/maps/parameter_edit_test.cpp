#include "chromo/maps/parameter_edit.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

using namespace chromo::maps;
using ::testing::HasSubstr;

namespace {

ParameterMaps uniform_maps(int width, int height, float cm, float ch, float bm, float che) {
  const std::size_t n = static_cast<std::size_t>(width) * height;
  return {width, height, std::vector<float>(n, cm), std::vector<float>(n, ch), std::vector<float>(n, bm),
          std::vector<float>(n, che), std::vector<float>(n, 0.0f)};
}

TEST(EditMask, EllipseIsFeatheredLinearlyAcrossTheOutline) {
  const cv::Mat mask = ellipse_mask(101, 101, {50, 50, 20, 20, 0}, 5.0);
  ASSERT_EQ(mask.type(), CV_32F);
  EXPECT_FLOAT_EQ(mask.at<float>(50, 50), 1.0f);  // centre
  EXPECT_FLOAT_EQ(mask.at<float>(50, 36), 1.0f);  // 6 px inside the outline: beyond the feather
  EXPECT_FLOAT_EQ(mask.at<float>(50, 94), 0.0f);  // 24 px outside
  EXPECT_NEAR(mask.at<float>(50, 70), 0.5f, 0.1f);   // on the outline
  EXPECT_NEAR(mask.at<float>(50, 67), 0.8f, 0.1f);   // 3 px inside: 0.5 + 3/10
  EXPECT_NEAR(mask.at<float>(50, 73), 0.2f, 0.1f);   // 3 px outside
  // Without feather the edge is hard.
  const cv::Mat hard = ellipse_mask(101, 101, {50, 50, 20, 20, 0}, 0.0);
  EXPECT_FLOAT_EQ(hard.at<float>(50, 67), 1.0f);
  EXPECT_FLOAT_EQ(hard.at<float>(50, 73), 0.0f);
}

TEST(EditMask, PolygonAndBadShapes) {
  const cv::Mat mask = polygon_mask(64, 64, {{{10, 10}, {50, 10}, {50, 50}, {10, 50}}}, 2.0);
  EXPECT_FLOAT_EQ(mask.at<float>(30, 30), 1.0f);
  EXPECT_FLOAT_EQ(mask.at<float>(60, 60), 0.0f);
  try {
    polygon_mask(64, 64, {{{100, 100}, {120, 100}, {120, 130}}}, 2.0);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("does not overlap the image"));
  }
  EXPECT_THROW(ellipse_mask(64, 64, {-200, -200, 10, 10, 0}, 1.0), std::invalid_argument);
  EXPECT_THROW(ellipse_mask(64, 64, {30, 30, 0, 10, 0}, 1.0), std::invalid_argument);
  EXPECT_THROW(polygon_mask(64, 64, {{{1, 1}, {5, 5}}}, 1.0), std::invalid_argument);
  EXPECT_THROW(ellipse_mask(64, 64, {30, 30, 10, 10, 0}, -1.0), std::invalid_argument);
}

TEST(EditMask, MaskImageMustMatchTheMaps) {
  const std::string path = ::testing::TempDir() + "/mask.png";
  cv::Mat image = cv::Mat::zeros(40, 30, CV_8U);
  cv::rectangle(image, {5, 5}, {20, 20}, cv::Scalar(255), cv::FILLED);
  ASSERT_TRUE(cv::imwrite(path, image));
  const cv::Mat mask = read_mask_image(path, 30, 40, 0.0);
  EXPECT_FLOAT_EQ(mask.at<float>(10, 10), 1.0f);
  EXPECT_FLOAT_EQ(mask.at<float>(30, 25), 0.0f);
  try {
    read_mask_image(path, 64, 64, 0.0);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("mask is 30x40 but the maps are 64x64"));
  }
  EXPECT_THROW(read_mask_image(::testing::TempDir() + "/none.png", 30, 40, 0.0), std::runtime_error);
}

TEST(ScaleParameters, FlushingScalesInsideTheMaskAndClampsToRanges) {
  ParameterMaps maps = uniform_maps(4, 1, 0.05f, 0.1f, 0.7f, 0.04f);
  maps.ch[3] = 0.3f;       // doubling would leave the range (0.32)
  maps.flags[2] = 8.0f;    // flagged: never edited
  cv::Mat mask(1, 4, CV_32F);
  mask.at<float>(0, 0) = 1.0f;
  mask.at<float>(0, 1) = 0.5f;
  mask.at<float>(0, 2) = 1.0f;
  mask.at<float>(0, 3) = 1.0f;
  const EditReport report = scale_parameters(maps, mask, {1.0, 2.0, 1.0, 2.0});
  EXPECT_FLOAT_EQ(maps.ch[0], 0.2f);
  EXPECT_FLOAT_EQ(maps.che[0], 0.08f);
  EXPECT_FLOAT_EQ(maps.ch[1], 0.15f);  // half mask: factor 1.5
  EXPECT_FLOAT_EQ(maps.ch[2], 0.1f);   // flagged
  EXPECT_FLOAT_EQ(maps.ch[3], 0.32f);  // clamped
  EXPECT_FLOAT_EQ(maps.cm[0], 0.05f);
  EXPECT_EQ(report.pixels_touched, 3u);
  EXPECT_EQ(report.clamped_ch, 1u);
  EXPECT_EQ(report.values_clamped, 1u);
  EXPECT_DOUBLE_EQ(report.clamped_share, 1.0 / 12.0);
}

TEST(ScaleParameters, BadFactorsOrMaskChangeNothing) {
  ParameterMaps maps = uniform_maps(2, 2, 0.05f, 0.1f, 0.7f, 0.0f);
  const cv::Mat mask = cv::Mat::ones(2, 2, CV_32F);
  EXPECT_THROW(scale_parameters(maps, mask, {1.0, -1.0, 1.0, 1.0}), std::invalid_argument);
  EXPECT_THROW(scale_parameters(maps, mask, {1.0, NAN, 1.0, 1.0}), std::invalid_argument);
  EXPECT_THROW(scale_parameters(maps, cv::Mat::ones(3, 2, CV_32F), {1.0, 2.0, 1.0, 1.0}), std::invalid_argument);
  EXPECT_FLOAT_EQ(maps.ch[0], 0.1f);
}

}  // namespace
