// The measurement run per polarisation state (docs/polarisation.md
// "Calibration per state"): on a sphere with polariser banks the run drives
// each LED type through the banks of CalibrationRunOptions::polarisation, and
// the library it measures is the LEDs' light through the film, as
// library_through_polariser predicts it from a library measured without
// films; the unpolarised state on that sphere drives both banks (twice).

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "calibration_lab_fixture.hpp"
#include "chromo/calibration/polarised_libraries.hpp"

namespace chromo::calibration {
namespace {

using testing::fast_run_options;

struct PolarisedConnectedLab {
  simulators::CalibrationLab lab;
  std::unique_ptr<drivers::LedController> leds;
  std::unique_ptr<drivers::Spectrometer> spectrometer;

  explicit PolarisedConnectedLab(bool banks) : lab([&] {
    simulators::CalibrationLabOptions options = testing::fast_lab_options();
    if (banks) options.leds.polariser_banks.fill(true);
    return options;
  }()) {
    leds = drivers::make_modbus_tcp_led_controller("127.0.0.1", lab.start_modbus_tcp());
    spectrometer = drivers::make_usb_spectrometer(lab.make_spectrometer_transport());
  }
  CalibrationSummary measure(drivers::Polarisation state) {
    CalibrationRunOptions options = fast_run_options();
    options.polarisation = state;
    CalibrationRun run(*leds, *spectrometer, lab.lamp_switch(), options);
    return run.run();
  }
};

TEST(PolarisedCalibrationRun, EachStateMeasuresTheLedsThroughItsBanksAsPredicted) {
  PolarisedConnectedLab plain(false), banked(true);
  const CalibrationSummary without_films = plain.measure(drivers::Polarisation::kUnpolarised);
  const CalibrationSummary cross = banked.measure(drivers::Polarisation::kCross);
  const CalibrationSummary parallel = banked.measure(drivers::Polarisation::kParallel);
  const CalibrationSummary both_banks = banked.measure(drivers::Polarisation::kUnpolarised);
  for (const CalibrationSummary* s : {&without_films, &cross, &parallel, &both_banks})
    ASSERT_EQ(s->termination, CalibrationTermination::kCompleted) << s->message;
  EXPECT_NE(cross.library.leds[0].description.find("cross"), std::string::npos) << cross.library.leds[0].description;

  const LedLibrary predicted =
      library_through_polariser(without_films.library, banked.lab.lab().options().polariser_film.transmission());
  for (int i = 0; i < spectral::kLedTypeCount; ++i) {
    const spectral::Spectrum& expected = predicted.leds[i].ladder.back().spectrum;
    const spectral::Spectrum& x = cross.library.leds[i].ladder.back().spectrum;
    const spectral::Spectrum& p = parallel.library.leds[i].ladder.back().spectrum;
    const spectral::Spectrum& u = both_banks.library.leds[i].ladder.back().spectrum;
    const double rms = std::sqrt((x.values() - expected.values()).square().mean()) / expected.max();
    const double flux_ratio = x.values().sum() / expected.values().sum();
    const double through_film = x.values().sum() / without_films.library.leds[i].ladder.back().spectrum.values().sum();
    std::printf("LED %d: cross through film %.4f of the bare LED; against the prediction rms/peak %.4f, flux %.4f; "
                "parallel/cross %.4f, both banks/cross %.4f\n",
                i, through_film, rms, flux_ratio, p.values().sum() / x.values().sum(), u.values().sum() / x.values().sum());
    // The spectrometer's noise and stray light (CalibrationRun's own figures against truth: < 0.5 % rms, < 1 % flux).
    EXPECT_LT(rms, 0.01) << "LED " << i;
    EXPECT_NEAR(flux_ratio, 1.0, 0.02) << "LED " << i;
    // Films transmit 0.30-0.42 of unpolarised light.
    EXPECT_GT(through_film, 0.29) << "LED " << i;
    EXPECT_LT(through_film, 0.43) << "LED " << i;
    EXPECT_NEAR(p.values().sum() / x.values().sum(), 1.0, 0.02) << "LED " << i;
    EXPECT_NEAR(u.values().sum() / x.values().sum(), 2.0, 0.04) << "LED " << i;
  }
}

TEST(PolarisedCalibrationRun, ABankStateOnASphereWithoutBanksEndsTheRunNamingIt) {
  PolarisedConnectedLab plain(false);
  const CalibrationSummary refused = plain.measure(drivers::Polarisation::kCross);
  EXPECT_EQ(refused.termination, CalibrationTermination::kDeviceError);
  EXPECT_NE(refused.message.find("W57"), std::string::npos) << refused.message;
  EXPECT_NE(refused.message.find("cross"), std::string::npos) << refused.message;
  EXPECT_EQ(plain.lab.lab().status().applied.drive, drivers::DriveLevels{});  // the LEDs are off
}

}  // namespace
}  // namespace chromo::calibration
