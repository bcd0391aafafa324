// The virtual lab's true LEDs: reference spectra, flux, drive-mode physics,
// temperature drift, warm-up, zones and injected faults.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <thread>

#include "chromo/simulators/leds/led_lab.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/colorimetry.hpp"
#include "chromo/spectral/resample.hpp"

namespace chromo::simulators {
namespace {

using drivers::LedState;
using spectral::LedType;

LedState only(LedType type, double level) {
  LedState state;
  state.drive[led_type_index(type)] = level;
  return state;
}

double centroid_nm(const spectral::Spectrum& s) {
  double sum = 0, weighted = 0;
  for (int i = 0; i < spectral::kGridSize; ++i) {
    sum += s[i];
    weighted += s[i] * spectral::grid_wavelength_nm(i);
  }
  return weighted / sum;
}

LedLabOptions warm(drivers::DriveMode mode = drivers::DriveMode::kPwmDuty) {
  LedLabOptions options;
  options.drive_mode = mode;
  options.start_warm = true;
  return options;
}

// Lights one type at `level`, settles the junction, returns the truth.
spectral::Spectrum emit(LedLab& lab, LedType type, double level) {
  EXPECT_EQ(lab.apply(only(type, level)), LabResult::kOk);
  lab.set_output_enabled(true);
  lab.settle_thermal();
  return lab.irradiance_now();
}

TEST(LedLab, FullDriveWarmedUpIsTheMeasuredFileScaledByTheFlux) {
  LedLab lab(warm());
  for (LedType type : spectral::kAllLedTypes) {
    const TrueLedParameters& p = lab.options().leds[led_type_index(type)];
    FineSpectrum file = load_reference_spectrum(p);
    spectral::Spectrum expected = spectral::resample_to_grid(file.wavelength_nm, file.value, p.spectrum_file) * p.relative_flux;
    spectral::Spectrum truth = emit(lab, type, 1.0);
    EXPECT_LT((truth - expected).values().abs().maxCoeff(), 1e-9) << led_type_name(type);
    EXPECT_NEAR(lab.irradiance_at_nm(550) , p.relative_flux * file.at(550), 1e-9) << led_type_name(type);
  }
  EXPECT_NEAR(emit(lab, LedType::kW57, 1.0).max(), 1.0, 0.05);  // SphereIllumination's unit
}

TEST(LedLab, PwmDutyKeepsTheShapeAtAFixedTemperature) {
  LedLabOptions options = warm();
  for (auto& led : options.leds) led.junction_rise_full_K = 0;  // no self-heating: isolate the drive physics
  LedLab lab(options);
  spectral::Spectrum full = emit(lab, LedType::kGreen, 1.0);
  spectral::Spectrum quarter = emit(lab, LedType::kGreen, 0.25);
  EXPECT_LT((quarter - full * 0.25).values().abs().maxCoeff(), 1e-12);
}

TEST(LedLab, ConstantCurrentShiftsThePeakAndDroops) {
  LedLabOptions options = warm(drivers::DriveMode::kConstantCurrent);
  for (auto& led : options.leds) led.junction_rise_full_K = 0;
  LedLab lab(options);
  spectral::Spectrum full = emit(lab, LedType::kGreen, 1.0);
  spectral::Spectrum half = emit(lab, LedType::kGreen, 0.5);
  // InGaN green: −4 nm per unit of current → +2 nm at half current.
  EXPECT_NEAR(centroid_nm(half) - centroid_nm(full), 2.0, 0.3);
  // Droop 0.2: η(0.5) = 0.9/0.8, so half the current gives 0.5625 of the flux.
  EXPECT_NEAR(half.integral() / full.integral(), 0.5625, 0.005);
}

TEST(LedLab, ColdLedsAreBrighterAndBlueShiftedAndWarmUpWithTheTimeConstant) {
  LedLabOptions options;  // cold start at ambient
  options.thermal_time_constant_s = 60;
  options.time_scale = 60.0 / 0.05;  // the 60 s time constant lasts 50 ms of wall time
  LedLab lab(options);
  ASSERT_EQ(lab.apply(only(LedType::kRed, 1.0)), LabResult::kOk);
  auto before_on = std::chrono::steady_clock::now();
  lab.set_output_enabled(true);
  auto after_on = std::chrono::steady_clock::now();
  spectral::Spectrum cold = lab.irradiance_now();
  EXPECT_NEAR(lab.junction_temperature_C(LedType::kRed), 25.0, 1.0);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));  // about one time constant of lab time
  auto before_read = std::chrono::steady_clock::now();
  double t1 = lab.junction_temperature_C(LedType::kRed);
  auto after_read = std::chrono::steady_clock::now();
  // First order: T = 25 + 30·(1 − exp(−t/τ)), t in lab time, bracketed by the wall-clock readings.
  auto rise = [&](auto from, auto to) {
    double lab_s = std::chrono::duration<double>(to - from).count() * options.time_scale;
    return 30.0 * (1.0 - std::exp(-lab_s / options.thermal_time_constant_s));
  };
  EXPECT_GE(t1, 25.0 + rise(after_on, before_read) - 1e-9);
  EXPECT_LE(t1, 25.0 + rise(before_on, after_read) + 1e-9);
  EXPECT_GT(t1, 25.0 + 0.5 * 30);  // at least most of a time constant has passed
  lab.settle_thermal();
  spectral::Spectrum hot = lab.irradiance_now();
  EXPECT_NEAR(lab.junction_temperature_C(LedType::kRed), 55.0, 1e-6);
  // Red AlInGaP: 0.9 %/K and 0.13 nm/K over 30 K.
  EXPECT_NEAR(cold.integral() / hot.integral(), 1.27, 0.02);
  EXPECT_NEAR(centroid_nm(hot) - centroid_nm(cold), 0.13 * 30, 0.3);
}

TEST(LedLab, InjectedFluxLossAndPeakShiftAreInTheTruth) {
  LedLab lab(warm());
  spectral::Spectrum before = emit(lab, LedType::kBlue, 0.6);
  const double before_at_454 = lab.irradiance_at_nm(454.0);
  lab.inject_flux_loss(LedType::kBlue, 0.05);
  spectral::Spectrum dimmer = lab.irradiance_now();
  EXPECT_LT((dimmer - before * 0.95).values().abs().maxCoeff(), 1e-12);
  lab.inject_peak_shift(LedType::kBlue, 2.0);
  spectral::Spectrum after = lab.irradiance_now();
  EXPECT_NEAR(centroid_nm(after) - centroid_nm(before), 2.0, 0.15);
  // 5-nm bin means of a shifted narrow line keep the flux to within ~1 %.
  EXPECT_NEAR(after.integral() / before.integral(), 0.95, 0.01);
  EXPECT_NEAR(lab.irradiance_at_nm(456.0), 0.95 * before_at_454, 1e-12);
  // The controller cannot see a degraded LED: no fault is reported.
  EXPECT_EQ(lab.status().channel_faults[5], 0u);
}

TEST(LedLab, DeadChannelEmitsNothingAndIsAnOpenCircuitWhenDriven) {
  LedLab lab(warm());
  emit(lab, LedType::kW40, 0.5);
  lab.set_dead_channel(LedType::kW40, true);
  EXPECT_EQ(lab.irradiance_now().max(), 0.0);
  EXPECT_EQ(lab.status().channel_faults[1], drivers::kLedFaultOpenCircuit);
  lab.apply(only(LedType::kW27, 0.5));
  EXPECT_EQ(lab.status().channel_faults[1], 0u);  // not driven: nothing to detect
}

TEST(LedLab, ZonesAreEqualPartsOfTheSphere) {
  LedLabOptions options = warm();
  options.zone_count = 4;
  LedLab lab(options);
  spectral::Spectrum all = emit(lab, LedType::kW57, 0.8);
  ASSERT_EQ(lab.apply(only(LedType::kW57, 0.0)), LabResult::kOk);
  LedState one = only(LedType::kW57, 0.8);
  one.zone = 2;
  ASSERT_EQ(lab.apply(one), LabResult::kOk);
  EXPECT_NEAR(lab.irradiance_now().integral() / all.integral(), 0.25, 1e-4);  // PWM: flux ∝ mean duty
  one.zone = 4;
  EXPECT_EQ(lab.apply(one), LabResult::kOutOfRange);
}

TEST(LedLab, HardwareTriggerAdvancesAnArmedSequence) {
  LedLab lab(warm());
  std::vector<LedState> states{only(LedType::kRed, 0.1), only(LedType::kRed, 0.2), only(LedType::kRed, 0.3)};
  ASSERT_EQ(lab.arm(states, drivers::SequenceTrigger::kHardwareRisingEdge), LabResult::kOk);
  lab.trigger();
  EXPECT_EQ(lab.status().sequence_position, 1);
  EXPECT_NEAR(lab.status().applied.drive[3], 0.2, 1e-12);
  EXPECT_EQ(lab.advance(), LabResult::kBadState);
  EXPECT_EQ(lab.trigger_count(), 1);
}

// The default fluxes make a D65 metamer need drives well inside [0, 1]: a
// non-negative least-squares fit of the six warm spectra to D65, scaled to
// the luminance of W57 alone at 70 % drive.
TEST(LedLab, D65MixNeedsDrivesWellInsideTheRange) {
  LedLab lab(warm());
  std::array<spectral::Spectrum, 6> basis;
  for (LedType type : spectral::kAllLedTypes) basis[led_type_index(type)] = emit(lab, type, 1.0);
  spectral::Spectrum target = spectral::illuminant_d65();
  target *= 0.7 * spectral::xyz_of_light(basis[0]).Y / spectral::xyz_of_light(target).Y;
  std::array<double, 6> w{};
  for (int sweep = 0; sweep < 5000; ++sweep)  // coordinate descent: exact for NNLS at convergence
    for (int j = 0; j < 6; ++j) {
      spectral::Spectrum residual = target;
      for (int k = 0; k < 6; ++k) residual -= basis[k] * w[k];
      double step = (residual * basis[j]).values().sum() / (basis[j] * basis[j]).values().sum();
      w[j] = std::max(0.0, w[j] + step);
    }
  std::printf("D65 mix at W57-70%% luminance: W57 %.3f W40 %.3f W27 %.3f R %.3f G %.3f B %.3f\n", w[0], w[1], w[2],
              w[3], w[4], w[5]);
  for (double level : w) EXPECT_LT(level, 0.9);
  EXPECT_GT(w[0] + w[1] + w[2], 0.3);  // the whites carry the mix
  EXPECT_GT(w[5], 0.0);                // D65 needs blue beyond the whites
}

}  // namespace
}  // namespace chromo::simulators
