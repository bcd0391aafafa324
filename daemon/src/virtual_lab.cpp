#include "chromo/daemon/virtual_lab.hpp"

#include <atomic>
#include <stdexcept>

#include "chromo/session/frame_files.hpp"
#include "chromo/drivers/spectrometer_factory.hpp"
#include "chromo/simulators/calibration_lab.hpp"
#include "chromo/simulators/camera/camera_simulator.hpp"
#include "chromo/simulators/scene/scene.hpp"

namespace chromo::daemon {

bool VirtualLabOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (sensor_width < 16 || sensor_width > 4096 || sensor_height < 16 || sensor_height > 4096)
    return fail("sensor_width/sensor_height: must be in [16, 4096]");
  if (scene_size < 16 || scene_size > 2048) return fail("scene_size: must be in [16, 2048]");
  if (!(led_time_scale >= 1 && led_time_scale <= 100000)) return fail("led_time_scale: must be in [1, 100000]");
  if (camera_serial.empty() || camera_serial.size() > 15)
    return fail("camera_serial: must be 1-15 characters (GigE Vision bootstrap)");
  if (!camera_address.empty() && (!camera_address.starts_with("127.") || camera_address.size() > 15))
    return fail("camera_address: must be empty or an address in 127.0.0.0/8");
  DeviceConfig probe;
  probe.settings = {{"pixel_format", pixel_format}};
  try {
    camera_capture_settings(probe);
  } catch (const std::invalid_argument& e) {
    return fail(e.what());
  }
  return true;
}

struct VirtualLabSimulators::Impl {
  explicit Impl(const VirtualLabOptions& options)
      : lab([&] {
          simulators::CalibrationLabOptions lab_options;
          lab_options.leds.time_scale = options.led_time_scale;
          return lab_options;
        }()) {
    simulators::SkinSceneOptions skin_options;
    skin_options.width = skin_options.height = options.scene_size;
    skin_options.seed = options.seed;
    skin_options.threads = options.scene_threads;
    skin = std::make_shared<const simulators::Scene>(simulators::make_skin_scene(skin_options));
    white = std::make_shared<const simulators::Scene>(
        simulators::make_white_target_scene(options.scene_size, options.scene_size));
    simulators::CameraSimulatorOptions camera_options;
    camera_options.serial = options.camera_serial;
    camera_options.sensor_width = options.sensor_width;
    camera_options.sensor_height = options.sensor_height;
    camera_options.camera_model.seed = options.seed;
    camera_options.address = options.camera_address;
    // The camera sees the LEDs (the lamp's port is closed during captures);
    // the lab outlives the camera simulator (declared first): non-owning.
    const std::shared_ptr<const simulators::SphereIllumination> light(std::shared_ptr<void>(), &lab.lab());
    camera = std::make_unique<simulators::CameraSimulator>(camera_options, light, skin);
    // The camera's exposures are the controller's hardware trigger input (as in chromo-sim).
    camera->set_exposure_hook([leds = &lab.lab()] { leds->trigger(); });
    // The controller's trigger output is wired to the camera's Line0 (cam0's trigger_input).
    lab.lab().connect_trigger_output([raw = camera.get()] { raw->pulse_trigger_input(); });
  }
  ~Impl() { lab.lab().disconnect_trigger_outputs(); }  // before the camera goes
  simulators::CalibrationLab lab;
  std::shared_ptr<const simulators::Scene> skin, white;
  std::unique_ptr<simulators::CameraSimulator> camera;
  std::atomic<bool> white_shown{false};
};

VirtualLabSimulators::VirtualLabSimulators(const VirtualLabOptions& options) {
  if (std::string error; !options.IsValid(&error)) throw std::invalid_argument("virtual lab: " + error);
  impl_ = std::make_unique<Impl>(options);
  modbus_port_ = impl_->lab.start_modbus_tcp();
}

VirtualLabSimulators::~VirtualLabSimulators() = default;

simulators::LedLab& VirtualLabSimulators::leds() { return impl_->lab.lab(); }
simulators::CameraSimulator& VirtualLabSimulators::camera() { return *impl_->camera; }
simulators::CalibrationLab& VirtualLabSimulators::calibration_lab() { return impl_->lab; }

void VirtualLabSimulators::place_in_sphere(session::StepRole role) {
  if (role == session::StepRole::kDark) return;
  const bool white = role == session::StepRole::kWhite;
  if (impl_->white_shown.exchange(white) == white) return;
  impl_->camera->set_scene(white ? impl_->white : impl_->skin);
}

bool VirtualLabSimulators::showing_white_target() const { return impl_->white_shown; }

VirtualLab start_virtual_lab(const VirtualLabOptions& options) {
  VirtualLab lab;
  lab.simulators = std::make_shared<VirtualLabSimulators>(options);
  auto simulators = lab.simulators;
  lab.devices = {
      {"sphere", DeviceKind::kLedController, "modbus-tcp", "127.0.0.1:" + std::to_string(simulators->modbus_port()),
       nlohmann::json::object()},
      {"cam0", DeviceKind::kCamera, "aravis", options.camera_serial,
       // Small socket buffer: enough for a few 640x480 frames, within a default rmem_max.
       {{"pixel_format", options.pixel_format},
        {"ip_address", simulators->camera().address()},
        {"trigger_input", "Line0"},
        {"socket_buffer_bytes", 4 << 20},
        {"frame_retention_ms", 500}}},
      {"spec0", DeviceKind::kSpectrometer, "virtual-usb", "in-process USB transport of the simulated USB2000+",
       nlohmann::json::object()},
  };
  BackendRegistry registry = builtin_backends();
  // The real USB2000+ driver over the simulator's in-process transport (the
  // simulated spectrometer has no libusb device node to open).
  registry.add_spectrometer("virtual-usb", [simulators](const DeviceConfig&) {
    return drivers::make_usb_spectrometer(simulators->calibration_lab().make_spectrometer_transport());
  });
  lab.device_set = registry.open(lab.devices);
  lab.device_set.keep_alive.push_back(simulators);
  lab.device_set.place_in_sphere = [raw = simulators.get()](session::StepRole role) { raw->place_in_sphere(role); };
  lab.device_set.reference_lamp = [raw = simulators.get()](bool on) { raw->calibration_lab().lamp().set_on(on); };
  lab.device_set.lab_time_scale = options.led_time_scale;
  lab.mixes = default_virtual_lab_mixes();
  lab.description = "LED controller simulator on Modbus TCP 127.0.0.1:" + std::to_string(simulators->modbus_port()) +
                    ", GigE Vision camera simulator " + options.camera_serial + " on " +
                    simulators->camera().address() + ":3956 (" +
                    std::to_string(options.sensor_width) + "x" + std::to_string(options.sensor_height) + " " +
                    options.pixel_format + "), simulated USB2000+ spectrometer and reference lamp; real drivers; "
                    "LED lab time " + std::to_string(static_cast<int>(options.led_time_scale)) + "x";
  return lab;
}

}  // namespace chromo::daemon
