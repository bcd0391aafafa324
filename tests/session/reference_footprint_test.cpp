// A posed camera's white references (issue 21 part 4): the camera sees the
// white target as a quadrilateral with dark around it. Its white means and
// noise come from its footprint only, so its noise model equals that of a
// camera whose target fills the frame; outside the footprint the
// measurement has no albedo and lists the pixels as no_reference.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <random>

#include "chromo/session/method_measurement.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/cie.hpp"

namespace chromo::session {
namespace {

constexpr int kWidth = 120, kHeight = 90;
constexpr double kDark = 0.02, kSigma = 0.002;

// An image of `level` per channel inside `footprint` (everywhere when empty),
// the dark level outside, with Gaussian noise.
// texture: the level times a smooth pattern of mean 1 (a subject registration can lock on).
RgbImage image(std::array<double, 3> level, const cv::Mat& footprint, std::mt19937& random, bool texture = false) {
  std::normal_distribution<double> noise(0, kSigma);
  RgbImage out;
  out.width = kWidth, out.height = kHeight;
  for (int c = 0; c < 3; ++c) {
    out.planes[c].resize(out.pixels());
    for (std::size_t i = 0; i < out.pixels(); ++i) {
      const bool inside = footprint.empty() || footprint.at<std::uint8_t>(static_cast<int>(i)) != 0;
      const int x = static_cast<int>(i % kWidth), y = static_cast<int>(i / kWidth);
      const double pattern = texture ? 1 + 0.3 * std::sin(x / 4.0) * std::cos(y / 5.0) : 1.0;
      out.planes[c][i] = static_cast<float>(kDark + (inside ? level[c] * pattern : 0.0) + noise(random));
    }
  }
  return out;
}

Captures captures(const cv::Mat& footprint, std::uint32_t seed) {
  std::mt19937 random(seed);
  Captures c;
  c.camera = spectral::builtin_camera("nikon_d5100");
  c.dark = image({0, 0, 0}, footprint, random);
  const std::array<double, 3> whites[3] = {{0.5, 0.5, 0.5}, {0.5, 0.5, 0.3}, {0.5, 0.5, 0.6}};
  c.recipe = standard_recipe();
  c.captures.resize(3);
  IlluminatedCapture* targets[3] = {&c.captures[0], &c.captures[1], &c.captures[2]};
  const char* names[3] = {"D65'", "W57", "W57+blue"};
  for (int k = 0; k < 3; ++k) {
    targets[k]->name = names[k];
    targets[k]->illuminant = spectral::illuminant_d65() * (k == 2 ? 1.5 : 1.0);
    targets[k]->white = image(whites[k], footprint, random);
    std::array<double, 3> subject = whites[k];
    for (double& v : subject) v *= 0.5;  // albedo 0.5 · ρ
    targets[k]->subject = image(subject, footprint, random, true);
  }
  return c;
}

TEST(ReferenceFootprint, APosedCamerasWhiteMeanAndNoiseComeFromItsFootprintOnly) {
  cv::Mat quad = cv::Mat::zeros(kHeight, kWidth, CV_8U);
  const std::vector<cv::Point> corners = {{20, 12}, {100, 5}, {110, 80}, {12, 70}};
  cv::fillConvexPoly(quad, corners, 255);
  const double area = cv::countNonZero(quad);

  const RgbImage dark = captures(quad, 1).dark;
  const ReferenceFootprint footprint = white_reference_footprint(captures(quad, 1).captures[0].white, dark);
  EXPECT_EQ(static_cast<double>(footprint.inside_pixels), area);
  std::size_t interior = 0;
  for (auto v : footprint.interior) interior += v;
  EXPECT_LT(static_cast<double>(interior), area);
  EXPECT_GT(static_cast<double>(interior), 0.9 * area);

  // The noise model of the posed camera is the framed camera's.
  const auto posed = measurement_set_from_references(captures(quad, 2));
  const auto framed = measurement_set_from_references(captures(cv::Mat(), 2));
  ASSERT_EQ(posed.channels.size(), framed.channels.size());
  for (std::size_t k = 0; k < posed.channels.size(); ++k) {
    EXPECT_NEAR(posed.channels[k].noise.read_sigma / framed.channels[k].noise.read_sigma, 1.0, 0.05)
        << posed.channels[k].name;
    EXPECT_NEAR(posed.channels[k].noise.saturation_albedo / framed.channels[k].noise.saturation_albedo, 1.0, 0.01)
        << posed.channels[k].name;
  }

  // No albedo outside the footprint; the albedo inside.
  const Measurement m = build_measurement(captures(quad, 3));
  EXPECT_EQ(static_cast<double>(m.no_reference_pixels), static_cast<double>(m.width) * m.height - area);
  std::size_t finite_outside = 0;
  std::vector<float> inside_r;
  for (std::size_t i = 0; i < m.no_reference.size(); ++i) {
    if (m.no_reference[i]) finite_outside += std::isfinite(m.measured[i * 4]) || std::isfinite(m.measured[i * 4 + 3]);
    else inside_r.push_back(m.measured[i * 4]);
  }
  EXPECT_EQ(finite_outside, 0u);
  std::nth_element(inside_r.begin(), inside_r.begin() + static_cast<std::ptrdiff_t>(inside_r.size() / 2), inside_r.end());
  EXPECT_NEAR(inside_r[inside_r.size() / 2], 0.99 * 0.5, 0.03);

  // A framed camera has every pixel inside and none without reference.
  const Measurement whole = build_measurement(captures(cv::Mat(), 4));
  EXPECT_EQ(whole.no_reference_pixels, 0u);
}

}  // namespace
}  // namespace chromo::session
