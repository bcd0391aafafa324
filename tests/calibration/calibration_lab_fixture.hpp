#pragma once
// The in-process virtual lab with the real drivers connected (Modbus TCP on
// loopback, USB2000+ behind the USB seam), shared by the measurement-run and
// closed-loop tests. The library is measured once per test program.

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "chromo/calibration/calibration_run.hpp"
#include "chromo/drivers/led_controller_factory.hpp"
#include "chromo/drivers/spectrometer_factory.hpp"
#include "chromo/simulators/calibration_lab.hpp"

namespace chromo::calibration::testing {

// Lab time runs 1500x the wall clock (the LEDs' thermal time constant is 60 s
// of lab time), so warm-ups and settling cost milliseconds of test time.
inline simulators::CalibrationLabOptions fast_lab_options() {
  simulators::CalibrationLabOptions options;
  options.leds.time_scale = 1500;
  return options;
}

struct ConnectedLab {
  simulators::CalibrationLab lab{fast_lab_options()};
  std::unique_ptr<drivers::LedController> leds;
  std::unique_ptr<drivers::Spectrometer> spectrometer;

  ConnectedLab() {
    leds = drivers::make_modbus_tcp_led_controller("127.0.0.1", lab.start_modbus_tcp());
    spectrometer = drivers::make_usb_spectrometer(lab.make_spectrometer_transport());
  }
};

// Fast run options: 0.2 s warm-up (300 s of lab time, 5 thermal time
// constants), 0.02 s settling (30 s of lab time), four rungs.
inline CalibrationRunOptions fast_run_options() {
  CalibrationRunOptions options;
  options.warm_up_s = 0.2;
  options.settle_s = 0.02;
  return options;
}

// The lab's true spectrum of one LED type alone at full drive, warmed up
// (truth, read from the LedLab, never through the drivers).
inline spectral::Spectrum true_full_drive_spectrum(simulators::LedLab& lab, LedType type) {
  drivers::LedState state;
  state.drive.fill(0);
  state.drive[spectral::led_type_index(type)] = 1.0;
  lab.apply(state);
  lab.set_output_enabled(true);
  lab.settle_thermal();
  spectral::Spectrum s = lab.irradiance_now();
  lab.set_output_enabled(false);
  return s;
}

// A library measured once per test program on one ConnectedLab (tests that
// inject faults into that lab must clear them), and the lab's truth.
struct MeasuredOnce {
  ConnectedLab connected;
  CalibrationSummary summary;
  std::vector<std::pair<double, std::string>> progress;
  std::array<spectral::Spectrum, spectral::kLedTypeCount> truth;
  MeasuredOnce() {
    CalibrationRun run(*connected.leds, *connected.spectrometer, connected.lab.lamp_switch(), fast_run_options());
    summary = run.run({[this](double f, const std::string& s) { progress.emplace_back(f, s); }, {}});
    for (int i = 0; i < spectral::kLedTypeCount; ++i)
      truth[i] = true_full_drive_spectrum(connected.lab.lab(), static_cast<LedType>(i));
  }
};

inline MeasuredOnce& measured() {
  static MeasuredOnce once;
  return once;
}

}  // namespace chromo::calibration::testing
