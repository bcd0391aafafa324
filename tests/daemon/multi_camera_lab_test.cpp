// The virtual lab with several cameras (issue 21 part 2): one camera
// simulator per configured camera, each on its own loopback address, each a
// device of chromod opened by the real driver, all exposed by the same
// session. A posed camera's white-reference frame shows the white patch
// where its pose puts it.
#include "test_lab.hpp"

#include <opencv2/imgproc.hpp>

#include <cstring>

#include "chromo/simulators/scene/camera_view.hpp"

namespace chromo::daemon {
namespace {

using testing::quick_standard_plan;
using testing::TestLab;
using testing::wait_final;

// The share of a 16-bit frame's pixels brighter than half its brightest.
double lit_pixels(const std::filesystem::path& tiff) {
  const auto image = session::read_tiff(tiff);
  cv::Mat values(image.height, image.width, CV_16U);
  std::memcpy(values.data, image.data.data(), values.total() * 2);
  double bright = 0;
  cv::minMaxLoc(values, nullptr, &bright);
  return cv::countNonZero(values > 0.5 * bright);
}

TEST(MultiCameraLab, EveryConfiguredCameraIsADeviceOnItsOwnAddressAndStoresEveryStep) {
  TestLab lab("multi-camera-lab");
  simulators::LabCamera side;
  side.name = "side";
  side.sensor_width = 200;
  side.sensor_height = 150;
  side.pixel_format = drivers::PixelFormat::kMono12;
  side.pose = simulators::LabCameraPose{};
  side.pose->distance_mm = 300;
  side.pose->azimuth_deg = 30;
  side.pose->elevation_deg = 10;
  side.pose->focal_length_mm = 1.4;  // the 80 mm patch ~108 px across at 300 mm
  lab.lab_options.cameras.push_back(side);
  auto daemon = lab.daemon();
  ASSERT_EQ(lab.simulators->camera_count(), 2u);
  EXPECT_NE(lab.simulators->camera(0).address(), lab.simulators->camera(1).address());
  ASSERT_EQ(daemon->devices().cameras.size(), 2u);
  EXPECT_EQ(daemon->devices().cameras[1]->config.name, "side");
  EXPECT_EQ(daemon->devices().cameras[1]->config.settings.at("ip_address"), lab.simulators->camera(1).address());

  auto started = daemon->start_session(quick_standard_plan(1), "two views");
  auto final = wait_final(*daemon, started.id);
  ASSERT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
  EXPECT_EQ(final.counters.stored, 14u);
  auto info = daemon->session(started.id);
  ASSERT_TRUE(info);
  std::map<std::string, int> per_camera;
  std::filesystem::path side_white;
  for (const auto& frame : info->frames) {
    ++per_camera[frame.camera];
    const auto image = session::read_tiff(std::filesystem::path(final.folder) / frame.file);
    if (frame.camera == "side") {
      EXPECT_EQ(image.width, 200);
      EXPECT_EQ(image.height, 150);
      EXPECT_EQ(frame.pixel_format, drivers::PixelFormat::kMono12);
      if (frame.step == "white_d65") side_white = std::filesystem::path(final.folder) / frame.file;
    } else {
      EXPECT_EQ(image.width, 160);
      EXPECT_EQ(frame.pixel_format, drivers::PixelFormat::kBayerRG12);
    }
  }
  EXPECT_EQ(per_camera["cam0"], 7);
  EXPECT_EQ(per_camera["side"], 7);
  // The white target fills the patch: the side camera sees it as the
  // quadrilateral its pose projects (and dark around it).
  ASSERT_FALSE(side_white.empty());
  const auto view = simulators::lab_camera_view(side);
  ASSERT_TRUE(view);
  const auto corners = simulators::patch_corners_in_image(*view, {lab.lab_options.scene_size, lab.lab_options.scene_size,
                                                                  lab.lab_options.patch_width_mm / lab.lab_options.scene_size});
  std::vector<cv::Point2f> quad(corners.begin(), corners.end());
  const double expected = cv::contourArea(quad);
  EXPECT_GT(expected, 0.2 * 200 * 150);  // a real test: the patch covers a good part of the sensor
  EXPECT_LT(expected, 0.9 * 200 * 150);
  EXPECT_NEAR(lit_pixels(side_white), expected, 0.04 * expected);
}

}  // namespace
}  // namespace chromo::daemon
