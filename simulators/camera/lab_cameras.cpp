// The virtual lab's camera list: see lab_cameras.hpp.
#include "chromo/simulators/camera/lab_cameras.hpp"

#include <arpa/inet.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

#include "chromo/session/session_plan.hpp"
#include "chromo/simulators/polarisation/polariser_pattern.hpp"

namespace chromo::simulators {
namespace {

using nlohmann::json;

std::string shown(const json& value) {
  std::string text = value.dump();
  return text.size() > 64 ? text.substr(0, 61) + "..." : text;
}

int read_int(const json& value, int min, int max) {
  const std::string range = "[" + std::to_string(min) + ", " + std::to_string(max) + "]";
  if (!value.is_number_integer()) throw std::invalid_argument(shown(value) + " is not an integer in " + range);
  const bool large = value.is_number_unsigned() && value.get<std::uint64_t>() > static_cast<std::uint64_t>(max);
  if (large || value.get<std::int64_t>() < min || value.get<std::int64_t>() > max)
    throw std::invalid_argument(shown(value) + " is outside " + range);
  return static_cast<int>(value.get<std::int64_t>());
}

// A number in the open interval (min, max), or the closed one [min, max].
double read_number(const json& value, double min, double max, bool open) {
  const std::string range = std::string(open ? "(" : "[") + json(min).dump() + ", " + json(max).dump() + (open ? ")" : "]");
  if (!value.is_number()) throw std::invalid_argument(shown(value) + " is not a number in " + range);
  const double v = value.get<double>();
  const bool inside = open ? v > min && v < max : v >= min && v <= max;
  if (!std::isfinite(v) || !inside) throw std::invalid_argument(shown(value) + " is outside " + range);
  return v;
}

std::string read_string(const json& value) {
  if (!value.is_string()) throw std::invalid_argument(shown(value) + " is not a string");
  return value.get<std::string>();
}

// Runs read(value) and names the key in what it throws.
template <class Read>
void keyed(const std::string& key, Read read) {
  try {
    read();
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(key + ": " + error.what());
  }
}

LabCameraPose read_pose(const json& value) {
  if (!value.is_object()) throw std::invalid_argument(shown(value) + " is not a JSON object");
  LabCameraPose pose;
  for (const auto& entry : value.items()) {
    // Not a structured binding: clang 14 (the fuzz build) cannot capture one in a lambda.
    const std::string& key = entry.key();
    const json& v = entry.value();
    keyed("." + key, [&] {
      if (key == "distance_mm") pose.distance_mm = read_number(v, 0, 100000, true);
      else if (key == "azimuth_deg") pose.azimuth_deg = read_number(v, -90, 90, true);
      else if (key == "elevation_deg") pose.elevation_deg = read_number(v, -90, 90, true);
      else if (key == "roll_deg") pose.roll_deg = read_number(v, -180, 180, false);
      else if (key == "focal_length_mm") pose.focal_length_mm = read_number(v, 0, 10000, true);
      else if (key == "pixel_size_um") pose.pixel_size_um = read_number(v, 0, 1000, true);
      else
        throw std::invalid_argument(
            "unknown key (distance_mm, azimuth_deg, elevation_deg, roll_deg, focal_length_mm, pixel_size_um)");
    });
  }
  return pose;
}

std::string read_address(const json& value) {
  const std::string text = read_string(value);
  if (text == "auto") return {};
  in_addr parsed{};
  if (::inet_pton(AF_INET, text.c_str(), &parsed) != 1 || !text.starts_with("127."))
    throw std::invalid_argument("\"" + text.substr(0, 64) + "\" is not \"auto\" or an address in 127.0.0.0/8");
  return text;
}

LabCamera read_camera(const json& entry) {
  if (!entry.is_object()) throw std::invalid_argument(" must be a JSON object");
  if (!entry.contains("name")) throw std::invalid_argument("name: missing");
  LabCamera camera;
  for (const auto& field : entry.items()) {
    const std::string& key = field.key();  // not a structured binding (clang 14, as in read_pose)
    const json& v = field.value();
    if (key == "pose") {
      try {
        camera.pose = read_pose(v);
      } catch (const std::invalid_argument& error) {
        const std::string what = error.what();
        throw std::invalid_argument("pose" + (what.starts_with(".") ? what : ": " + what));
      }
      continue;
    }
    keyed(key, [&] {
      if (key == "name") {
        camera.name = read_string(v);
        if (!session::is_valid_name(camera.name))
          throw std::invalid_argument("\"" + camera.name.substr(0, 64) + "\" does not match [A-Za-z0-9_+.-]{1,64}");
      } else if (key == "serial") {
        camera.serial = read_string(v);
        if (camera.serial.empty() || camera.serial.size() > 15)
          throw std::invalid_argument("must be 1-15 characters (GigE Vision bootstrap)");
      } else if (key == "address") {
        camera.address = read_address(v);
      } else if (key == "sensor_width") {
        camera.sensor_width = read_int(v, 16, 4096);
      } else if (key == "sensor_height") {
        camera.sensor_height = read_int(v, 16, 4096);
      } else if (key == "pixel_format") {
        const std::string name = read_string(v);
        const auto format = drivers::parse_pixel_format(name);
        if (!format)
          throw std::invalid_argument("\"" + name.substr(0, 64) + "\" unknown (" + drivers::pixel_format_names() + ")");
        camera.pixel_format = *format;
      } else if (key == "sensitivity") {
        camera.sensitivity = read_string(v);
        if (camera.sensitivity.empty()) throw std::invalid_argument("empty (builtin:NAME or a CSV file)");
      } else {
        throw std::invalid_argument(
            "unknown key (name, serial, address, sensor_width, sensor_height, pixel_format, pose, sensitivity)");
      }
    });
  }
  return camera;
}

}  // namespace

std::vector<LabCamera> read_lab_cameras(const json& list) {
  if (!list.is_array()) throw std::invalid_argument(": " + shown(list) + " is not a JSON array");
  if (list.empty()) throw std::invalid_argument(": the lab needs at least one camera");
  if (list.size() > 64) throw std::invalid_argument(": at most 64 cameras");
  std::vector<LabCamera> cameras;
  std::set<std::string> names, serials, addresses;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string at = "[" + std::to_string(i) + "]";
    try {
      cameras.push_back(read_camera(list[i]));
    } catch (const std::invalid_argument& error) {
      const std::string what = error.what();
      throw std::invalid_argument(at + (what.starts_with(" ") ? what.substr(1).insert(0, ": ") : "." + what));
    }
    const LabCamera& camera = cameras.back();
    if (!names.insert(camera.name).second)
      throw std::invalid_argument(at + ".name: \"" + camera.name + "\" is used twice");
    if (!camera.serial.empty() && !serials.insert(camera.serial).second)
      throw std::invalid_argument(at + ".serial: \"" + camera.serial + "\" is used twice");
    if (!camera.address.empty() && !addresses.insert(camera.address).second)
      throw std::invalid_argument(at + ".address: \"" + camera.address + "\" is used twice");
  }
  return cameras;
}

std::string lab_camera_serial(const LabCamera& camera, const std::string& first_serial, std::size_t index) {
  if (!camera.serial.empty()) return camera.serial;
  return index == 0 ? first_serial : first_serial.substr(0, 13) + std::to_string(index);
}

std::optional<CameraView> lab_camera_view(const LabCamera& camera) {
  if (!camera.pose) return std::nullopt;
  const LabCameraPose& pose = *camera.pose;
  CameraView view;
  view.intrinsics = {camera.sensor_width, camera.sensor_height, pose.focal_length_mm, pose.pixel_size_um};
  view.pose = look_at(orbit_eye_mm(pose.distance_mm, pose.azimuth_deg, pose.elevation_deg), {0, 0, 0}, pose.roll_deg);
  return view;
}

double lab_camera_field_width_mm(const LabCamera& camera, double patch_width_mm) {
  const std::optional<CameraView> view = lab_camera_view(camera);
  if (!view) return patch_width_mm;
  // A patch of 1 mm pixels: the image → patch map's step along a row at the centre, in mm per sensor pixel.
  const int patch_px = std::max(2, static_cast<int>(std::lround(patch_width_mm)));
  const PatchGeometry patch{patch_px, patch_px, patch_width_mm / patch_px};
  const cv::Matx33d to_patch = patch_to_image_homography(*view, patch).inv();
  const auto at = [&](double x, double y) {
    const cv::Vec3d p = to_patch * cv::Vec3d(x, y, 1);
    return cv::Vec2d(p[0] / p[2], p[1] / p[2]) * patch.pixel_size_mm;
  };
  const double cx = 0.5 * (camera.sensor_width - 1), cy = 0.5 * (camera.sensor_height - 1);
  const double mm_per_pixel = cv::norm(at(cx + 0.5, cy) - at(cx - 0.5, cy));
  return mm_per_pixel * camera.sensor_width;
}

spectral::CameraSensitivity lab_camera_sensitivity(const LabCamera& camera,
                                                   const spectral::CameraSensitivity& fallback) {
  if (camera.sensitivity.empty()) return fallback;
  if (camera.sensitivity.starts_with("builtin:")) return spectral::builtin_camera(camera.sensitivity.substr(8));
  return spectral::read_camera_sensitivity(camera.sensitivity);
}

CameraSimulatorOptions lab_camera_simulator_options(const LabCamera& camera, std::size_t index,
                                                    const std::string& first_serial, double patch_width_mm,
                                                    std::uint64_t seed, const spectral::CameraSensitivity& sensitivity) {
  CameraSimulatorOptions options;
  options.serial = lab_camera_serial(camera, first_serial, index);
  options.address = camera.address;
  options.sensor_width = camera.sensor_width;
  options.sensor_height = camera.sensor_height;
  options.pixel_format = camera.pixel_format;
  options.view = lab_camera_view(camera);
  options.patch_width_mm = patch_width_mm;
  options.camera_model.sensitivity = sensitivity;
  options.camera_model.seed = seed + index;
  return options;
}

CameraAnalyser lab_camera_analyser(const LabCamera& camera, double roughness_rad) {
  if (!(roughness_rad > 0)) throw std::invalid_argument("lab_camera_analyser: roughness_rad must be positive");
  CameraAnalyser analyser;
  if (!camera.pose || (camera.pose->azimuth_deg == 0 && camera.pose->elevation_deg == 0)) return analyser;
  const LabCameraPose& pose = *camera.pose;
  const cv::Vec3d design_view(0, 0, -1);  // the patch normal, toward the cameras (camera_view.hpp's frame)
  const cv::Vec3d view = cv::normalize(orbit_eye_mm(pose.distance_mm, pose.azimuth_deg, pose.elevation_deg));
  analyser.view_angle_deg = std::acos(std::clamp(view.dot(design_view), -1.0, 1.0)) * 180.0 / M_PI;
  analyser.cross_leak = cross_polarisation_leak(design_view, view, roughness_rad, pose.roll_deg).lobe_leak;
  return analyser;
}

}  // namespace chromo::simulators
