#include "chromo/simulators/polarisation/polariser_pattern.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "chromo/simulators/scene/camera_view.hpp"

namespace chromo::simulators {
namespace {

cv::Vec3d mirror(const cv::Vec3d& e, const cv::Vec3d& h) { return e - 2.0 * e.dot(h) * h; }

// The camera's image x and y axes in the world frame (rows of look_at's rotation).
void image_axes(const cv::Vec3d& view, double roll_deg, cv::Vec3d* x, cv::Vec3d* y) {
  const CameraPose pose = look_at(view * 300.0, {0, 0, 0}, roll_deg);
  *x = cv::Vec3d(pose.rotation(0, 0), pose.rotation(0, 1), pose.rotation(0, 2));
  *y = cv::Vec3d(pose.rotation(1, 0), pose.rotation(1, 1), pose.rotation(1, 2));
}

std::vector<cv::Vec3d> hemisphere_lights(int count) {  // Fibonacci, even in solid angle, z < 0
  std::vector<cv::Vec3d> lights;
  const double golden_angle = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = -(i + 0.5) / count;
    const double r = std::sqrt(1.0 - z * z), phi = i * golden_angle;
    lights.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  return lights;
}

}  // namespace

CrossPolarisationLeak cross_polarisation_leak(const cv::Vec3d& design_view_in, const cv::Vec3d& camera_view_in,
                                              double roughness_rad, double camera_roll_deg, int light_count) {
  if (!(design_view_in[2] < 0) || !(camera_view_in[2] < 0))
    throw std::invalid_argument("cross_polarisation_leak: both views must be on the lit side of the patch (z < 0)");
  if (!(roughness_rad > 0)) throw std::invalid_argument("cross_polarisation_leak: roughness_rad must be positive");
  if (light_count < 100) throw std::invalid_argument("cross_polarisation_leak: light_count must be at least 100");
  const cv::Vec3d design_view = cv::normalize(design_view_in), camera_view = cv::normalize(camera_view_in);
  const cv::Vec3d patch_normal(0, 0, -1);

  // The pattern: the light's polarisation whose mirror image toward the
  // design camera lies along the design analyser's blocked axis (image y).
  cv::Vec3d design_x, design_y;
  image_axes(design_view, 0, &design_x, &design_y);
  auto pattern = [&](const cv::Vec3d& light) { return mirror(design_y, cv::normalize(light + design_view)); };

  const std::vector<cv::Vec3d> lights = hemisphere_lights(light_count);
  std::vector<cv::Vec3d> reflected;  // each light's pattern polarisation, mirrored toward the camera
  std::vector<double> weight;
  for (const cv::Vec3d& light : lights) {
    const cv::Vec3d h = cv::normalize(light + camera_view);
    const double tilt = std::acos(std::clamp(h.dot(patch_normal), -1.0, 1.0));
    reflected.push_back(mirror(pattern(light), h));
    weight.push_back(std::exp(-0.5 * tilt * tilt / (roughness_rad * roughness_rad)));
  }
  cv::Vec3d x, y;
  image_axes(camera_view, camera_roll_deg, &x, &y);
  CrossPolarisationLeak best;
  best.lobe_leak = 2.0;
  for (int step = 0; step < 720; ++step) {  // analyser angle in 0.25° steps
    const double angle = step * 0.25 * std::numbers::pi / 180.0;
    const cv::Vec3d analyser = std::cos(angle) * x + std::sin(angle) * y;
    double sum = 0, total = 0;
    for (std::size_t k = 0; k < lights.size(); ++k) {
      const double along = reflected[k].dot(analyser);
      sum += weight[k] * along * along;
      total += weight[k];
    }
    if (sum / total < best.lobe_leak) {
      best.lobe_leak = sum / total;
      best.analyser_angle_deg = step * 0.25;
    }
  }
  const double angle = best.analyser_angle_deg * std::numbers::pi / 180.0;
  const cv::Vec3d analyser = std::cos(angle) * x + std::sin(angle) * y;
  const cv::Vec3d mirror_light = 2.0 * patch_normal.dot(camera_view) * patch_normal - camera_view;
  const double along = mirror(pattern(mirror_light), patch_normal).dot(analyser);
  best.mirror_leak = along * along;
  return best;
}

}  // namespace chromo::simulators
