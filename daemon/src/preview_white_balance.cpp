// Daemon::preview_white_balance: the live view's white balance from the
// daemon's own LED library and the camera's sensitivity (white_balance.hpp).
#include <fmt/format.h>

#include "chromo/daemon/daemon.hpp"

namespace chromo::daemon {

WhiteBalance Daemon::preview_white_balance(const std::string& camera) {
  const session::CaptureSources sources = light_sources();
  if (sources.led_library_source == session::kNominalLedLibrary || sources.led_library.source != "measured")
    return {{1, 1, 1}, "none: raw (no LED calibration: calibrate on the Devices page)"};
  if (devices_.led_controllers.empty()) return {{1, 1, 1}, "none: raw (no LED controller)"};
  auto& led = *devices_.led_controllers.front();
  drivers::LedStatus status;
  {
    std::lock_guard lock(led.mutex);
    if (!led.device) return {{1, 1, 1}, "none: raw (" + led.config.name + ": " + led.open_error + ")"};
    status = led.device->read_status();
  }
  std::string lit;
  for (int i = 0; i < spectral::kLedTypeCount; ++i)
    if (status.applied.drive[i] > 0)
      lit += fmt::format("{}{} {:.2f}", lit.empty() ? "" : ", ", spectral::led_type_name(spectral::kAllLedTypes[i]),
                         status.applied.drive[i]);
  if (!status.output_enabled || lit.empty()) return {{1, 1, 1}, "none: raw (the LEDs are off)"};
  const session::CameraSensitivitySource sensitivity = sources.sensitivity_of(camera);
  try {
    const auto gains = white_balance_gains(sources.led_library, sensitivity.sensitivity, status.applied.drive);
    return {gains, fmt::format("LED library {} (measured {}), camera {}, LEDs {}",
                               std::filesystem::path(sources.led_library_source).filename().string(),
                               sources.led_library.created_utc, sensitivity.source, lit)};
  } catch (const std::invalid_argument& error) {
    return {{1, 1, 1}, std::string("none: raw (") + error.what() + ")"};
  }
}

}  // namespace chromo::daemon
