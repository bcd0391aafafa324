// CameraView: see camera_view.hpp.
#include "chromo/simulators/scene/camera_view.hpp"

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace chromo::simulators {
namespace {

constexpr double kDegree = std::numbers::pi / 180;

cv::Vec3d normalized(const cv::Vec3d& v) { return v / cv::norm(v); }

// Patch pixel (x, y, 1) → world (X, Y, 1) on the plane Z = 0.
cv::Matx33d patch_to_plane(const PatchGeometry& patch) {
  const double s = patch.pixel_size_mm;
  return {s, 0, -0.5 * (patch.width_px - 1) * s, 0, s, -0.5 * (patch.height_px - 1) * s, 0, 0, 1};
}

void check(const CameraView& view) {
  if (std::string error; !view.IsValid(&error)) throw std::invalid_argument("camera view: " + error);
}

}  // namespace

cv::Matx33d CameraIntrinsics::matrix() const {
  const double f = focal_length_mm / (pixel_size_um * 1e-3);
  return {f, 0, 0.5 * (width_px - 1), 0, f, 0.5 * (height_px - 1), 0, 0, 1};
}

bool CameraView::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (intrinsics.width_px < 1 || intrinsics.height_px < 1) return fail("sensor size must be positive");
  if (!(intrinsics.focal_length_mm > 0 && intrinsics.focal_length_mm <= 10000))
    return fail("focal_length_mm must be in (0, 10000]");
  if (!(intrinsics.pixel_size_um > 0 && intrinsics.pixel_size_um <= 1000)) return fail("pixel_size_um must be in (0, 1000]");
  const cv::Matx33d r = pose.rotation;
  const cv::Matx33d should_be_eye = r * r.t();
  if (cv::norm(should_be_eye - cv::Matx33d::eye(), cv::NORM_INF) > 1e-6 || std::abs(cv::determinant(r) - 1) > 1e-6)
    return fail("rotation must be orthonormal with determinant +1");
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(pose.translation_mm[i])) return fail("translation_mm must be finite");
  return true;
}

CameraPose look_at(const cv::Vec3d& eye_mm, const cv::Vec3d& target_mm, double roll_deg) {
  const cv::Vec3d forward = target_mm - eye_mm;
  if (!(cv::norm(forward) > 1e-9)) throw std::invalid_argument("look_at: eye and target coincide");
  const cv::Vec3d z = normalized(forward);
  const cv::Vec3d down(0, 1, 0);  // the image's "down" is world +Y
  const cv::Vec3d side = down.cross(z);
  if (!(cv::norm(side) > 1e-9)) throw std::invalid_argument("look_at: the camera looks along the patch's Y axis");
  const cv::Vec3d x0 = normalized(side);
  const cv::Vec3d y0 = z.cross(x0);
  const double c = std::cos(roll_deg * kDegree), s = std::sin(roll_deg * kDegree);
  const cv::Vec3d x = c * x0 + s * y0;
  const cv::Vec3d y = -s * x0 + c * y0;
  CameraPose pose;
  pose.rotation = {x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]};
  pose.translation_mm = -(pose.rotation * eye_mm);
  return pose;
}

cv::Vec3d orbit_eye_mm(double distance_mm, double azimuth_deg, double elevation_deg) {
  if (!(distance_mm > 0) || !(std::abs(azimuth_deg) < 90) || !(std::abs(elevation_deg) < 90))
    throw std::invalid_argument("orbit_eye_mm: distance must be positive, |azimuth| and |elevation| below 90 degrees");
  const double az = azimuth_deg * kDegree, el = elevation_deg * kDegree;
  return distance_mm * cv::Vec3d(std::sin(az) * std::cos(el), -std::sin(el), -std::cos(az) * std::cos(el));
}

cv::Matx33d patch_to_image_homography(const CameraView& view, const PatchGeometry& patch) {
  check(view);
  if (patch.width_px < 1 || patch.height_px < 1 || !(patch.pixel_size_mm > 0))
    throw std::invalid_argument("patch geometry: size and pixel size must be positive");
  const cv::Matx33d& r = view.pose.rotation;
  const cv::Vec3d& t = view.pose.translation_mm;
  const cv::Matx33d plane_to_camera(r(0, 0), r(0, 1), t[0], r(1, 0), r(1, 1), t[1], r(2, 0), r(2, 1), t[2]);
  const cv::Matx33d to_camera = plane_to_camera * patch_to_plane(patch);
  // Every corner in front of the camera: the patch never straddles the camera's plane.
  for (double x : {-0.5, patch.width_px - 0.5})
    for (double y : {-0.5, patch.height_px - 0.5}) {
      const cv::Vec3d in_camera = to_camera * cv::Vec3d(x, y, 1);
      if (!(in_camera[2] > 0)) throw std::invalid_argument("camera view: the patch is not wholly in front of the camera");
    }
  return view.intrinsics.matrix() * to_camera;
}

std::array<cv::Point2d, 4> patch_corners_in_image(const CameraView& view, const PatchGeometry& patch) {
  const cv::Matx33d h = patch_to_image_homography(view, patch);
  const double right = patch.width_px - 0.5, bottom = patch.height_px - 0.5;
  std::array<cv::Point2d, 4> corners;
  const cv::Vec3d patch_corners[4] = {{-0.5, -0.5, 1}, {right, -0.5, 1}, {right, bottom, 1}, {-0.5, bottom, 1}};
  for (int i = 0; i < 4; ++i) {
    const cv::Vec3d p = h * patch_corners[i];
    corners[i] = {p[0] / p[2], p[1] / p[2]};
  }
  return corners;
}

cv::Mat render_view(const cv::Mat& patch_image, const CameraView& view, double patch_pixel_size_mm) {
  if (patch_image.empty()) throw std::invalid_argument("render_view: empty patch image");
  const cv::Matx33d h =
      patch_to_image_homography(view, {patch_image.cols, patch_image.rows, patch_pixel_size_mm});
  cv::Mat image;
  // warpPerspective samples the source at H⁻¹·(sensor pixel): the inverse map.
  cv::warpPerspective(patch_image, image, cv::Mat(h), cv::Size(view.intrinsics.width_px, view.intrinsics.height_px),
                      cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  return image;
}

}  // namespace chromo::simulators
