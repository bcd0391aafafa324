// The common view's pieces (maps/common_view.hpp) on flags maps drawn from a
// known quadrilateral: the outline's corners, the homography between two
// outlines against the one that drew them, the resampling's categorical and
// outside cells, and the errors for a target not wholly in view.
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>

#include "chromo/estimation/pixel_flags.hpp"
#include "chromo/maps/common_view.hpp"

namespace chromo::maps {
namespace {

constexpr float kOutside = static_cast<float>(estimation::PixelFlag::kNoReference);

// A 160×120 map whose cells with centres inside `quad` see the target.
files::FloatImage flags_inside(const std::vector<cv::Point2f>& quad) {
  files::FloatImage maps;
  maps.width = 160, maps.height = 120;
  maps.channel_names = {"Cm", "flags"};
  maps.channels.assign(2, std::vector<float>(160 * 120));
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) {
      const bool in = cv::pointPolygonTest(quad, cv::Point2f(x, y), false) >= 0;
      maps.channels[0][y * 160 + x] = in ? 0.01f * static_cast<float>(x) : NAN;
      maps.channels[1][y * 160 + x] = in ? 0.0f : kOutside;
    }
  return maps;
}

TEST(CommonView, TheOutlineCornersAndTheHomographyAreWithinAFractionOfACell) {
  const std::vector<cv::Point2f> a{{30.3f, 20.6f}, {131.2f, 25.1f}, {127.4f, 98.2f}, {34.1f, 95.7f}};
  const std::vector<cv::Point2f> b{{20.8f, 15.2f}, {110.5f, 22.9f}, {118.3f, 103.4f}, {25.6f, 90.1f}};
  const auto outline_a = find_target_outline(flags_inside(a), "a");
  const auto outline_b = find_target_outline(flags_inside(b), "b");
  for (int k = 0; k < 4; ++k) {
    EXPECT_LT(cv::norm(outline_a.corners[k] - cv::Point2d(a[k])), 0.5) << k;
    EXPECT_LT(cv::norm(outline_b.corners[k] - cv::Point2d(b[k])), 0.5) << k;
  }
  const auto mapping = map_onto_reference(outline_b, outline_a);
  const cv::Matx33d truth(cv::getPerspectiveTransform(b.data(), a.data()));
  for (double u = 40; u < 110; u += 10)
    for (double v = 30; v < 90; v += 10) {
      const cv::Vec3d p = mapping.to_reference * cv::Vec3d(u, v, 1), q = truth * cv::Vec3d(u, v, 1);
      EXPECT_LT(std::hypot(p[0] / p[2] - q[0] / q[2], p[1] / p[2] - q[1] / q[2]), 0.5) << u << "," << v;
    }
  EXPECT_GT(mapping.outline_cells, 200u);
  EXPECT_LT(mapping.residual_px, 0.5);
}

TEST(CommonView, ResamplingKeepsFlagsCategoricalAndMarksCellsItCannotSee) {
  auto maps = flags_inside({{30, 20}, {130, 20}, {130, 100}, {30, 100}});
  maps.channels[1][60 * 160 + 80] = 3;  // one flagged cell
  const cv::Matx33d shift(1, 0, 0.5, 0, 1, 0, 0, 0, 1);  // half a cell right
  const auto common = resample_into_common_view(maps, shift, 100, 100);
  const auto& flags = common.channel("flags");
  const auto& cm = common.channel("Cm");
  for (int x : {80, 81}) EXPECT_TRUE(flags[60 * 100 + x] == 0 || flags[60 * 100 + x] == 3) << x;  // never between
  EXPECT_TRUE(flags[60 * 100 + 80] == 3 || flags[60 * 100 + 81] == 3);
  EXPECT_NEAR(cm[50 * 100 + 70], 0.01 * 69.5, 1e-5);              // bilinear between 69 and 70
  EXPECT_EQ(flags[10 * 100 + 10], kOutside);
  EXPECT_TRUE(std::isnan(cm[10 * 100 + 10]));
}

TEST(CommonView, ATargetNotWhollyInViewIsRefusedNamingTheMaps) {
  try {
    find_target_outline(flags_inside({{-5, 20}, {130, 20}, {130, 100}, {-5, 100}}), "side's maps");
    FAIL() << "no error";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("side's maps: the white target reaches the map's left or right edge"),
              std::string::npos)
        << error.what();
  }
  auto none = flags_inside({{30, 20}, {130, 20}, {130, 100}, {30, 100}});
  std::fill(none.channels[1].begin(), none.channels[1].end(), kOutside);
  EXPECT_THROW(find_target_outline(none, "x"), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::maps
