#pragma once
// DeviceSet: the daemon's named devices, opened from the configuration
// through backend factories, so that real backends, the simulators and test
// devices plug in the same way.
//
// BackendRegistry maps a backend name ("modbus-tcp", "aravis", ...) to a
// factory. The real drivers register theirs in backends.cpp; the virtual lab
// (virtual_lab.hpp) is one more: its simulators started in process, the
// real drivers' factories pointed at them, plus its in-process spectrometer
// seam (virtual_lab.cpp); open_devices (devices.hpp) picks it when no
// devices are configured. An unknown backend
// is a configuration error naming it; so is an unknown or invalid setting (a
// factory throws std::invalid_argument for it, which open() passes on with
// the device named, instead of recording an open_error).
//
// Thread rules: a DeviceSet is built once and its members never change. Each
// device is used under its own mutex (lock()); the drivers' one-thread-at-a-
// time rule is kept that way. A device that could not be opened stays in the
// set with `open_error` set and is reported UNREACHABLE.

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "chromo/daemon/config.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromo/session/surface_factors.hpp"
#include "chromo/drivers/camera.hpp"
#include "chromo/drivers/led_controller.hpp"
#include "chromo/drivers/spectrometer.hpp"

namespace chromo::daemon {

template <typename Interface>
struct NamedDevice {
  DeviceConfig config;
  std::unique_ptr<Interface> device;  // null when open_error is set
  std::string open_error;
  std::mutex mutex;  // hold while calling the device
};

struct DeviceSet {
  // Keeps in-process simulators (the virtual lab) alive as long as the
  // devices: declared first, so it is destroyed last, after the drivers that
  // talk to the simulators have closed their connections.
  std::vector<std::shared_ptr<void>> keep_alive;
  std::vector<std::unique_ptr<NamedDevice<drivers::LedController>>> led_controllers;
  std::vector<std::unique_ptr<NamedDevice<drivers::Camera>>> cameras;
  std::vector<std::unique_ptr<NamedDevice<drivers::Spectrometer>>> spectrometers;
  // The virtual lab's stand-in for the operator placing the white target or
  // the subject in the sphere: called by the sequencer before each step with
  // its role (the camera simulator's scene is switched). Empty with real
  // devices (the plan's prompts ask the operator).
  std::function<void(session::StepRole role)> place_in_sphere;
  // Switches the spectrometer's reference lamp (calibration runs need it:
  // calibration_run.hpp), returning once its output is stable. The virtual
  // lab's lamp; empty with real devices unless one is wired (then a
  // calibration run is refused, naming the missing lamp).
  std::function<void(bool on)> reference_lamp;
  // The polariser films as the devices describe them (the virtual lab's own
  // model), for estimation.films_extinction_ratio "virtual_lab"; none with
  // real devices.
  std::optional<session::SurfaceFactors> own_films;
  // Lab seconds per wall-clock second of the LED simulator (1 for real
  // devices); calibration runs shorten their waits by it.
  double lab_time_scale = 1;

  // By name; empty name = the only one of its kind. nullptr when not found
  // (or ambiguous); `error` says which.
  NamedDevice<drivers::LedController>* led_controller(const std::string& name, std::string* error);
  NamedDevice<drivers::Spectrometer>* spectrometer(const std::string& name, std::string* error);
};

class BackendRegistry {
 public:
  using LedFactory = std::function<std::unique_ptr<drivers::LedController>(const DeviceConfig&)>;
  using CameraFactory = std::function<std::unique_ptr<drivers::Camera>(const DeviceConfig&)>;
  using SpectrometerFactory = std::function<std::unique_ptr<drivers::Spectrometer>(const DeviceConfig&)>;

  void add_led_controller(const std::string& backend, LedFactory factory);
  void add_camera(const std::string& backend, CameraFactory factory);
  void add_spectrometer(const std::string& backend, SpectrometerFactory factory);

  // Every configured device; a factory's exception becomes that device's
  // open_error. Throws std::invalid_argument for a backend nobody registered.
  DeviceSet open(const std::vector<DeviceConfig>& devices) const;
  std::vector<std::string> backends(DeviceKind kind) const;

 private:
  std::map<std::string, LedFactory> led_;
  std::map<std::string, CameraFactory> camera_;
  std::map<std::string, SpectrometerFactory> spectrometer_;
};

// The registry with every backend built into this daemon (backends.cpp):
// modbus-tcp, modbus-rtu, hid (LED controllers), usb (spectrometer), aravis
// (camera); settings in docs/config.md.
BackendRegistry builtin_backends();

// What a camera's configuration fixes for every capture: settings
// pixel_format, roi {x, y, width, height}, gain_db, and the trigger mode:
// kHardware when trigger_input ("Line0"…"Line9") says the camera's input is
// wired to the LED controller's trigger output, else kSoftware (the sequencer
// adds the exposure per step). std::invalid_argument naming
// "settings.<key>" when one is invalid.
drivers::CameraSettings camera_capture_settings(const DeviceConfig& config);

// A `hid` LED controller's address: vendor:product[:serial], hex ids.
struct HidAddress {
  std::uint16_t vendor_id = 0, product_id = 0;
  std::string serial;  // empty = the first device with these ids
};
// std::invalid_argument "address: ..." naming the part that is wrong.
HidAddress parse_hid_address(const std::string& address);

}  // namespace chromo::daemon
