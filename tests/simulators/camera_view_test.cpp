// Camera views (simulators/scene/camera_view.hpp): the pinhole geometry's
// numbers worked by hand, the rendering's inverse map, and the lab's camera
// list read key by key (simulators/camera/lab_cameras.hpp).
#include <gtest/gtest.h>

#include <cmath>

#include "chromo/simulators/camera/lab_cameras.hpp"
#include "chromo/simulators/scene/camera_view.hpp"

namespace chromo::simulators {
namespace {

std::string refusal(const nlohmann::json& list) {
  try {
    read_lab_cameras(list);
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return "(accepted)";
}

CameraView square_on(double distance_mm) {
  CameraView view;
  view.intrinsics = {640, 480, 8, 3.45};
  view.pose = look_at(orbit_eye_mm(distance_mm, 0, 0), {0, 0, 0});
  return view;
}

TEST(CameraView, SquareOnPatchCornersAreWherePinholeGeometryPutsThem) {
  // 80 mm patch at 300 mm through an 8 mm lens on 3.45 µm pixels:
  // f = 8 / 0.00345 = 2318.84 px, half width 40 mm → 40/300·f = 309.18 px.
  const PatchGeometry patch{200, 200, 0.4};
  const auto corners = patch_corners_in_image(square_on(300), patch);
  const double half = 40.0 / 300.0 * (8 / 0.00345);
  EXPECT_NEAR(corners[0].x, 319.5 - half, 1e-9);
  EXPECT_NEAR(corners[0].y, 239.5 - half, 1e-9);
  EXPECT_NEAR(corners[2].x, 319.5 + half, 1e-9);
  EXPECT_NEAR(corners[2].y, 239.5 + half, 1e-9);
  // Twice as far: half the size.
  const auto far = patch_corners_in_image(square_on(600), patch);
  EXPECT_NEAR(far[1].x - far[0].x, half, 1e-9);
}

TEST(CameraView, EveryLookAtViewSeesThePatchCentreAtThePrincipalPoint) {
  const PatchGeometry patch{101, 101, 0.5};  // odd: pixel 50 is the centre
  for (double azimuth : {-60.0, -10.0, 35.0})
    for (double elevation : {-40.0, 0.0, 25.0})
      for (double roll : {0.0, 30.0}) {
        CameraView view = square_on(250);
        view.pose = look_at(orbit_eye_mm(250, azimuth, elevation), {0, 0, 0}, roll);
        const cv::Vec3d centre = patch_to_image_homography(view, patch) * cv::Vec3d(50, 50, 1);
        EXPECT_NEAR(centre[0] / centre[2], 319.5, 1e-9);
        EXPECT_NEAR(centre[1] / centre[2], 239.5, 1e-9);
      }
  // Swung right (+X), the camera sees the patch's right edge nearer: longer than the left.
  CameraView right = square_on(250);
  right.pose = look_at(orbit_eye_mm(250, 30, 0), {0, 0, 0});
  const auto c = patch_corners_in_image(right, patch);
  EXPECT_GT(c[2].y - c[1].y, c[3].y - c[0].y);
}

TEST(CameraView, RendersThePatchThroughTheInverseMapAndDarkAround) {
  const CameraView view = square_on(600);  // the patch covers ~309 x 309 px in the middle
  cv::Mat patch(200, 200, CV_32FC3, cv::Scalar(0.5, 0.25, 0.125));
  patch.at<cv::Vec3f>(0, 0) = {1, 1, 1};
  const cv::Mat image = render_view(patch, view, 0.4);
  ASSERT_EQ(image.size(), cv::Size(640, 480));
  EXPECT_EQ(image.at<cv::Vec3f>(5, 5), cv::Vec3f(0, 0, 0));
  EXPECT_EQ(image.at<cv::Vec3f>(240, 320), cv::Vec3f(0.5f, 0.25f, 0.125f));
  // The patch's first pixel lands where the homography sends it.
  const cv::Vec3d first = patch_to_image_homography(view, {200, 200, 0.4}) * cv::Vec3d(0, 0, 1);
  const cv::Point at(static_cast<int>(std::lround(first[0] / first[2])), static_cast<int>(std::lround(first[1] / first[2])));
  EXPECT_GT(image.at<cv::Vec3f>(at)[2], 0.5f);
}

TEST(CameraView, RefusesBadViewsAndAPatchBehindTheCamera) {
  CameraView view = square_on(300);
  std::string error;
  view.pose.rotation(0, 0) = 2;
  EXPECT_FALSE(view.IsValid(&error));
  EXPECT_NE(error.find("orthonormal"), std::string::npos);
  view = square_on(300);
  view.intrinsics.focal_length_mm = 0;
  EXPECT_FALSE(view.IsValid(&error));
  // 20 mm away and swung 80 degrees: the far half of an 80 mm patch is behind the camera.
  view = square_on(20);
  view.pose = look_at(orbit_eye_mm(20, 80, 0), {0, 0, 0});
  EXPECT_THROW(patch_to_image_homography(view, {200, 200, 0.4}), std::invalid_argument);
  EXPECT_THROW(look_at({0, -100, 0}, {0, 0, 0}), std::invalid_argument);  // along Y: no "up"
  EXPECT_THROW(orbit_eye_mm(300, 90, 0), std::invalid_argument);
}

TEST(LabCameras, ReadsTheListAndNamesTheKeyOfEveryRefusal) {
  const auto cameras = read_lab_cameras(nlohmann::json::parse(R"([
    {"name": "cam0"},
    {"name": "left", "address": "127.0.0.9", "sensor_width": 2448, "sensor_height": 2048, "pixel_format": "Mono12",
     "pose": {"distance_mm": 400, "azimuth_deg": -20, "focal_length_mm": 16}, "sensitivity": "builtin:sony_ilce_7m3"}
  ])"));
  ASSERT_EQ(cameras.size(), 2u);
  EXPECT_EQ(cameras[0].sensor_width, 640);
  EXPECT_FALSE(cameras[0].pose.has_value());
  EXPECT_FALSE(lab_camera_view(cameras[0]).has_value());
  EXPECT_EQ(cameras[1].address, "127.0.0.9");
  EXPECT_EQ(cameras[1].pixel_format, drivers::PixelFormat::kMono12);
  ASSERT_TRUE(cameras[1].pose.has_value());
  EXPECT_EQ(cameras[1].pose->distance_mm, 400);
  EXPECT_EQ(cameras[1].pose->elevation_deg, 0);
  const auto view = lab_camera_view(cameras[1]);
  ASSERT_TRUE(view.has_value());
  EXPECT_EQ(view->intrinsics.width_px, 2448);
  EXPECT_EQ(view->intrinsics.focal_length_mm, 16);

  using nlohmann::json;
  EXPECT_EQ(refusal(json::object()).rfind(": ", 0), 0u);
  EXPECT_EQ(refusal(json::array()), ": the lab needs at least one camera");
  EXPECT_EQ(refusal(json::parse(R"([{"sensor_width": 64}])")), "[0].name: missing");
  EXPECT_EQ(refusal(json::parse(R"([3])")), "[0]: must be a JSON object");
  EXPECT_EQ(refusal(json::parse(R"([{"name": "a"}, {"name": "b", "sensor_width": 8}])")).rfind("[1].sensor_width: 8 ", 0), 0u);
  EXPECT_EQ(refusal(json::parse(R"([{"name": "a"}, {"name": "a"}])")), "[1].name: \"a\" is used twice");
  EXPECT_EQ(refusal(json::parse(R"([{"name": "a", "address": "10.0.0.1"}])")).rfind("[0].address: ", 0), 0u);
  EXPECT_EQ(refusal(json::parse(R"([{"name": "a", "address": "127.0.0.2"}, {"name": "b", "address": "127.0.0.2"}])")),
            "[1].address: \"127.0.0.2\" is used twice");
  EXPECT_EQ(refusal(json::parse(R"([{"name": "a", "pixel_format": "YUV422"}])")).rfind("[0].pixel_format: \"YUV422\" unknown", 0), 0u);
  EXPECT_EQ(refusal(json::parse(R"([{"name": "a", "pose": {"azimuth_deg": 95}}])")).rfind("[0].pose.azimuth_deg: 95 is outside", 0), 0u);
  EXPECT_EQ(refusal(json::parse(R"([{"name": "a", "pose": {"yaw": 1}}])")).rfind("[0].pose.yaw: unknown key", 0), 0u);
  EXPECT_EQ(refusal(json::parse(R"([{"name": "a", "pose": 3}])")), "[0].pose: 3 is not a JSON object");
  EXPECT_EQ(refusal(json::parse(R"([{"name": "a", "lens": 3}])")).rfind("[0].lens: unknown key", 0), 0u);
  EXPECT_EQ(refusal(json::parse(R"([{"name": "a b"}])")).rfind("[0].name: ", 0), 0u);
}

// The maps' scale bar needs the subject's width a frame row spans
// (docs/maps.md "Scale bar"): the patch's own width without a pose; with
// one, the pinhole's scale at the centre (distance × pixel / focal) times
// the sensor's width, larger by 1/cos for a camera swung sideways.
TEST(LabCameras, FieldWidthIsThePatchWithoutAPoseAndThePinholeScaleWithOne) {
  LabCamera unposed;
  EXPECT_DOUBLE_EQ(lab_camera_field_width_mm(unposed, 80), 80);
  LabCamera square_on;
  square_on.pose = LabCameraPose{300, 0, 0, 0, 8, 3.45};
  EXPECT_NEAR(lab_camera_field_width_mm(square_on, 80), 640 * 300 * 3.45e-3 / 8, 1e-6);  // 82.8 mm
  LabCamera swung = square_on;
  swung.pose->azimuth_deg = 30;
  EXPECT_NEAR(lab_camera_field_width_mm(swung, 80), 640 * 300 * 3.45e-3 / 8 / std::cos(30 * M_PI / 180), 1e-4);
}

}  // namespace
}  // namespace chromo::simulators
