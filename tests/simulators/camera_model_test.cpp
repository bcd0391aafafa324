// The virtual lab's camera model: response normalisation, exposure and gain
// scaling, saturation, the noise statistics it states, Bayer phase, seeds.
#include <gtest/gtest.h>

#include <cmath>

#include "chromo/simulators/camera/camera_model.hpp"

namespace chromo::simulators {
namespace {

TEST(CameraModel, FlatUnitIrradianceOnWhiteGivesGreenResponseOne) {
  const CameraModel model{CameraModelOptions{}};
  const auto w = model.weights(spectral::Spectrum::constant(1.0));
  EXPECT_NEAR(w.row(1).sum(), 1.0, 1e-12);
  EXPECT_GT(w.row(0).sum(), 0.1);
  EXPECT_GT(w.row(2).sum(), 0.1);
}

TEST(CameraModel, SignalScalesWithExposureAndGainAndClipsAtFullScale) {
  const CameraModel model{CameraModelOptions{}};
  const double black = model.options().black_level_dn;
  const double at_5ms = model.expected_dn(0.4, 5000, 0) - black;
  EXPECT_NEAR(model.expected_dn(0.4, 10000, 0) - black, 2 * at_5ms, 1e-9);
  EXPECT_NEAR(model.expected_dn(0.4, 5000, 20 * std::log10(2.0)) - black, 2 * at_5ms, 1e-9);
  EXPECT_EQ(model.expected_dn(10.0, 100000, 12), model.max_dn());
}

TEST(CameraModel, NoiseMatchesTheStatedSigma) {
  CameraModelOptions options;
  const CameraModel model{options};
  const cv::Mat response(200, 200, CV_32FC3, cv::Scalar(0.3, 0.3, 0.3));
  const cv::Mat dn = model.expose(response, SensorLayout::kMono, 0, 0, 10000, 0, 0);
  ASSERT_EQ(dn.type(), CV_16U);
  cv::Scalar mean, stddev;
  cv::meanStdDev(dn, mean, stddev);
  const double expected = model.expected_dn(0.3, 10000, 0), sigma = model.noise_sigma_dn(0.3, 10000, 0);
  EXPECT_NEAR(mean[0], expected, 4 * sigma / 200);
  EXPECT_NEAR(stddev[0], sigma, 0.03 * sigma);
}

TEST(CameraModel, SaturatedPixelsReadFullScaleWithoutNoise) {
  const CameraModel model{CameraModelOptions{}};
  const cv::Mat response(16, 16, CV_32FC3, cv::Scalar(50, 50, 50));
  const cv::Mat dn = model.expose(response, SensorLayout::kThreeChannel, 0, 0, 10000, 24, 0);
  double min_value = 0, max_value = 0;
  cv::minMaxLoc(dn.reshape(1), &min_value, &max_value);
  EXPECT_EQ(min_value, model.max_dn());
  EXPECT_EQ(max_value, model.max_dn());
}

TEST(CameraModel, BayerPhaseFollowsTheSensorPosition) {
  const CameraModel model{CameraModelOptions{}};
  // R, G, B: 2000, 4000, 6000 electrons at 10 us (noise about 10 DN, steps of 400 DN).
  const cv::Mat response(4, 4, CV_32FC3, cv::Scalar(100, 200, 300));
  const cv::Mat at_origin = model.expose(response, SensorLayout::kBayerRGGB, 0, 0, 10, 0, 0);
  const cv::Mat shifted = model.expose(response, SensorLayout::kBayerRGGB, 1, 0, 10, 0, 0);
  // (0,0) is red on the sensor origin, green when the window starts one column right.
  EXPECT_LT(at_origin.at<std::uint16_t>(0, 0), shifted.at<std::uint16_t>(0, 0));
  EXPECT_LT(at_origin.at<std::uint16_t>(0, 1), at_origin.at<std::uint16_t>(1, 1));  // green < blue
}

TEST(CameraModel, ExpectedFrameIsTheNoiseFreeMeanOfExposedFrames) {
  const CameraModel model{CameraModelOptions{}};
  const cv::Mat response(64, 64, CV_32FC3, cv::Scalar(0.2, 0.3, 0.1));
  const cv::Mat expected = model.expected(response, SensorLayout::kBayerRGGB, 0, 0, 8000, 0);
  ASSERT_EQ(expected.type(), CV_32F);
  // Same Bayer sites as expose(): R at (0,0), G at (0,1) and (1,0), B at (1,1); unrounded.
  EXPECT_FLOAT_EQ(expected.at<float>(0, 0), model.expected_dn(0.2f, 8000, 0));
  EXPECT_FLOAT_EQ(expected.at<float>(1, 0), model.expected_dn(0.3f, 8000, 0));
  EXPECT_FLOAT_EQ(expected.at<float>(1, 1), model.expected_dn(0.1f, 8000, 0));
  // The mean of a noisy frame's red sites is the expectation (σ ≈ 6 DN, 1024 sites).
  double sum = 0;
  const cv::Mat noisy = model.expose(response, SensorLayout::kBayerRGGB, 0, 0, 8000, 0, 3);
  for (int y = 0; y < 64; y += 2)
    for (int x = 0; x < 64; x += 2) sum += noisy.at<std::uint16_t>(y, x);
  EXPECT_NEAR(sum / 1024, expected.at<float>(0, 0), 4 * model.noise_sigma_dn(0.2, 8000, 0) / 32);
  EXPECT_EQ(model.expected(response, SensorLayout::kThreeChannel, 0, 0, 8000, 0).type(), CV_32FC3);
  EXPECT_THROW(model.expected(cv::Mat(4, 4, CV_32F), SensorLayout::kMono, 0, 0, 1, 0), std::invalid_argument);
}

TEST(CameraModel, SameSeedAndFrameReproduceOtherFramesDiffer) {
  const CameraModel model{CameraModelOptions{}};
  const cv::Mat response(32, 32, CV_32FC3, cv::Scalar(0.2, 0.3, 0.1));
  const cv::Mat a = model.expose(response, SensorLayout::kBayerRGGB, 0, 0, 8000, 0, 7);
  const cv::Mat b = model.expose(response, SensorLayout::kBayerRGGB, 0, 0, 8000, 0, 7);
  const cv::Mat c = model.expose(response, SensorLayout::kBayerRGGB, 0, 0, 8000, 0, 8);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_L1), 0.0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_L1), 0.0);
  CameraModelOptions bad;
  bad.full_well_e = 0;
  EXPECT_THROW(CameraModel{bad}, std::invalid_argument);
}

}  // namespace
}  // namespace chromo::simulators
