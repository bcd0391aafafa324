// Camera dark/white references and frames → albedo, with the virtual lab's
// camera model and scenes in-process (no GigE camera simulator).

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "chromo/calibration/camera_references.hpp"
#include "chromo/simulators/camera/camera_model.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::calibration {
namespace {

constexpr int kWidth = 64, kHeight = 48, kFrames = 8;

// The sphere's illumination falls off toward the edges (what the flat field removes).
cv::Mat vignetted(const cv::Mat& response) {
  cv::Mat out = response.clone();
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x) {
      const double dx = (x - kWidth / 2.0) / kWidth, dy = (y - kHeight / 2.0) / kHeight;
      out.at<cv::Vec3f>(y, x) *= static_cast<float>(1.0 - 1.2 * (dx * dx + dy * dy));
    }
  return out;
}

struct Capture {
  simulators::CameraModel camera{simulators::CameraModelOptions{}};
  spectral::Spectrum light = spectral::illuminant_d65() * (1.0 / spectral::illuminant_d65().max());
  std::uint64_t frame_index = 0;
  cv::Mat mean_of(const cv::Mat& response, double exposure_us) {
    std::vector<cv::Mat> frames;
    for (int k = 0; k < kFrames; ++k)
      frames.push_back(camera.expose(response, simulators::SensorLayout::kThreeChannel, 0, 0, exposure_us, 0, frame_index++));
    return average_frames(frames);
  }
};

TEST(CameraReferences, FramesBecomeAlbedoThroughDarkAndFlatField) {
  Capture capture;
  const auto weights = capture.camera.weights(capture.light);
  const simulators::Scene white_scene = simulators::make_white_target_scene(kWidth, kHeight);
  simulators::SkinSceneOptions skin_options;
  skin_options.width = kWidth;
  skin_options.height = kHeight;
  skin_options.white_patch = false;
  skin_options.threads = 1;
  const simulators::Scene skin = simulators::make_skin_scene(skin_options);

  IlluminationReference ref;
  ref.state = "d65";
  ref.exposure_us = 16000;       // skin is darker: a longer exposure than the white's
  ref.white_exposure_us = 8000;
  ref.white_reflectance = simulators::kWhiteTargetReflectance;
  ref.frames_averaged = kFrames;
  const cv::Mat zero = cv::Mat::zeros(kHeight, kWidth, CV_32FC3);
  ref.dark = capture.mean_of(zero, ref.exposure_us);
  ref.dark_white = capture.mean_of(zero, ref.white_exposure_us);
  ref.white = capture.mean_of(vignetted(white_scene.render(weights)), ref.white_exposure_us);
  const cv::Mat skin_response = skin.render(weights);
  const cv::Mat frame = capture.mean_of(vignetted(skin_response), ref.exposure_us);

  const cv::Mat albedo = frame_to_albedo(frame, ref);
  // Truth: the camera-weighted albedo Σ S·E·a / Σ S·E per channel.
  double sum_error = 0, max_error = 0;
  int n = 0;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x)
      for (int c = 0; c < 3; ++c) {
        const double truth = skin_response.at<cv::Vec3f>(y, x)[c] / weights.row(c).sum();
        const double error = std::abs(albedo.at<cv::Vec3f>(y, x)[c] - truth);
        sum_error += error;
        max_error = std::max(max_error, error);
        ++n;
      }
  std::printf("albedo error: mean %.5f max %.5f\n", sum_error / n, max_error);
  // Shot and read noise of 8 averaged frames (skin at ~10-40 % of the full well).
  EXPECT_LT(sum_error / n, 0.004);
  EXPECT_LT(max_error, 0.03);
  // Without the flat field (white as one mean value) the vignetting would stay.
  IlluminationReference flat = ref;
  flat.white = cv::Mat(ref.white.size(), ref.white.type(), cv::mean(ref.white));
  const cv::Mat uncorrected = frame_to_albedo(frame, flat);
  const double corner = uncorrected.at<cv::Vec3f>(0, 0)[1] / (skin_response.at<cv::Vec3f>(0, 0)[1] / weights.row(1).sum());
  EXPECT_LT(corner, 0.85);

  // Stored beside the library and read back exactly.
  const auto dir = std::filesystem::path(::testing::TempDir()) / "camera_references_roundtrip";
  std::filesystem::remove_all(dir);
  CameraReferenceSet set{"virtual camera", "2026-11-22T17:00:00Z", "led-library-20261122T170000Z.json", {ref}};
  save_camera_references(set, dir);
  const CameraReferenceSet loaded = load_camera_references(dir);
  ASSERT_EQ(loaded.states.size(), 1u);
  const IlluminationReference* back = loaded.find("d65");
  ASSERT_NE(back, nullptr);
  EXPECT_EQ(cv::norm(back->white, ref.white, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(back->dark_white, ref.dark_white, cv::NORM_INF), 0.0);
  EXPECT_DOUBLE_EQ(back->white_exposure_us, 8000);
  EXPECT_EQ(cv::norm(frame_to_albedo(frame, *back), albedo, cv::NORM_INF), 0.0);

  // A missing reference file is named.
  std::filesystem::remove(dir / "d65-white.exr");
  try {
    load_camera_references(dir);
    FAIL() << "expected DataError";
  } catch (const spectral::DataError& e) {
    EXPECT_NE(std::string(e.what()).find("d65-white.exr"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

TEST(CameraReferences, MismatchedFrameAndDarkWhiteAreRefused) {
  IlluminationReference ref;
  ref.state = "d65";
  ref.exposure_us = ref.white_exposure_us = 1000;
  ref.dark = ref.dark_white = cv::Mat::zeros(4, 4, CV_32FC3);
  ref.white = cv::Mat(4, 4, CV_32FC3, cv::Scalar(100, 100, 0));  // blue channel saw no light
  EXPECT_THROW(frame_to_albedo(cv::Mat::zeros(4, 5, CV_32FC3), ref), std::invalid_argument);
  const cv::Mat albedo = frame_to_albedo(cv::Mat(4, 4, CV_32FC3, cv::Scalar(50, 25, 10)), ref);
  EXPECT_FLOAT_EQ(albedo.at<cv::Vec3f>(1, 1)[0], 0.5f * 0.99f);
  EXPECT_FLOAT_EQ(albedo.at<cv::Vec3f>(1, 1)[1], 0.25f * 0.99f);
  EXPECT_TRUE(std::isnan(albedo.at<cv::Vec3f>(1, 1)[2]));
  CameraReferenceSet bad{"cam", "2026-11-22T17:00:00Z", "", {ref}};
  bad.states[0].state = "D65 white";
  EXPECT_THROW(save_camera_references(bad, std::filesystem::path(::testing::TempDir()) / "never"), spectral::DataError);
}

}  // namespace
}  // namespace chromo::calibration
