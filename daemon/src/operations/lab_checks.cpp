// The lab's checks on typed facts (lab_checks.hpp); docs/doctor.md.
#include "chromo/daemon/internal/operations/lab_checks.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace chromo::daemon {
namespace {

std::string mib(std::uint64_t bytes) { return fmt::format("{:.1f} MiB", static_cast<double>(bytes) / (1 << 20)); }
std::string gib(std::uint64_t bytes) { return fmt::format("{:.1f} GiB", static_cast<double>(bytes) / (1 << 30)); }

CheckResult ok(std::string id, std::string finding) { return {std::move(id), CheckStatus::ok, std::move(finding), ""}; }
CheckResult skipped(std::string id, std::string reason) {
  return {std::move(id), CheckStatus::skipped, std::move(reason), ""};
}

// What to do when a device of this backend does not answer.
std::string unreachable_fix(const DeviceFacts& device) {
  if (device.backend == "aravis")
    return "check the camera's power and cable and that its serial is " + device.address +
           " (arv-tool-0.8 lists the cameras this PC sees; with settings.ip_address, arv-tool-0.8 -a ADDRESS)";
  if (device.backend == "modbus-tcp")
    return "check the controller's power and network and that " + device.address + " is its address and port";
  if (device.backend == "modbus-rtu") return "check the controller's power and that " + device.address + " is its serial port";
  if (device.backend == "hid")
    return "plug the controller in and check that " + device.address + " is its vendor:product[:serial] (lsusb)";
  if (device.backend == "usb") return "plug the spectrometer in (lsusb should list it)";
  return "check the device's power and connection";
}

CheckResult device_check(const DeviceFacts& device) {
  const std::string id = "device." + device.name;
  if (device.reachable) return ok(id, fmt::format("{} {} ({}) answers", device.kind, device.address, device.backend));
  return {id, CheckStatus::failed,
          fmt::format("{} {} ({}) does not answer: {}", device.kind, device.address, device.backend, device.detail),
          unreachable_fix(device)};
}

// hid and usb devices are opened through a device node the service user must
// be able to read and write (the package's udev rules grant it).
std::optional<CheckResult> permission_check(const DeviceFacts& device) {
  if (device.backend != "hid" && device.backend != "usb") return std::nullopt;
  const std::string id = "permissions." + device.name;
  if (device.device_node.empty()) return skipped(id, "no device node found for " + device.address);
  if (device.device_node_usable) return ok(id, device.device_node.string() + " is readable and writable");
  return CheckResult{id, CheckStatus::failed,
                     device.device_node.string() + " is not readable and writable by chromod's user",
                     "install the udev rules (the package's 60-chromosphere.rules; after a change of the configuration's "
                     "devices: chromod --config FILE --write-host-files /etc), then udevadm control --reload && "
                     "udevadm trigger, and replug the device"};
}

CheckResult receive_buffer_check(const CameraStreamFacts& camera, const HostFacts& host, const CheckLimits& limits) {
  const std::string id = "receive_buffer." + camera.name;
  if (camera.frame_bytes == 0) return skipped(id, "frame size unknown (the camera does not answer)");
  if (!host.rmem_max_bytes) return skipped(id, "net.core.rmem_max unreadable");
  const auto needed = static_cast<std::uint64_t>(std::ceil(limits.frames_in_flight * static_cast<double>(camera.frame_bytes)));
  const std::uint64_t effective = std::min<std::uint64_t>(camera.socket_buffer_bytes, *host.rmem_max_bytes);
  const std::string finding =
      fmt::format("stream buffer {} (settings.socket_buffer_bytes {}, net.core.rmem_max {}) for {} frames of {}",
                  mib(effective), mib(camera.socket_buffer_bytes), mib(*host.rmem_max_bytes),
                  limits.frames_in_flight, mib(camera.frame_bytes));
  if (effective >= needed) return ok(id, finding);
  if (camera.socket_buffer_bytes < needed)
    return {id, CheckStatus::warning, finding + ": below the " + mib(needed) + " it needs, frames may be lost",
            fmt::format("raise the camera's settings.socket_buffer_bytes to at least {}", needed)};
  return {id, CheckStatus::warning, finding + ": below the " + mib(needed) + " it needs, frames may be lost",
          fmt::format("raise net.core.rmem_max to at least {} (the package's /usr/lib/sysctl.d/60-chromosphere.conf; "
                      "now: sysctl -w net.core.rmem_max={})",
                      needed, needed)};
}

CheckResult mtu_check(const CameraStreamFacts& camera, const CheckLimits& limits) {
  const std::string id = "mtu." + camera.name;
  if (camera.ip_address.empty()) return skipped(id, "no settings.ip_address: the interface is not known before discovery");
  if (camera.interface_name.empty() || camera.interface_mtu_bytes <= 0)
    return {id, CheckStatus::failed, "no network interface of this PC reaches " + camera.ip_address,
            "give the camera's network interface an address in the camera's subnet (ip addr, or NetworkManager)"};
  const std::string where = fmt::format("{} reaches {} with MTU {}", camera.interface_name, camera.ip_address,
                                        camera.interface_mtu_bytes);
  if (camera.packet_size_bytes > camera.interface_mtu_bytes)
    return {id, CheckStatus::failed,
            fmt::format("{}, below settings.packet_size_bytes {}: every packet would be dropped", where,
                        camera.packet_size_bytes),
            fmt::format("raise the interface's MTU (ip link set {} mtu {}) or lower settings.packet_size_bytes",
                        camera.interface_name, limits.jumbo_mtu_bytes)};
  if (camera.interface_mtu_bytes < limits.jumbo_mtu_bytes)
    return {id, CheckStatus::warning, where + ": no jumbo packets (more packets per frame, more load per frame)",
            fmt::format("set the interface's MTU to {} (ip link set {} mtu {}; persistently in its network "
                        "configuration) and settings.packet_size_bytes to 8000",
                        limits.jumbo_mtu_bytes, camera.interface_name, limits.jumbo_mtu_bytes)};
  return ok(id, where);
}

CheckResult sessions_dir_check(const HostFacts& host) {
  const std::string id = "permissions.sessions_dir";
  if (host.sessions_dir_writable) return ok(id, host.sessions_dir.string() + " is writable");
  return {id, CheckStatus::failed, host.sessions_dir.string() + " is not writable by chromod's user",
          "give chromod's user the folder (the service's is /var/lib/chromosphere/sessions) or set sessions_dir"};
}

CheckResult disk_check(const LabFacts& facts, const CheckLimits& limits) {
  const std::string id = "disk";
  if (!facts.host.free_disk_bytes) return skipped(id, "free space at the sessions folder unknown");
  std::uint64_t room = *facts.host.free_disk_bytes;
  std::string limit;
  if (facts.storage_limit_bytes > 0 && facts.storage_limit_bytes < room) {
    room = facts.storage_limit_bytes;
    limit = " (storage_limit_bytes)";
  }
  const std::string finding = fmt::format("{} free{} at {}; a standard session stores {}", gib(room), limit,
                                          facts.host.sessions_dir.string(), mib(facts.session_bytes));
  if (room < facts.session_bytes)
    return {id, CheckStatus::failed, finding + ": not enough for one session",
            "free disk space (chromo session delete ID for sessions already copied elsewhere) or move sessions_dir"};
  if (static_cast<double>(room) < limits.sessions_of_free_disk * static_cast<double>(facts.session_bytes))
    return {id, CheckStatus::warning,
            fmt::format("{}: room for fewer than {} sessions", finding, limits.sessions_of_free_disk),
            "free disk space or move sessions_dir to a larger disk"};
  return ok(id, finding);
}

CheckResult clock_check(const HostFacts& host, const CheckLimits& limits) {
  const std::string id = "clock";
  if (!host.clock_synchronised) return skipped(id, "the kernel's clock state is unreadable");
  const std::string fix =
      "synchronise the clock (timedatectl set-ntp true with systemd-timesyncd, or chrony); frame times and "
      "calibration ages come from it";
  if (!*host.clock_synchronised)
    return {id, CheckStatus::warning, "the system clock is not synchronised (no NTP discipline)", fix};
  if (host.clock_max_error_us && *host.clock_max_error_us > limits.clock_max_error_us)
    return {id, CheckStatus::warning,
            fmt::format("the clock is synchronised but its error bound is {} ms", *host.clock_max_error_us / 1000), fix};
  return ok(id, "the system clock is synchronised");
}

CheckResult calibration_check(const LabFacts& facts, const CheckLimits& limits) {
  const std::string id = "calibration";
  if (facts.calibration.library_path.empty())
    return {id, CheckStatus::warning, "no LED library: sessions use the configuration's mixes, uncalibrated",
            "run a calibration (chromo calibrate) with the spectrometer in the sphere"};
  if (!facts.calibration.measured_at)
    return skipped(id, "the age of " + facts.calibration.library_path.string() + " is unknown");
  const auto age = std::chrono::duration_cast<std::chrono::hours>(facts.now - *facts.calibration.measured_at);
  const std::string finding =
      fmt::format("LED library {} is {:.1f} days old", facts.calibration.library_path.string(), age.count() / 24.0);
  if (age > limits.calibration_max_age)
    return {id, CheckStatus::warning, fmt::format("{} (older than {} days)", finding, limits.calibration_max_age.count() / 24),
            "run a calibration (chromo calibrate): the LEDs drift with age"};
  return ok(id, finding);
}

// Each LED's rate from the two readings; the fastest one decides.
CheckResult led_settled_check(const LedTemperatureFacts& leds, const CheckLimits& limits) {
  const std::string id = "leds_settled." + leds.controller;
  if (!leds.error.empty()) return skipped(id, "temperatures not read: " + leds.error);
  const std::size_t count = std::min({leds.led_names.size(), leds.first_C.size(), leds.last_C.size()});
  if (leds.interval_s <= 0 || count == 0) return skipped(id, "the controller reports no temperatures");
  std::size_t fastest = 0;
  std::vector<double> rate_C_per_min(count);
  std::string now;
  for (std::size_t i = 0; i < count; ++i) {
    rate_C_per_min[i] = (leds.last_C[i] - leds.first_C[i]) / leds.interval_s * 60;
    if (std::abs(rate_C_per_min[i]) > std::abs(rate_C_per_min[fastest])) fastest = i;
    now += fmt::format("{}{} {:.1f} °C", i ? ", " : "", leds.led_names[i], leds.last_C[i]);
  }
  const double rate = rate_C_per_min[fastest];
  if (std::abs(rate) <= limits.led_settled_C_per_min)
    return ok(id, fmt::format("settled: {} (at most {:.2f} °C/min over {:.1f} s)", now, std::abs(rate), leds.interval_s));
  const double wait_s = limits.led_thermal_time_constant_s * std::log(std::abs(rate) / limits.led_settled_C_per_min);
  // A warning, not a failure: the lab is sound, it needs a wait (a session
  // may still start; chromo doctor does not fail on it).
  return {id, CheckStatus::warning,
          fmt::format("{} {} at {:.1f} °C/min ({:.1f} °C now; settled is below {:.1f} °C/min): {}", leds.led_names[fastest],
                      rate > 0 ? "warming" : "cooling", std::abs(rate), leds.last_C[fastest], limits.led_settled_C_per_min, now),
          fmt::format("wait about {:.0f} s with the LEDs as they are (thermal time constant {:g} s), then check again",
                      std::ceil(wait_s), limits.led_thermal_time_constant_s)};
}

}  // namespace

std::string check_status_name(CheckStatus status) {
  switch (status) {
    case CheckStatus::ok: return "ok";
    case CheckStatus::warning: return "warning";
    case CheckStatus::failed: return "failed";
    case CheckStatus::skipped: return "skipped";
  }
  return "unknown";
}

std::vector<CheckResult> run_lab_checks(const LabFacts& facts, const CheckLimits& limits) {
  std::vector<CheckResult> results;
  for (const auto& device : facts.devices) results.push_back(device_check(device));
  for (const auto& device : facts.devices)
    if (auto check = permission_check(device)) results.push_back(std::move(*check));
  results.push_back(sessions_dir_check(facts.host));
  for (const auto& camera : facts.cameras) {
    results.push_back(receive_buffer_check(camera, facts.host, limits));
    results.push_back(mtu_check(camera, limits));
  }
  results.push_back(disk_check(facts, limits));
  results.push_back(clock_check(facts.host, limits));
  results.push_back(calibration_check(facts, limits));
  for (const auto& leds : facts.led_temperatures) results.push_back(led_settled_check(leds, limits));
  return results;
}

CheckStatus worst_status(const std::vector<CheckResult>& results) {
  CheckStatus worst = CheckStatus::ok;
  for (const auto& result : results) {
    if (result.status == CheckStatus::failed) return CheckStatus::failed;
    if (result.status == CheckStatus::warning) worst = CheckStatus::warning;
  }
  return worst;
}

}  // namespace chromo::daemon
