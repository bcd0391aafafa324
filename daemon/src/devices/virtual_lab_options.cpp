// VirtualLabOptions' checks, the camera simulators' options it gives, and
// the configuration's virtual_lab section mapped to it: apart from
// virtual_lab.cpp (which starts the lab) so that the configuration reader,
// which reads and checks virtual_lab.cameras with them, links without the
// devices (the fuzz_config harness compiles it alone).
#include <set>
#include <stdexcept>

#include "chromo/daemon/internal/devices/virtual_lab.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromo/simulators/camera/camera_simulator.hpp"
#include "chromo/simulators/camera/lab_cameras.hpp"
#include "chromo/simulators/scene/camera_view.hpp"

namespace chromo::daemon {

bool VirtualLabOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (cameras.empty()) return fail("cameras: the lab needs at least one camera");
  if (scene_size < 16 || scene_size > 2048) return fail("scene_size: must be in [16, 2048]");
  if (!(patch_width_mm > 0 && patch_width_mm <= 10000)) return fail("patch_width_mm: must be in (0, 10000]");
  if (subsurface.on && !subsurface.IsValid(nullptr))
    return fail("subsurface_blue_px: must be in (0, subsurface_red_px], subsurface_red_px at most 64");
  if (camera_serial.empty() || camera_serial.size() > 15)
    return fail("camera_serial: must be 1-15 characters (GigE Vision bootstrap)");
  std::set<std::string> names, addresses, serials;
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const simulators::LabCamera& camera = cameras[i];
    const std::string at = "cameras[" + std::to_string(i) + "].";
    if (!session::is_valid_name(camera.name)) return fail(at + "name: must match [A-Za-z0-9_+.-]{1,64}");
    if (camera.name == "sphere" || camera.name == "spec0")
      return fail(at + "name: \"" + camera.name + "\" is the lab's LED controller or spectrometer");
    if (!names.insert(camera.name).second) return fail(at + "name: \"" + camera.name + "\" is used twice");
    if (!camera.address.empty() && !addresses.insert(camera.address).second)
      return fail(at + "address: \"" + camera.address + "\" is used twice");
    if (!serials.insert(serial_of(i)).second) return fail(at + "serial: \"" + serial_of(i) + "\" is used twice");
    const simulators::CameraSimulatorOptions simulator = camera_simulator_options(i, simulators::CameraModelOptions{}.sensitivity);
    if (std::string problem; !simulator.IsValid(&problem)) return fail(at.substr(0, at.size() - 1) + ": " + problem);
    if (simulator.view) try {  // the square patch wholly in front of the camera
        simulators::patch_to_image_homography(*simulator.view, {scene_size, scene_size, patch_width_mm / scene_size});
      } catch (const std::invalid_argument& e) {
        return fail(at + "pose: " + e.what());
      }
  }
  if (!(polariser_roughness_rad > 0 && polariser_roughness_rad <= 1))
    return fail("polariser_roughness_rad: must be in (0, 1]");
  if (!(led_time_scale >= 1 && led_time_scale <= 100000)) return fail("led_time_scale: must be in [1, 100000]");
  return true;
}

std::string VirtualLabOptions::serial_of(std::size_t index) const {
  return simulators::lab_camera_serial(cameras.at(index), camera_serial, index);
}

simulators::CameraSimulatorOptions VirtualLabOptions::camera_simulator_options(
    std::size_t index, const spectral::CameraSensitivity& sensitivity) const {
  simulators::CameraSimulatorOptions options = simulators::lab_camera_simulator_options(
      cameras.at(index), index, camera_serial, patch_width_mm, seed, sensitivity);
  if (polarisers) options.analyser = simulators::lab_camera_analyser(cameras.at(index), polariser_roughness_rad);
  return options;
}

namespace {

VirtualCameraConfig plain_camera(const simulators::LabCamera& camera) {
  VirtualCameraConfig plain{camera.name,         camera.serial,       camera.address,
                            camera.sensor_width, camera.sensor_height, camera.pixel_format,
                            std::nullopt,        camera.sensitivity};
  if (const auto& pose = camera.pose)
    plain.pose = VirtualCameraPose{pose->distance_mm, pose->azimuth_deg,     pose->elevation_deg,
                                   pose->roll_deg,    pose->focal_length_mm, pose->pixel_size_um};
  return plain;
}

simulators::LabCamera lab_camera(const VirtualCameraConfig& plain) {
  simulators::LabCamera camera{plain.name,         plain.serial,       plain.address,
                               plain.sensor_width, plain.sensor_height, plain.pixel_format,
                               std::nullopt,       plain.sensitivity};
  if (const auto& pose = plain.pose)
    camera.pose = simulators::LabCameraPose{pose->distance_mm, pose->azimuth_deg,     pose->elevation_deg,
                                            pose->roll_deg,    pose->focal_length_mm, pose->pixel_size_um};
  return camera;
}

}  // namespace

std::vector<VirtualCameraConfig> read_virtual_cameras(const nlohmann::json& list) {
  std::vector<VirtualCameraConfig> cameras;
  for (const auto& camera : simulators::read_lab_cameras(list)) cameras.push_back(plain_camera(camera));
  return cameras;
}

VirtualLabOptions virtual_lab_options(const VirtualLabConfig& config) {
  VirtualLabOptions options;
  options.cameras.clear();
  for (const auto& camera : config.cameras) options.cameras.push_back(lab_camera(camera));
  options.patch_width_mm = config.patch_width_mm;
  options.polarisers = config.polarisers;
  options.subsurface.on = config.subsurface;
  options.subsurface.sigma_blue_px = config.subsurface_blue_px;
  options.subsurface.sigma_red_px = config.subsurface_red_px;
  return options;
}

}  // namespace chromo::daemon
