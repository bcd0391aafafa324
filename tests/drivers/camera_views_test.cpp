// Each camera's frames match its pose (issue 21 part 2): two posed camera
// simulators, each on its own loopback address, look at one planar patch
// with dark markers; their frames come through the real driver over GigE
// Vision. The homography between the two frames, estimated from the markers
// found in them, must agree with the one the poses give
// (H_b · H_a⁻¹, simulators/scene/camera_view.hpp) to a fraction of a pixel
// (measured: 0.29 px at most over the patch).
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstring>

#include "camera_fixture.hpp"
#include "chromo/simulators/scene/camera_view.hpp"

namespace chromo::testing {
namespace {

constexpr int kPatchSize = 200;        // scene pixels
constexpr double kPatchWidthMm = 80;   // 0.4 mm a scene pixel
constexpr int kSensor = 384;

struct Marker {
  double x, y, radius;  // scene pixels
};
// Distinct radii: a marker is recognised in any view by its area's rank.
const Marker kMarkers[] = {{45, 50, 6}, {150, 45, 7.5}, {100, 100, 9}, {40, 155, 10.5}, {160, 150, 12}, {105, 160, 5}};

std::shared_ptr<const simulators::Scene> marker_scene() {
  auto scene = std::make_shared<simulators::Scene>(kPatchSize, kPatchSize);
  for (int y = 0; y < kPatchSize; ++y)
    for (int x = 0; x < kPatchSize; ++x) {
      bool dark = false;
      for (const Marker& m : kMarkers) dark |= std::hypot(x - m.x, y - m.y) <= m.radius;
      scene->set_albedo(x, y, spectral::Spectrum::constant(dark ? 0.03 : 0.8));
    }
  return scene;
}

simulators::CameraView posed(double azimuth_deg, double elevation_deg, double roll_deg) {
  simulators::CameraView view;
  view.intrinsics = {kSensor, kSensor, 3.5, 3.45};
  view.pose = simulators::look_at(simulators::orbit_eye_mm(300, azimuth_deg, elevation_deg), {0, 0, 0}, roll_deg);
  return view;
}

// One Mono16 frame of a camera simulator with `view`, through the driver.
cv::Mat grab(const simulators::CameraView& view, const std::string& serial) {
  simulators::CameraSimulatorOptions options;
  options.serial = serial;
  options.sensor_width = options.sensor_height = kSensor;
  options.view = view;
  options.patch_width_mm = kPatchWidthMm;
  auto light = std::make_shared<simulators::FixedSpectrumIllumination>(test_irradiance());
  simulators::CameraSimulator simulator(options, light, marker_scene());
  drivers::AravisCameraOptions driver;
  driver.serial = serial;
  driver.address = simulator.address();
  driver.frame_retention_ms = kTestFrameRetentionMs;
  driver.socket_buffer_bytes = 4u << 20;
  driver.on_warning = [](const std::string&) {};
  auto camera = drivers::AravisCamera::open(driver);
  drivers::CameraSettings settings;
  settings.exposure_us = 10000;
  settings.pixel_format = drivers::PixelFormat::kMono16;
  settings.trigger_mode = drivers::TriggerMode::kSoftware;
  camera->configure(settings);
  FrameSink sink;
  camera->start_stream(sink.callback());
  camera->software_trigger();
  EXPECT_TRUE(sink.wait_for_count(1, std::chrono::milliseconds(5000)));
  camera->stop_stream();
  auto frames = sink.take();
  if (frames.empty() || frames[0].status != drivers::FrameStatus::kComplete) return {};
  cv::Mat image(frames[0].height, frames[0].width, CV_16U);
  std::memcpy(image.data, frames[0].data.data(), frames[0].data.size());
  return image;
}

// The markers' centroids in a frame, in kMarkers' order (by area rank):
// dark blobs inside the lit patch, not touching the frame's border.
std::vector<cv::Point2d> find_markers(const cv::Mat& frame) {
  cv::Mat values;
  frame.convertTo(values, CV_32F);
  double bright = 0;
  cv::minMaxLoc(values, nullptr, &bright);
  cv::Mat dark = values < 0.5 * bright;
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(dark, labels, stats, centroids, 8, CV_32S);
  std::vector<std::pair<int, cv::Point2d>> blobs;
  for (int i = 1; i < count; ++i) {
    const int x = stats.at<int>(i, cv::CC_STAT_LEFT), y = stats.at<int>(i, cv::CC_STAT_TOP);
    const int w = stats.at<int>(i, cv::CC_STAT_WIDTH), h = stats.at<int>(i, cv::CC_STAT_HEIGHT);
    if (x == 0 || y == 0 || x + w == frame.cols || y + h == frame.rows) continue;  // the dark surround
    if (stats.at<int>(i, cv::CC_STAT_AREA) < 20) continue;                          // noise
    blobs.push_back({stats.at<int>(i, cv::CC_STAT_AREA), {centroids.at<double>(i, 0), centroids.at<double>(i, 1)}});
  }
  std::sort(blobs.begin(), blobs.end(), [](auto& a, auto& b) { return a.first < b.first; });
  std::vector<std::size_t> by_radius(std::size(kMarkers));
  for (std::size_t i = 0; i < by_radius.size(); ++i) by_radius[i] = i;
  std::sort(by_radius.begin(), by_radius.end(), [](auto a, auto b) { return kMarkers[a].radius < kMarkers[b].radius; });
  std::vector<cv::Point2d> found(std::size(kMarkers));
  if (blobs.size() != found.size()) return {};
  for (std::size_t rank = 0; rank < blobs.size(); ++rank) found[by_radius[rank]] = blobs[rank].second;
  return found;
}

// Least-squares homography from ≥ 4 correspondences (normalised DLT).
cv::Matx33d estimate_homography(const std::vector<cv::Point2d>& from, const std::vector<cv::Point2d>& to) {
  auto normaliser = [](const std::vector<cv::Point2d>& points) {
    cv::Point2d mean(0, 0);
    for (const auto& p : points) mean += p;
    mean *= 1.0 / points.size();
    double spread = 0;
    for (const auto& p : points) spread += cv::norm(p - mean);
    const double s = std::sqrt(2.0) * points.size() / spread;
    return cv::Matx33d(s, 0, -s * mean.x, 0, s, -s * mean.y, 0, 0, 1);
  };
  const cv::Matx33d tf = normaliser(from), tt = normaliser(to);
  cv::Mat a(static_cast<int>(2 * from.size()), 9, CV_64F, cv::Scalar(0));
  for (std::size_t i = 0; i < from.size(); ++i) {
    const cv::Vec3d p = tf * cv::Vec3d(from[i].x, from[i].y, 1), q = tt * cv::Vec3d(to[i].x, to[i].y, 1);
    double* r0 = a.ptr<double>(static_cast<int>(2 * i));
    double* r1 = a.ptr<double>(static_cast<int>(2 * i + 1));
    const double row0[9] = {-p[0], -p[1], -1, 0, 0, 0, q[0] * p[0], q[0] * p[1], q[0]};
    const double row1[9] = {0, 0, 0, -p[0], -p[1], -1, q[1] * p[0], q[1] * p[1], q[1]};
    std::copy(row0, row0 + 9, r0);
    std::copy(row1, row1 + 9, r1);
  }
  cv::Mat w, u, vt;
  cv::SVD::compute(a, w, u, vt, cv::SVD::FULL_UV);
  cv::Matx33d h;
  for (int k = 0; k < 9; ++k) h.val[k] = vt.at<double>(8, k);
  return tt.inv() * h * tf;
}

cv::Point2d apply(const cv::Matx33d& h, const cv::Point2d& p) {
  const cv::Vec3d q = h * cv::Vec3d(p.x, p.y, 1);
  return {q[0] / q[2], q[1] / q[2]};
}

// The largest distance, over camera A's view of the patch (a 9×9 grid of
// patch points), between where two homographies A → B send a point.
double largest_disagreement_px(const cv::Matx33d& a_to_b, const cv::Matx33d& other, const cv::Matx33d& patch_to_a) {
  double worst = 0;
  for (int i = 0; i <= 8; ++i)
    for (int j = 0; j <= 8; ++j) {
      const cv::Point2d in_a = apply(patch_to_a, {i * (kPatchSize - 1) / 8.0, j * (kPatchSize - 1) / 8.0});
      worst = std::max(worst, cv::norm(apply(a_to_b, in_a) - apply(other, in_a)));
    }
  return worst;
}

TEST(CameraViews, TwoCamerasFramesMatchTheirPosesHomography) {
  const simulators::CameraView view_a = posed(-25, 8, 0), view_b = posed(20, -12, 6);
  const cv::Mat frame_a = grab(view_a, "CHROMO-VIEW-A"), frame_b = grab(view_b, "CHROMO-VIEW-B");
  ASSERT_FALSE(frame_a.empty());
  ASSERT_FALSE(frame_b.empty());
  const auto markers_a = find_markers(frame_a), markers_b = find_markers(frame_b);
  ASSERT_EQ(markers_a.size(), std::size(kMarkers));
  ASSERT_EQ(markers_b.size(), std::size(kMarkers));
  const cv::Matx33d estimated = estimate_homography(markers_a, markers_b);

  const simulators::PatchGeometry patch{kPatchSize, kPatchSize, kPatchWidthMm / kPatchSize};
  const cv::Matx33d h_a = simulators::patch_to_image_homography(view_a, patch);
  const cv::Matx33d h_b = simulators::patch_to_image_homography(view_b, patch);
  const cv::Matx33d from_poses = h_b * h_a.inv();
  // Marker centroids carry noise and a perspective bias of a few hundredths
  // of a pixel; a pose 1 degree off disagrees by more than a pixel.
  const double error_px = largest_disagreement_px(estimated, from_poses, h_a);
  EXPECT_LT(error_px, 0.5);
  const cv::Matx33d h_b_off = simulators::patch_to_image_homography(posed(21, -12, 6), patch);
  EXPECT_GT(largest_disagreement_px(estimated, h_b_off * h_a.inv(), h_a), 1.0);
  // Each frame alone: its markers where its own pose puts them.
  for (std::size_t k = 0; k < std::size(kMarkers); ++k) {
    EXPECT_LT(cv::norm(markers_a[k] - apply(h_a, {kMarkers[k].x, kMarkers[k].y})), 0.5) << k;
    EXPECT_LT(cv::norm(markers_b[k] - apply(h_b, {kMarkers[k].x, kMarkers[k].y})), 0.5) << k;
  }
  // Outside the patch the sensor is dark (black level only); the white patch
  // between the markers is lit.
  const cv::Point2d white = apply(h_a, {75, 100});
  EXPECT_LT(frame_a.at<std::uint16_t>(0, 0), frame_a.at<std::uint16_t>(cv::Point(white)) / 10);
  std::cout << "homography between the views: largest disagreement with the poses' " << error_px << " px\n";
}

}  // namespace
}  // namespace chromo::testing
