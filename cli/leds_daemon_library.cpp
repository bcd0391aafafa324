// The LED library chromod uses (CalibrationService.GetLedLibrary), for
// `chromo leds plot` and `--library daemon`: each LED's spectrum per unit
// drive as one rung at drive 1, its drive limit, the file and when measured.
#include <stdexcept>

#include "chromo/calibration/led_library.hpp"
#include "chromosphere/v1/calibration.grpc.pb.h"
#include "daemon_client.hpp"
#include "leds_common.hpp"

namespace chromo::cli {

namespace pb = chromosphere::v1;

std::optional<DaemonLedLibrary> daemon_led_library(const DaemonAddress& address, std::string* why_not) {
  const DaemonConnection daemon(address);
  pb::GetLedLibraryResponse response;
  const grpc::Status status =
      pb::CalibrationService::NewStub(daemon.channel())->GetLedLibrary(daemon.context().get(), {}, &response);
  if (status.error_code() == grpc::StatusCode::FAILED_PRECONDITION) {
    // A daemon without a library estimates with the built-in nominal one.
    return DaemonLedLibrary{calibration::nominal_led_library(),
                            "chromod's: the built-in nominal library (chromod at " + address.target + " has no LED library)"};
  }
  if (!status.ok()) {
    *why_not = "chromod at " + address.target + " did not answer: " + status.error_message();
    return std::nullopt;
  }
  calibration::LedLibrary library;
  library.source = response.source();
  library.created_utc = response.created_utc();
  if (response.leds_size() != spectral::kLedTypeCount)
    throw std::runtime_error("chromod sent " + std::to_string(response.leds_size()) + " LED spectra, not 6");
  for (int i = 0; i < spectral::kLedTypeCount; ++i) {
    const pb::LedSpectrum& led = response.leds(i);
    calibration::LedRecord& record = library.leds[i];
    record.type = spectral::kAllLedTypes[i];
    record.description = led.description();
    record.max_drive_level = led.max_drive_level();
    calibration::LedSpectrumSample rung;
    rung.drive_level = 1.0;
    rung.spectrum = spectral::Spectrum::from_values({led.spectrum_per_unit_drive().begin(), led.spectrum_per_unit_drive().end()});
    record.ladder = {rung};
  }
  if (const std::string problem = calibration::validate(library); !problem.empty())
    throw std::runtime_error("chromod's LED library: " + problem);
  const std::string file = response.library().empty() ? "built in" : response.library();
  return DaemonLedLibrary{library, "chromod's: " + file + " (" + response.source() +
                                       (response.created_utc().empty() ? "" : " " + response.created_utc()) + ")"};
}

}  // namespace chromo::cli
