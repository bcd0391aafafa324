// The camera simulator on a polarised sphere (docs/polarisation.md, "Virtual
// lab physics"): a camera with an analyser renders the skin under the state
// the LED lab drives; the lab's light already holds the light film, so the
// white target sees the same in cross and parallel and twice that through
// both banks; on the highlight (parallel − cross)/2 in albedo units is the
// surface layer times (ER − 1)²/(ER + 1)²; a sphere without banks renders as
// before, bit for bit.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

#include "chromo/simulators/camera/camera_simulator.hpp"
#include "chromo/simulators/leds/led_lab.hpp"
#include "chromo/simulators/polarisation/polarised_skin.hpp"

namespace chromo::simulators {
namespace {

using drivers::Polarisation;

constexpr int kWidth = 160, kHeight = 128;

SkinSceneOptions camera_skin_options() {
  SkinSceneOptions options;
  options.width = kWidth;
  options.height = kHeight;
  options.threads = 2;
  return options;
}

struct PolarisedCameraRig {
  explicit PolarisedCameraRig(bool banks, bool analyser = true) {
    LedLabOptions lab_options;
    lab_options.start_warm = true;
    if (banks) lab_options.polariser_banks.fill(true);
    lab = std::make_shared<LedLab>(lab_options);
    lab->set_output_enabled(true);
    skin = std::make_shared<const Scene>(make_skin_scene(camera_skin_options()));
    CameraSimulatorOptions options;
    options.sensor_width = kWidth;
    options.sensor_height = kHeight;
    if (analyser) options.analyser = CameraAnalyser{};
    camera = std::make_unique<CameraSimulator>(options, lab, skin);
    camera->set_skin_scene_options(skin, camera_skin_options());
  }
  // W57 (and optionally B) at full drive, each type in its state; the sensor response.
  cv::Mat respond(Polarisation w57_state, std::optional<Polarisation> blue_state = std::nullopt) {
    drivers::LedState state;
    state.drive[static_cast<int>(spectral::LedType::kW57)] = 1.0;
    state.polarisation[static_cast<int>(spectral::LedType::kW57)] = w57_state;
    if (blue_state) {
      state.drive[static_cast<int>(spectral::LedType::kBlue)] = 1.0;
      state.polarisation[static_cast<int>(spectral::LedType::kBlue)] = *blue_state;
    }
    EXPECT_EQ(lab->apply(state), LabResult::kOk);
    lab->settle_thermal();
    return camera->sensor_response_now();
  }
  std::shared_ptr<LedLab> lab;
  std::shared_ptr<const Scene> skin;
  std::unique_ptr<CameraSimulator> camera;
};

// Mean response of the scene's white target, per channel.
cv::Vec3d white_mean(const cv::Mat& response, const Scene& scene) {
  cv::Vec3d sum(0, 0, 0);
  int count = 0;
  for (int y = 0; y < scene.height(); ++y)
    for (int x = 0; x < scene.width(); ++x)
      if (scene.regions().at<std::uint8_t>(y, x) == static_cast<std::uint8_t>(SceneRegion::kWhiteTarget)) {
        const cv::Vec3f v = response.at<cv::Vec3f>(y, x);
        for (int c = 0; c < 3; ++c) sum[c] += v[c];
        ++count;
      }
  return sum / count;
}

bool bitwise_equal(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() &&
         std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

TEST(CameraPolarisationTest, SphereWithoutBanksRendersAsBeforeBitForBit) {
  PolarisedCameraRig rig(/*banks=*/false);
  const cv::Mat now = rig.respond(Polarisation::kUnpolarised);
  EXPECT_FALSE(rig.lab->polarised_irradiance_now().has_value());
  EXPECT_TRUE(bitwise_equal(now, rig.camera->sensor_response(rig.lab->irradiance_now())));
  EXPECT_GT(cv::norm(now), 0);
}

TEST(CameraPolarisationTest, CameraWithoutAnalyserOnAPolarisedSphereRendersAsBefore) {
  PolarisedCameraRig rig(/*banks=*/true, /*analyser=*/false);
  const cv::Mat cross = rig.respond(Polarisation::kCross);
  EXPECT_TRUE(bitwise_equal(cross, rig.camera->sensor_response(rig.lab->irradiance_now())));
}

TEST(CameraPolarisationTest, CrossAndParallelSeparateTheHighlightAndAgreeOnTheWhiteTarget) {
  PolarisedCameraRig rig(/*banks=*/true);
  const cv::Mat cross = rig.respond(Polarisation::kCross);
  const cv::Mat parallel = rig.respond(Polarisation::kParallel);
  const cv::Mat both_banks = rig.respond(Polarisation::kUnpolarised);
  const cv::Vec3d white_cross = white_mean(cross, *rig.skin), white_parallel = white_mean(parallel, *rig.skin),
                  white_both = white_mean(both_banks, *rig.skin);
  for (int c = 0; c < 3; ++c) {
    // The lab emits T·L in either state: the depolarising target sees no difference.
    EXPECT_NEAR(white_parallel[c] / white_cross[c], 1.0, 1e-6) << "channel " << c;
    // Both banks: 2·T·L.
    EXPECT_NEAR(white_both[c] / white_cross[c], 2.0, 1e-6) << "channel " << c;
  }
  // The strongest highlight pixel and a sheen-only skin pixel.
  const cv::Mat surface = skin_surface_layer(*rig.skin, camera_skin_options(), 0);
  cv::Point highlight;
  double surface_max = 0;
  cv::minMaxLoc(surface, nullptr, &surface_max, nullptr, &highlight);
  ASSERT_GT(surface_max, 0.25);
  const cv::Vec3f p = parallel.at<cv::Vec3f>(highlight), x = cross.at<cv::Vec3f>(highlight);
  const int green = 1;
  // Albedo units: divided by the white target of the same state, times ρ_white.
  const double difference_in_albedo =
      kWhiteTargetReflectance * (p[green] / white_parallel[green] - x[green] / white_cross[green]) / 2;
  // (ER − 1)²/(ER + 1)² of the surface layer (closed form, design view): the
  // green channel spans ER 1:58.6 (470 nm) to 1:200, so between 0.934 and 0.981.
  const double surface_fraction = difference_in_albedo / surface_max;
  std::printf("highlight s = %.4f: (parallel - cross)/2 in albedo units = %.4f of s (green)\n", surface_max,
              surface_fraction);
  EXPECT_GT(surface_fraction, 0.934);
  EXPECT_LT(surface_fraction, 0.981);
  EXPECT_GT(p[green], 1.3 * x[green]);  // the parallel frame keeps the highlight
}

TEST(CameraPolarisationTest, TheWhiteTargetSceneIsTheSkinScenesWhiteStrip) {
  PolarisedCameraRig rig(/*banks=*/true);
  const cv::Mat skin = rig.respond(Polarisation::kCross);
  rig.camera->set_scene(std::make_shared<const Scene>(make_white_target_scene(kWidth, kHeight)));
  const cv::Mat white = rig.camera->sensor_response_now();
  const cv::Vec3d strip = white_mean(skin, *rig.skin);
  const cv::Scalar target = cv::mean(white);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(strip[c] / target[c], 1.0, 1e-5) << "channel " << c;
}

TEST(CameraPolarisationTest, MixedStatesAreTheSumOfTheirTypesRenderedAlone) {
  PolarisedCameraRig rig(/*banks=*/true);
  const cv::Mat mixed = rig.respond(Polarisation::kCross, Polarisation::kParallel);
  const cv::Mat white_cross = rig.respond(Polarisation::kCross);
  drivers::LedState blue;
  blue.drive[static_cast<int>(spectral::LedType::kBlue)] = 1.0;
  blue.polarisation[static_cast<int>(spectral::LedType::kBlue)] = Polarisation::kParallel;
  ASSERT_EQ(rig.lab->apply(blue), LabResult::kOk);
  rig.lab->settle_thermal();
  const cv::Mat blue_parallel = rig.camera->sensor_response_now();
  const cv::Mat sum = white_cross + blue_parallel;
  EXPECT_LT(cv::norm(mixed, sum, cv::NORM_INF), 1e-5 * cv::norm(sum, cv::NORM_INF));
}

}  // namespace
}  // namespace chromo::simulators
