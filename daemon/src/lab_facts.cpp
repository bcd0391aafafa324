// Daemon::lab_facts and Daemon::check_lab: the lab's checks (lab_checks.hpp)
// on this daemon's devices, configuration, LED library and host.
#include <array>
#include <chrono>
#include <cstdint>
#include <optional>
#include <thread>

#include "chromo/daemon/daemon.hpp"
#include "chromo/daemon/internal/operations/host_facts.hpp"
#include "chromo/drivers/camera/aravis_camera.hpp"
#include "chromo/drivers/spectrometer/ocean_optics_protocol.hpp"

namespace chromo::daemon {
namespace {

void find_device_node(DeviceFacts& device) {
  if (device.backend == "usb") {
    device.device_node = find_usb_device_node(drivers::ocean_optics::kVendorId, drivers::ocean_optics::kProductIdUsb2000Plus);
  } else if (device.backend == "hid") {
    try {
      const HidAddress ids = parse_hid_address(device.address);
      device.device_node = find_hidraw_node(ids.vendor_id, ids.product_id);
    } catch (const std::invalid_argument&) {
      // the device check names the address (the controller did not open)
    }
  }
  if (!device.device_node.empty()) device.device_node_usable = device_node_usable(device.device_node);
}

// The configured stream of a camera: its frame from the configured ROI and
// pixel format (else the device's full sensor and first format).
CameraStreamFacts camera_stream_facts(NamedDevice<drivers::Camera>& camera) {
  CameraStreamFacts facts;
  const DeviceConfig& config = camera.config;
  facts.name = config.name;
  facts.socket_buffer_bytes = config.settings.value("socket_buffer_bytes", drivers::AravisCameraOptions{}.socket_buffer_bytes);
  facts.packet_size_bytes = config.settings.value("packet_size_bytes", 0);
  facts.ip_address = config.settings.value("ip_address", std::string());
  if (!facts.ip_address.empty())
    if (auto route = interface_reaching(facts.ip_address)) {
      facts.interface_name = route->name;
      facts.interface_mtu_bytes = route->mtu_bytes;
    }
  if (!camera.device) return facts;
  try {
    const drivers::CameraSettings wanted = camera_capture_settings(config);
    std::lock_guard lock(camera.mutex);
    const drivers::CameraInfo info = camera.device->info();
    const int width = wanted.roi.width > 0 ? wanted.roi.width : info.sensor_width;
    const int height = wanted.roi.height > 0 ? wanted.roi.height : info.sensor_height;
    drivers::PixelFormat format = wanted.pixel_format;
    if (!config.settings.contains("pixel_format") && !info.pixel_formats.empty()) format = info.pixel_formats.front();
    facts.frame_bytes = drivers::pixel_format_info(format).frame_bytes(width, height);
  } catch (const std::exception&) {
    facts.frame_bytes = 0;  // the device check reports why
  }
  return facts;
}

// The LED readings of lab_facts: the first at its start, the last at least
// this long after (the device probes in between count towards it).
constexpr std::chrono::milliseconds kLedReadingInterval{500};
constexpr std::array<const char*, spectral::kLedTypeCount> kLedNames{"W57", "W40", "W27", "Red", "Green", "Blue"};

// Every controller's temperatures now (std::nullopt and the error for one that cannot be read).
struct LedReading {
  std::optional<drivers::LedStatus> status;
  std::string error;
  std::chrono::steady_clock::time_point at;
};
std::vector<LedReading> read_led_temperatures(DeviceSet& devices) {
  std::vector<LedReading> readings;
  for (auto& led : devices.led_controllers) {
    LedReading reading;
    try {
      std::lock_guard lock(led->mutex);
      if (!led->device) throw std::runtime_error(led->open_error);
      reading.status = led->device->read_status();
    } catch (const std::exception& error) {
      reading.error = error.what();
    }
    reading.at = std::chrono::steady_clock::now();
    readings.push_back(std::move(reading));
  }
  return readings;
}

}  // namespace

LabFacts Daemon::lab_facts() {
  LabFacts facts;
  const std::vector<LedReading> first = read_led_temperatures(devices_);
  for (const auto& report : probe_devices()) {
    DeviceFacts device{report.name, device_kind_name(report.kind), report.backend, report.address,
                       report.health == DeviceReport::Health::kOk, report.detail, {}, false};
    find_device_node(device);
    facts.devices.push_back(std::move(device));
  }
  std::uint64_t frame_bytes_of_all_cameras = 0;
  for (auto& camera : devices_.cameras) {
    facts.cameras.push_back(camera_stream_facts(*camera));
    frame_bytes_of_all_cameras += facts.cameras.back().frame_bytes;
  }
  facts.host = read_host_facts(config_.sessions_dir);
  facts.session_bytes = session::standard_plan(standard_plan_options()).frames_per_camera_total() * frame_bytes_of_all_cameras;
  facts.storage_limit_bytes = config_.storage_limit_bytes;
  facts.calibration.library_path = calibrations_->library_path();
  if (!facts.calibration.library_path.empty()) {
    std::error_code error;
    const auto written = std::filesystem::last_write_time(facts.calibration.library_path, error);
    if (!error) facts.calibration.measured_at = std::chrono::time_point_cast<std::chrono::system_clock::duration>(std::chrono::file_clock::to_sys(written));
  }
  if (!first.empty()) std::this_thread::sleep_until(first.front().at + kLedReadingInterval);
  const std::vector<LedReading> last = read_led_temperatures(devices_);
  for (std::size_t c = 0; c < first.size() && c < last.size(); ++c) {
    LedTemperatureFacts leds;
    leds.controller = devices_.led_controllers[c]->config.name;
    leds.error = !first[c].error.empty() ? first[c].error : last[c].error;
    if (leds.error.empty()) {
      leds.led_names.assign(kLedNames.begin(), kLedNames.end());
      leds.first_C.assign(first[c].status->temperature_C.begin(), first[c].status->temperature_C.end());
      leds.last_C.assign(last[c].status->temperature_C.begin(), last[c].status->temperature_C.end());
      leds.interval_s = std::chrono::duration<double>(last[c].at - first[c].at).count();
    }
    facts.led_temperatures.push_back(std::move(leds));
  }
  return facts;
}

// The virtual lab's LEDs run lab_time_scale times faster than the wall clock:
// their thermal time constant in wall-clock seconds is shorter by as much,
// and their wall-clock rates higher by as much.
std::vector<CheckResult> Daemon::check_lab(const CheckLimits& limits) {
  CheckLimits scaled = limits;
  scaled.led_thermal_time_constant_s /= devices_.lab_time_scale;
  scaled.led_settled_C_per_min *= devices_.lab_time_scale;  // its rates too: 0.5 °C/min of lab time
  return run_lab_checks(lab_facts(), scaled);
}

}  // namespace chromo::daemon
