#include "chromo/simulators/scene/subject_motion.hpp"

#include <cmath>
#include <random>

#include <opencv2/imgproc.hpp>

namespace chromo::simulators {

bool SubjectMotionOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  auto speed_ok = [](double v, double limit) { return std::isfinite(v) && std::abs(v) <= limit; };
  if (!speed_ok(drift_x_mm_per_s, 10) || !speed_ok(drift_y_mm_per_s, 10))
    return fail("motion.drift_x_mm_per_s/drift_y_mm_per_s: must be within ±10 mm/s");
  if (!speed_ok(drift_deg_per_s, 10)) return fail("motion.drift_deg_per_s: must be within ±10 °/s");
  if (!speed_ok(axial_drift_mm_per_s, 10)) return fail("motion.axial_drift_mm_per_s: must be within ±10 mm/s");
  if (!(working_distance_mm >= 20 && working_distance_mm <= 5000)) return fail("motion.working_distance_mm: must be 20-5000");
  if (!(tremor_sigma_mm >= 0 && tremor_sigma_mm <= 5)) return fail("motion.tremor_sigma_mm: must be 0-5");
  if (!(tremor_sigma_deg >= 0 && tremor_sigma_deg <= 5)) return fail("motion.tremor_sigma_deg: must be 0-5");
  if (!(mm_per_scene_pixel >= 0.001 && mm_per_scene_pixel <= 10)) return fail("motion.mm_per_scene_pixel: must be 0.001-10");
  return true;
}

SubjectPose subject_pose(const SubjectMotionOptions& o, double t, int capture_index) {
  SubjectPose pose;
  if (!o.enabled) return pose;
  pose.dx_px = o.drift_x_mm_per_s * t / o.mm_per_scene_pixel;
  pose.dy_px = o.drift_y_mm_per_s * t / o.mm_per_scene_pixel;
  pose.rotation_deg = o.drift_deg_per_s * t;
  pose.scale = 1.0 / (1.0 - o.axial_drift_mm_per_s * t / o.working_distance_mm);  // closer: larger
  if (capture_index > 0) {
    std::mt19937_64 rng(o.seed * 0x9E3779B97F4A7C15ull + static_cast<std::uint64_t>(capture_index));
    std::normal_distribution<double> normal;
    pose.dx_px += o.tremor_sigma_mm * normal(rng) / o.mm_per_scene_pixel;
    pose.dy_px += o.tremor_sigma_mm * normal(rng) / o.mm_per_scene_pixel;
    pose.rotation_deg += o.tremor_sigma_deg * normal(rng);
  }
  return pose;
}

cv::Matx23d pose_matrix(const SubjectPose& pose, double cx, double cy) {
  const double a = pose.rotation_deg * M_PI / 180.0;
  const double c = pose.scale * std::cos(a), s = pose.scale * std::sin(a);
  // M·q = centre + s·R·(q − centre) + shift
  return {c, -s, cx - c * cx + s * cy + pose.dx_px, s, c, cy - s * cx - c * cy + pose.dy_px};
}

cv::Mat move_subject(const cv::Mat& reference, const SubjectPose& pose) {
  if (pose.dx_px == 0 && pose.dy_px == 0 && pose.rotation_deg == 0 && pose.scale == 1) return reference;
  const cv::Matx23d m = pose_matrix(pose, 0.5 * (reference.cols - 1), 0.5 * (reference.rows - 1));
  cv::Mat moved;
  cv::warpAffine(reference, moved, cv::Mat(m), reference.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT_101);
  return moved;
}

}  // namespace chromo::simulators
