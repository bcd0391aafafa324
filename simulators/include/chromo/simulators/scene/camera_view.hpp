#pragma once
// CameraView: where a virtual-lab camera stands and what it sees of the
// planar skin patch: a pinhole camera (intrinsics from its sensor size,
// pixel size and focal length) with a pose (rotation, translation) in the
// patch's world frame, and the homography patch → image that follows
// (docs/camera.md "Camera views").
//
// World frame, millimetres: the patch lies in the plane Z = 0, centred on the
// origin, X along the scene's columns and Y along its rows (down the scene),
// so a camera on the −Z side looking at the origin without roll sees the
// patch upright. Camera frame: OpenCV's (x right, y down, z forward along
// the optical axis); x_camera = R·X_world + t.
//
// Pixel coordinates, in the patch (scene pixels) and in the image (sensor
// pixels) alike: pixel centres at integers, (0, 0) the first pixel's centre
// (OpenCV's remap/warp convention). The patch's pixel (x, y) is at
// X = (x − (W−1)/2)·s, Y = (y − (H−1)/2)·s with s its pixel size in mm; the
// principal point is the sensor's centre ((w−1)/2, (h−1)/2).
//
// Pure functions on values; no state. Throws std::invalid_argument for
// invalid views (IsValid's message) and for a patch that is not wholly in
// front of the camera.

#include <opencv2/core.hpp>

#include <array>
#include <string>

namespace chromo::simulators {

struct CameraIntrinsics {
  int width_px = 640;            // sensor size, pixels
  int height_px = 480;
  double focal_length_mm = 25;
  double pixel_size_um = 3.45;   // square pixels

  // K: f = focal_length_mm / pixel_size in pixels, principal point at the centre.
  cv::Matx33d matrix() const;
};

struct CameraPose {
  cv::Matx33d rotation = cv::Matx33d::eye();   // world → camera, orthonormal, det +1
  cv::Vec3d translation_mm{0, 0, 300};         // the world origin in camera coordinates
};

struct CameraView {
  CameraIntrinsics intrinsics;
  CameraPose pose;

  bool IsValid(std::string* error) const;
};

// The scene as a physical patch: width × height pixels of pixel_size_mm.
struct PatchGeometry {
  int width_px = 256;
  int height_px = 256;
  double pixel_size_mm = 0.25;
};

// A camera at eye_mm looking at target_mm, rolled by roll_deg about its
// optical axis (positive: the image turns clockwise); "up" in its image is
// world −Y. Throws when eye and target coincide or the camera looks along ±Y.
CameraPose look_at(const cv::Vec3d& eye_mm, const cv::Vec3d& target_mm, double roll_deg = 0);

// The eye of a camera distance_mm from the patch centre, swung azimuth_deg
// towards +X (right) and elevation_deg towards −Y (up) from the patch's
// normal on the −Z side; |azimuth|, |elevation| < 90.
cv::Vec3d orbit_eye_mm(double distance_mm, double azimuth_deg, double elevation_deg);

// H with image ~ H · (patch x, y, 1)ᵀ. Throws when a patch corner is not in
// front of the camera (depth ≤ 0).
cv::Matx33d patch_to_image_homography(const CameraView& view, const PatchGeometry& patch);

// The camera's view of `patch_image` (any depth, 1-4 channels; its size is
// the patch's): every sensor pixel inverse-mapped through the homography and
// sampled bilinearly; sensor pixels that see no patch are 0 (dark).
cv::Mat render_view(const cv::Mat& patch_image, const CameraView& view, double patch_pixel_size_mm);

// The patch's four corners (outer pixel edges) in image pixels, clockwise
// from the top-left: where a view's patch ends.
std::array<cv::Point2d, 4> patch_corners_in_image(const CameraView& view, const PatchGeometry& patch);

}  // namespace chromo::simulators
