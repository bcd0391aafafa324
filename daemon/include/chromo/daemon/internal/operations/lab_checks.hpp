#pragma once
// The lab's checks: what is wrong with a lab PC for its configuration, one
// finding and one fix each. `chromo doctor` (DeviceService.CheckLab) prints
// them; a preflight before a session runs the same ones.
//
// The checks are pure functions of typed facts (LabFacts): the daemon gathers
// them from its devices, its configuration and the host (host_facts.hpp),
// and tests inject a fault by changing one fact. Each check's id names what it
// looked at ("device.cam0", "receive_buffer.cam0", "mtu.cam0", "disk",
// "clock", "calibration", "leds_settled.sphere", "permissions.spec0",
// "permissions.sessions_dir").
// docs/doctor.md lists them with their thresholds.

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace chromo::daemon {

enum class CheckStatus { ok, warning, failed, skipped };
// "ok", "warning", "failed", "skipped".
std::string check_status_name(CheckStatus status);

struct CheckResult {
  std::string id;       // what was checked: "device.cam0", "disk", ...
  CheckStatus status = CheckStatus::ok;
  std::string finding;  // what was found, with the numbers
  std::string fix;      // what to do about it; empty when status is ok or skipped
};

// A configured device as the daemon found it.
struct DeviceFacts {
  std::string name;
  std::string kind;     // "led_controller", "camera", "spectrometer"
  std::string backend;  // "aravis", "modbus-tcp", "hid", "usb", ...
  std::string address;  // as configured
  bool reachable = false;
  std::string detail;   // the open error or the probe's answer when not reachable
  // The device's node for hid/usb backends (found by vendor:product in sysfs,
  // host_facts.hpp); empty when not found or not such a backend.
  std::filesystem::path device_node;
  // Whether the user chromod runs as can read and write device_node.
  bool device_node_usable = false;
};

// A configured camera's stream as the configuration and the device make it.
struct CameraStreamFacts {
  std::string name;
  std::size_t frame_bytes = 0;            // ROI (or sensor) × pixel format; 0 = unknown (camera not reachable)
  std::size_t socket_buffer_bytes = 0;    // settings.socket_buffer_bytes (or the driver's default)
  int packet_size_bytes = 0;              // settings.packet_size_bytes; 0 = the camera's own
  std::string ip_address;                 // settings.ip_address; empty = found by discovery
  std::string interface_name;             // the host interface that reaches ip_address; empty = none found
  int interface_mtu_bytes = 0;            // that interface's MTU; 0 = unknown
};

// Facts of the host (read by read_host_facts, host_facts.hpp).
struct HostFacts {
  std::optional<std::uint64_t> rmem_max_bytes;       // net.core.rmem_max
  std::optional<std::uint64_t> free_disk_bytes;      // at the sessions folder (nearest existing parent)
  std::optional<bool> clock_synchronised;            // adjtimex(): the kernel's clock is disciplined (NTP)
  std::optional<std::int64_t> clock_max_error_us;    // adjtimex()'s maxerror
  bool sessions_dir_writable = false;                // by the user chromod runs as
  std::filesystem::path sessions_dir;
};

struct CalibrationFacts {
  std::filesystem::path library_path;  // empty = no LED library (configured mixes only)
  std::optional<std::chrono::system_clock::time_point> measured_at;  // the library file's modification time
};

// An LED controller's temperatures (LedStatus::temperature_C) read twice,
// interval_s apart (Daemon::lab_facts): how fast each LED still warms or
// cools.
struct LedTemperatureFacts {
  std::string controller;              // the configuration's name
  std::vector<std::string> led_names;  // "W57", ..., one per temperature
  std::vector<double> first_C, last_C; // each LED's temperature at the first and the last reading
  double interval_s = 0;               // between the readings; 0 = not read (see error)
  std::string error;                   // why the controller could not be read
};

struct LabFacts {
  std::vector<DeviceFacts> devices;
  std::vector<CameraStreamFacts> cameras;
  HostFacts host;
  CalibrationFacts calibration;
  std::vector<LedTemperatureFacts> led_temperatures;  // one per LED controller
  std::uint64_t session_bytes = 0;        // what one standard session stores (frames of every camera)
  std::uint64_t storage_limit_bytes = 0;  // the configuration's storage_limit_bytes (0 = the disk)
  std::chrono::system_clock::time_point now = std::chrono::system_clock::now();
};

// The thresholds a lab may tune (docs/doctor.md).
struct CheckLimits {
  double frames_in_flight = 4;            // the receive buffer holds this many frames of each camera
  int jumbo_mtu_bytes = 9000;             // below it on a camera's interface: a warning (packets of ~1.4 kB)
  double sessions_of_free_disk = 10;      // fewer sessions' room left than this: a warning
  std::chrono::hours calibration_max_age{24 * 30};  // older LED library: a warning
  std::int64_t clock_max_error_us = 100000;         // a synchronised clock's bound beyond this: a warning
  // An LED warming or cooling faster than this has not settled: the
  // session's white and subject would be lit by junctions at different
  // temperatures (docs/calibration.md §6): failed, with the wait.
  double led_settled_C_per_min = 0.5;
  // The LEDs' thermal time constant (wall-clock seconds), for the wait the
  // fix names: a rate r falls below the limit after τ·ln(r / limit).
  double led_thermal_time_constant_s = 60;
};

// Every check on these facts, in a fixed order: devices, permissions,
// receive buffer and MTU per camera, disk, clock, calibration, LEDs settled. Never throws
// for a fact it lacks: that check is `skipped` with the reason.
std::vector<CheckResult> run_lab_checks(const LabFacts& facts, const CheckLimits& limits = {});

// The worst status of the results (failed > warning > ok; skipped counts as ok).
CheckStatus worst_status(const std::vector<CheckResult>& results);

}  // namespace chromo::daemon
