#pragma once
// Subject motion in the virtual lab: the subject (a forearm on a rest) is not
// still while a plan runs. Between captures it drifts (slow translation,
// rotation and a change of distance to the camera, which changes the
// magnification) and trembles (a random small displacement and rotation per
// capture). Poses are relative to the reference capture (the first subject
// capture, where the scene's pixels are the truth), so a capture t seconds
// after the reference sees the subject at
//
//   drift:   (vx, vy)·t mm, ω·t degrees, magnification 1 / (1 + vz·t / working_distance)
//   tremor:  N(0, σ_mm²) per axis, N(0, σ_deg²), drawn per capture (seed, capture index)
//
// converted to scene pixels with mm_per_scene_pixel, about the sensor's
// centre. Default amplitudes (docs/camera.md, "Subject motion"): a
// supported forearm drifts about 0.1 mm/s sideways and 0.2 mm/s along the
// optical axis and turns 0.05°/s; physiological tremor of a supported limb is
// tens of micrometres (σ 0.02 mm, 0.01°). These are the orders of magnitude
// of the literature on postural drift and physiological tremor, not
// measurements of ours; every one is configurable.
//
// The magnification change is what a Euclidean registration (shift +
// rotation, session/registration.hpp) cannot undo: it leaves a residual that
// grows with the time between captures, so a longer plan costs registration
// error.

#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

namespace chromo::simulators {

struct SubjectMotionOptions {
  bool enabled = false;                 // off: every capture sees the subject where the reference did
  double drift_x_mm_per_s = 0.10;
  double drift_y_mm_per_s = 0.05;
  double drift_deg_per_s = 0.05;
  double axial_drift_mm_per_s = 0.2;    // towards (+) the camera
  double working_distance_mm = 250;     // camera to subject
  double tremor_sigma_mm = 0.02;
  double tremor_sigma_deg = 0.01;
  double mm_per_scene_pixel = 0.025;    // a 2592-pixel sensor sees about 65 mm
  std::uint64_t seed = 11;

  bool IsValid(std::string* error) const;
};

struct SubjectPose {
  double dx_px = 0, dy_px = 0;   // scene pixels
  double rotation_deg = 0;
  double scale = 1;              // magnification relative to the reference capture
};

// The pose of capture `capture_index` taken `seconds_since_reference` after
// the reference capture (identity for the reference itself: index 0 at 0 s
// with tremor drawn only for later captures).
SubjectPose subject_pose(const SubjectMotionOptions& options, double seconds_since_reference, int capture_index);

// The 2×3 map from reference image coordinates to this capture's image
// coordinates (a point of the subject at q in the reference is at M·q here),
// about the centre (cx, cy).
cv::Matx23d pose_matrix(const SubjectPose& pose, double cx, double cy);

// The subject as this capture sees it: `reference` (any CV_32FC(n) image)
// warped by the pose (bilinear; the border the motion uncovers is the
// reflected scene, within the motion's amplitude of the edge).
cv::Mat move_subject(const cv::Mat& reference, const SubjectPose& pose);

}  // namespace chromo::simulators
