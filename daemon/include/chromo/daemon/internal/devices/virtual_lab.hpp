#pragma once
// The built-in virtual lab chromod runs without devices configured, one more
// backend of the device set (open_devices, devices.hpp): the device
// simulators of simulators/ started in this process on their real protocols,
// exactly as chromo-sim starts them, and devices connected to them through
// the real drivers:
//
//   LED controller "sphere"  LedControllerSimulator on Modbus TCP 127.0.0.1:<free port>
//                            ← drivers' Modbus TCP LedController (backend "modbus-tcp")
//   cameras ("cam0" by       one CameraSimulator per VirtualLabOptions::cameras entry
//   default)                 (simulators/camera/lab_cameras.hpp: sensor, pixel format,
//                            pose, sensitivity), GigE Vision each on its own loopback
//                            address 127.77.x.y:3956 (the project's device side, setting
//                            the device's ip_address) rendering its view of the scene
//                            under the LEDs' light. Every camera's Line0 is wired to the
//                            controller's trigger output (trigger_input "Line0": the
//                            controller, the trigger master, triggers them all); the
//                            first camera's exposure-active line is the controller's
//                            trigger input, as in chromo-sim
//                            ← AravisCamera (backend "aravis")
//   spectrometer "spec0"     simulated USB2000+ behind the USB transport seam, looking
//                            into the sphere (LEDs + the reference lamp)
//                            ← drivers' USB2000+ driver (backend "virtual-usb": the real
//                            driver over the simulator's in-process transport)
//
// The scene is the skin patch; DeviceSet::place_in_sphere switches it to the
// white target for white-reference steps and back for subject steps (the
// operator's job in the real sphere). DeviceSet::reference_lamp switches the
// lamp calibration runs measure first.
//
// Each camera simulator binds an address of its own (its LabCamera::address,
// or one picked at random in 127.77.0.0/16), so cameras and labs run side by
// side; start_virtual_lab throws std::runtime_error when an explicit address
// is taken.
//
// Lifetime: the simulators live in VirtualLab::simulators, which the
// DeviceSet also keeps alive (destroyed after the drivers). Thread rules:
// the fault switches of VirtualLabSimulators (tests) may be called from any
// one thread while sessions run on theirs.

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/daemon/config.hpp"
#include "chromo/daemon/internal/devices/device_set.hpp"
#include "chromo/session/surface_factors.hpp"
#include "chromo/simulators/camera/lab_cameras.hpp"
#include "chromo/simulators/scene/scene.hpp"

namespace chromo::simulators {
class CalibrationLab;
class CameraSimulator;
class LedLab;
}  // namespace chromo::simulators

namespace chromo::daemon {

struct VirtualLabOptions {
  // The cameras, each a device of that name (default: "cam0", 640x480
  // BayerRG12, filling its sensor with the patch: small, the pipeline
  // stores every frame). Names must differ from "sphere" and "spec0".
  std::vector<simulators::LabCamera> cameras = {simulators::LabCamera{}};
  double patch_width_mm = 80;      // the skin patch's physical width, for posed cameras
  int scene_size = 256;            // skin and white-target scenes (square), seen by every camera
  // The first camera's serial when its entry names none; camera k > 0 gets
  // the first 13 characters of it and k (simulators::lab_camera_serial).
  std::string camera_serial = "CHROMO-VLAB-CAM";
  double led_time_scale = 300;     // lab seconds per wall-clock second (LED warm-up, drift)
  // false: the LEDs do not drift with their junction temperature (every
  // type's peak_shift_nm_per_K and flux_loss_per_K 0), for measuring what
  // else differs between two sessions.
  bool led_thermal_drift = true;
  // false: the skin scene without its white target strip (SkinSceneOptions::white_patch).
  bool skin_white_strip = true;
  std::uint64_t seed = 1;          // scene and camera noise
  int scene_threads = 0;           // building the skin scene (0 = all cores)
  // A polarised sphere (docs/polarisation.md): every LED type has a cross
  // and a parallel bank (the default film) and every camera an analyser,
  // crossed for the view along the patch normal; a posed camera elsewhere
  // leaks its view's share (simulators::lab_camera_analyser at this
  // roughness, radians, of the skin's highlight lobe).
  bool polarisers = false;
  double polariser_roughness_rad = 0.3;
  // Subsurface spread in the skin scene's photographs (SkinSceneOptions::subsurface); off by default.
  simulators::SubsurfaceSpread subsurface;

  // Names the key: "cameras[1].sensor_width: ...".
  bool IsValid(std::string* error) const;
  // The serial of camera `index` (its entry's, else derived from camera_serial;
  // std::out_of_range beyond the list).
  std::string serial_of(std::size_t index) const;
  // The simulator options of camera `index` (std::out_of_range beyond) with
  // the sensitivity it renders with; its noise seed is seed + index; with
  // polarisers, its analyser.
  simulators::CameraSimulatorOptions camera_simulator_options(std::size_t index,
                                                              const spectral::CameraSensitivity& sensitivity) const;
};

// The running simulators, for the daemon's wiring and for tests' faults.
class VirtualLabSimulators {
 public:
  explicit VirtualLabSimulators(const VirtualLabOptions& options);
  ~VirtualLabSimulators();

  simulators::LedLab& leds();                   // truth + faults (set_unresponsive, dead channel...)
  simulators::CameraSimulator& camera();        // the first camera: faults (set_packet_loss_ratio, power_off/power_on)
  // The camera of options.cameras[index] (std::out_of_range beyond).
  simulators::CameraSimulator& camera(std::size_t index);
  std::size_t camera_count() const;
  simulators::CalibrationLab& calibration_lab();
  int modbus_port() const { return modbus_port_; }
  // Shows the white target (kWhite) or the skin patch (kSubject); kDark leaves the scene.
  void place_in_sphere(session::StepRole role);
  bool showing_white_target() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int modbus_port_ = 0;
};

struct VirtualLab {
  std::vector<DeviceConfig> devices;
  DeviceSet device_set;
  std::map<std::string, drivers::DriveLevels> mixes;  // placeholders until a calibration solved them
  std::string description;
  std::shared_ptr<VirtualLabSimulators> simulators;
};

// Throws std::invalid_argument for invalid options, std::runtime_error when a
// simulator cannot start (GigE port taken); a driver that cannot connect
// leaves its device with an open_error, as with configured devices. The
// device set describes the lab's own films (DeviceSet::own_films:
// virtual_lab_surface_factors).
VirtualLab start_virtual_lab(const VirtualLabOptions& options = {});

// The polarised virtual lab's films as a datasheet would give them (its
// light and analyser films, simulators::PolariserFilm's defaults, crossed
// exactly: the design view), for estimation.films_extinction_ratio
// "virtual_lab" (kVirtualLabFilms).
session::SurfaceFactors virtual_lab_surface_factors();

// The configuration's side of the lab (virtual_lab_options.cpp, which the
// configuration reader links alone): virtual_lab.cameras read by the reader
// chromo-sim shares (simulators::read_lab_cameras) into plain options;
// throws std::invalid_argument "[i].key: what is wrong".
std::vector<VirtualCameraConfig> read_virtual_cameras(const nlohmann::json& list);
// The lab's options for a configuration's virtual_lab section (cameras,
// patch width, polarisers; every other option at its default).
VirtualLabOptions virtual_lab_options(const VirtualLabConfig& config);

}  // namespace chromo::daemon
