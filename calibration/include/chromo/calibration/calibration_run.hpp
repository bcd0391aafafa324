#pragma once
// CalibrationRun: measures an LED library through the devices (issue
// "Calibration", item 1). In order:
//
//  1. Spectrometer response. All LEDs off, the reference lamp on (a
//     tungsten-halogen lamp taken as a Planckian radiator at
//     options.lamp_temperature_K); SpectrometerReader::measure auto-ranges the
//     integration time, takes the dark with the lamp off and subtracts it;
//     the lamp's counts per second on the project grid give the relative
//     spectral response correction (response_calibration.hpp), stored in the
//     library (instrument.response_calibration).
//  2. For each LED type in W57, W40, W27, R, G, B order: warm-up (the LED
//     alone at its top rung for warm_up_s), then the ladder of drive levels
//     from the top down, each after settle_s: the LED temperature is read
//     from the controller, the spectrum is measured (auto-ranged, dark with
//     the output disabled, dark-subtracted) and multiplied by the
//     correction. A channel the controller flags (open circuit, over-
//     temperature, short) or that gives no light ends the run, naming it.
//  3. Linearity of flux against drive (led_library_analysis.hpp) per LED;
//     an LED deviating more than max_linearity_deviation_percent is named in
//     the Summary (the library is still returned: the operator decides).
//
// Units of the spectra: counts per second × correction (1 at 560 nm), i.e.
// relative spectral irradiance; the same units the closed loop measures in
// (closed_loop.hpp), so a library and a loop on the same spectrometer agree.
//
// Thread rules: run() blocks the calling thread and uses the devices from it
// only; the callbacks are called from that thread. Lifetime: the controller,
// spectrometer and lamp switch must outlive the CalibrationRun. Device
// failures (DeviceError) are caught and reported in the Summary
// (kDeviceError, with the device's own message); the LEDs are switched off
// whatever the outcome.

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "chromo/calibration/led_library.hpp"
#include "chromo/calibration/led_library_analysis.hpp"
#include "chromo/drivers/led_controller.hpp"
#include "chromo/drivers/spectrometer.hpp"
#include "chromo/drivers/spectrometer_reader.hpp"
#include "chromo/files/progress.hpp"

namespace chromo::calibration {

struct CalibrationRunOptions {
  std::vector<double> drive_levels{0.25, 0.5, 0.75, 1.0};  // strictly increasing, in (0, 1]
  double warm_up_s = 2.0;  // wall-clock seconds each LED type is held at its top rung first
  double settle_s = 0.2;   // wall-clock seconds after every drive change
  double lamp_temperature_K = 3000;
  std::string lamp_description = "tungsten-halogen reference lamp";
  drivers::SpectrometerReaderOptions reader;
  double max_linearity_deviation_percent = 2.0;
  // Below this fraction of the saturation count at the longest integration
  // the reader allows, an LED counts as giving no light (dead).
  double min_peak_fraction = 0.02;
  std::array<double, spectral::kLedTypeCount> max_drive_level{1, 1, 1, 1, 1, 1};  // copied into the library
  std::optional<double> ambient_temperature_C;
  std::string notes;
  // The banks each LED type is measured through (docs/polarisation.md
  // "Calibration per state"): kCross or kParallel on a sphere with polariser
  // banks measure that bank's light (the LEDs through its film); kUnpolarised
  // drives the only bank, or both. The state is named in every LED record's
  // description. A controller without the bank refuses (kDeviceError).
  drivers::Polarisation polarisation = drivers::Polarisation::kUnpolarised;

  bool IsValid(std::string* error) const;
};

enum class CalibrationTermination {
  kCompleted,     // library complete (see linearity_ok)
  kCancelled,     // progress.cancelled() said so; no library
  kDeviceError,   // a device failed or a channel is dead/faulted; message names it
  kInvalidInput,  // options rejected
};
std::string_view calibration_termination_name(CalibrationTermination termination);

struct CalibrationSummary {
  CalibrationTermination termination = CalibrationTermination::kInvalidInput;
  std::string message;
  LedLibrary library;  // complete only when kCompleted
  std::array<LinearityReport, spectral::kLedTypeCount> linearity{};
  bool linearity_ok = false;
  int spectra_measured = 0;  // lamp + per LED its cold spectrum and ladder rungs
  double elapsed_s = 0;
  bool IsLibraryUsable() const { return termination == CalibrationTermination::kCompleted; }
};

class CalibrationRun {
 public:
  // Switches the reference lamp on (true) or off (false), returning once its
  // output is stable. The lamp must be off when the run starts.
  using LampSwitch = std::function<void(bool on)>;

  // std::invalid_argument if !options.IsValid().
  CalibrationRun(drivers::LedController& leds, drivers::Spectrometer& spectrometer, LampSwitch lamp,
                 CalibrationRunOptions options);

  // Progress (files/progress.hpp): reported before each measurement step
  // (the fraction of steps done and the step's text) and 1 ("done") at the
  // end; cancelled() is polled before each step and ends the run with
  // kCancelled, the LEDs off and no library.
  CalibrationSummary run(const files::Progress& progress = {});

 private:
  drivers::LedController& leds_;
  drivers::Spectrometer& spectrometer_;
  LampSwitch lamp_;
  CalibrationRunOptions options_;
};

// The light switch the spectrometer reader uses for the dark: switches the
// controller's output and then reads its status. Some controllers (the
// simulator's Modbus front-end among them) acknowledge a coil write before
// acting on it; the next request is served only after the previous one was
// acted on, so the status read is the barrier that makes "returned" mean
// "switched".
void switch_led_output(drivers::LedController& leds, bool on);

// "2026-11-22T16:00:00Z" for now (UTC).
std::string utc_timestamp_now();

}  // namespace chromo::calibration
