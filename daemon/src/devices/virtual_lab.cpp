#include "chromo/daemon/internal/devices/virtual_lab.hpp"

#include <atomic>
#include <stdexcept>

#include "chromo/session/frame_files.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromo/drivers/spectrometer_factory.hpp"
#include "chromo/simulators/calibration_lab.hpp"
#include "chromo/simulators/camera/camera_simulator.hpp"
#include "chromo/simulators/polarisation/polariser_optics.hpp"
#include "chromo/spectral/grid.hpp"
#include "chromo/simulators/scene/scene.hpp"

namespace chromo::daemon {

struct VirtualLabSimulators::Impl {
  explicit Impl(const VirtualLabOptions& options)
      : lab([&] {
          simulators::CalibrationLabOptions lab_options;
          lab_options.leds.time_scale = options.led_time_scale;
          if (!options.led_thermal_drift)
            for (auto& led : lab_options.leds.leds) led.peak_shift_nm_per_K = 0, led.flux_loss_per_K = 0;
          if (options.polarisers) lab_options.leds.polariser_banks.fill(true);  // all six types
          return lab_options;
        }()) {
    simulators::SkinSceneOptions skin_options;
    skin_options.width = skin_options.height = options.scene_size;
    skin_options.seed = options.seed;
    skin_options.threads = options.scene_threads;
    skin_options.white_patch = options.skin_white_strip;
    skin_options.subsurface = options.subsurface;
    skin = std::make_shared<const simulators::Scene>(simulators::make_skin_scene(skin_options));
    white = std::make_shared<const simulators::Scene>(
        simulators::make_white_target_scene(options.scene_size, options.scene_size));
    // The cameras see the LEDs (the lamp's port is closed during captures);
    // the lab outlives the camera simulators (declared first): non-owning.
    const std::shared_ptr<const simulators::SphereIllumination> light(std::shared_ptr<void>(), &lab.lab());
    const spectral::CameraSensitivity lab_sensitivity = simulators::CameraModelOptions{}.sensitivity;
    for (std::size_t i = 0; i < options.cameras.size(); ++i) {
      const auto sensitivity = simulators::lab_camera_sensitivity(options.cameras[i], lab_sensitivity);
      cameras.push_back(std::make_unique<simulators::CameraSimulator>(
          options.camera_simulator_options(i, sensitivity), light, skin));
      cameras.back()->set_skin_scene_options(skin, skin_options);  // its surface layer, seen through an analyser
      // The controller's trigger output is wired to every camera's Line0 (trigger_input "Line0").
      lab.lab().connect_trigger_output([raw = cameras.back().get()] { raw->pulse_trigger_input(); });
    }
    // The first camera's exposures are the controller's hardware trigger input (as in chromo-sim).
    cameras.front()->set_exposure_hook([leds = &lab.lab()] { leds->trigger(); });
  }
  ~Impl() { lab.lab().disconnect_trigger_outputs(); }  // before the camera goes
  simulators::CalibrationLab lab;
  std::shared_ptr<const simulators::Scene> skin, white;
  std::vector<std::unique_ptr<simulators::CameraSimulator>> cameras;
  std::atomic<bool> white_shown{false};
};

VirtualLabSimulators::VirtualLabSimulators(const VirtualLabOptions& options) {
  if (std::string error; !options.IsValid(&error)) throw std::invalid_argument("virtual lab: " + error);
  impl_ = std::make_unique<Impl>(options);
  modbus_port_ = impl_->lab.start_modbus_tcp();
}

VirtualLabSimulators::~VirtualLabSimulators() = default;

simulators::LedLab& VirtualLabSimulators::leds() { return impl_->lab.lab(); }
simulators::CameraSimulator& VirtualLabSimulators::camera() { return *impl_->cameras.front(); }
simulators::CameraSimulator& VirtualLabSimulators::camera(std::size_t index) { return *impl_->cameras.at(index); }
std::size_t VirtualLabSimulators::camera_count() const { return impl_->cameras.size(); }
simulators::CalibrationLab& VirtualLabSimulators::calibration_lab() { return impl_->lab; }

void VirtualLabSimulators::place_in_sphere(session::StepRole role) {
  if (role == session::StepRole::kDark) return;
  const bool white = role == session::StepRole::kWhite;
  if (impl_->white_shown.exchange(white) == white) return;
  for (auto& camera : impl_->cameras) camera->set_scene(white ? impl_->white : impl_->skin);
}

bool VirtualLabSimulators::showing_white_target() const { return impl_->white_shown; }

VirtualLab start_virtual_lab(const VirtualLabOptions& options) {
  VirtualLab lab;
  lab.simulators = std::make_shared<VirtualLabSimulators>(options);
  auto simulators = lab.simulators;
  lab.devices.push_back({"sphere", DeviceKind::kLedController, "modbus-tcp",
                         "127.0.0.1:" + std::to_string(simulators->modbus_port()), nlohmann::json::object()});
  std::string camera_description;
  for (std::size_t i = 0; i < options.cameras.size(); ++i) {
    const simulators::LabCamera& camera = options.cameras[i];
    const std::string format(drivers::pixel_format_name(camera.pixel_format));
    const std::string address = simulators->camera(i).address();
    lab.devices.push_back({camera.name, DeviceKind::kCamera, "aravis", options.serial_of(i),
                           // Small socket buffer: enough for a few 640x480 frames, within a default rmem_max.
                           {{"pixel_format", format},
                            {"ip_address", address},
                            {"trigger_input", "Line0"},
                            {"socket_buffer_bytes", 4 << 20},
                            {"frame_retention_ms", 500}}});
    camera_description += (i == 0 ? "" : ", ") + camera.name + " " + options.serial_of(i) + " on " + address +
                          ":3956 (" + std::to_string(camera.sensor_width) + "x" +
                          std::to_string(camera.sensor_height) + " " + format + (camera.pose ? ", posed" : "") + ")";
  }
  lab.devices.push_back({"spec0", DeviceKind::kSpectrometer, "virtual-usb",
                         "in-process USB transport of the simulated USB2000+", nlohmann::json::object()});
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
  lab.device_set.own_films = virtual_lab_surface_factors();
  lab.mixes = default_virtual_lab_mixes();
  lab.description = "LED controller simulator on Modbus TCP 127.0.0.1:" + std::to_string(simulators->modbus_port()) +
                    ", GigE Vision camera simulator" + (options.cameras.size() > 1 ? "s " : " ") +
                    camera_description + ", simulated USB2000+ spectrometer and reference lamp; real drivers; "
                    "LED lab time " + std::to_string(static_cast<int>(options.led_time_scale)) + "x" +
                    (options.polarisers ? "; polarised sphere (cross and parallel banks, camera analysers)" : "");
  return lab;
}

session::SurfaceFactors virtual_lab_surface_factors() {
  const simulators::PolariserFilm film;
  spectral::Spectrum ratio;
  for (int i = 0; i < spectral::kGridSize; ++i) ratio[i] = film.extinction_ratio_at(spectral::grid_wavelength_nm(i));
  return session::surface_factors_of_extinction(
      ratio, "the virtual lab's films (PolariserFilm: 1:" + std::to_string(static_cast<int>(film.extinction_ratio_550nm)) +
                 " at 550 nm, 1:" + std::to_string(static_cast<int>(film.extinction_ratio_400nm)) +
                 " at 400 nm; design view)");
}

}  // namespace chromo::daemon
