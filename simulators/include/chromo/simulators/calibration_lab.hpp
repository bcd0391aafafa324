#pragma once
// CalibrationLab: the virtual lab as a calibration run sees it, in-process:
// the LED controller simulator (its LedLab is the truth), the reference lamp
// in a port of the sphere, and a spectrometer looking into the sphere (it
// sees LEDs + lamp). Connect the real drivers to it:
//
//   CalibrationLab lab(options);
//   auto leds = drivers::make_modbus_tcp_led_controller("127.0.0.1", lab.start_modbus_tcp());
//   auto spectrometer = drivers::make_usb_spectrometer(lab.make_spectrometer_transport());
//   calibration::CalibrationRun run(*leds, *spectrometer, lab.lamp_switch(), run_options);
//
// Lifetime: transports made here must not outlive the lab. Thread rules: as
// LedControllerSimulator (start from one thread; lab(), lamp() from any).

#include <functional>
#include <memory>

#include "chromo/simulators/leds/led_controller_simulator.hpp"
#include "chromo/simulators/reference_lamp.hpp"
#include "chromo/simulators/spectrometer/usb_spectrometer_device.hpp"

namespace chromo::simulators {

struct CalibrationLabOptions {
  LedLabOptions leds = fast_lab_leds();
  double lamp_temperature_K = 3000;
  DetectorModel detector;

  // LED lab options for calibration: lab time 300× the wall clock, so a
  // 1 s warm-up is 5 thermal time constants.
  static LedLabOptions fast_lab_leds() {
    LedLabOptions options;
    options.time_scale = 300;
    return options;
  }
};

class CalibrationLab {
 public:
  explicit CalibrationLab(CalibrationLabOptions options = {})
      : options_(options), simulator_(options.leds), lamp_(options.lamp_temperature_K),
        seen_({&simulator_.lab(), &lamp_}) {}

  int start_modbus_tcp() { return simulator_.start_modbus_tcp(); }
  std::unique_ptr<UsbSpectrometerDevice> make_spectrometer_transport() const {
    return std::make_unique<UsbSpectrometerDevice>(seen_, options_.detector);
  }
  std::function<void(bool)> lamp_switch() {
    return [this](bool on) { lamp_.set_on(on); };
  }

  LedLab& lab() { return simulator_.lab(); }
  LedControllerSimulator& simulator() { return simulator_; }
  ReferenceLamp& lamp() { return lamp_; }
  const CalibrationLabOptions& options() const { return options_; }

 private:
  CalibrationLabOptions options_;
  LedControllerSimulator simulator_;
  ReferenceLamp lamp_;
  SummedIllumination seen_;
};

}  // namespace chromo::simulators
