#include "chromo/calibration/calibration_run.hpp"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <thread>

#include <fmt/format.h>

#include "chromo/calibration/response_calibration.hpp"
#include "chromo/drivers/device_error.hpp"
#include "led_count.hpp"

namespace chromo::calibration {
namespace {

void sleep_s(double seconds) {
  if (seconds > 0) std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
}

// Dark-subtracted peak of a measurement as a fraction of full scale.
double signal_fraction(const drivers::SpectrometerMeasurement& m, double saturation_counts) {
  const double peak = *std::max_element(m.pixel_counts_per_s.begin(), m.pixel_counts_per_s.end());
  return peak * m.integration_time_us * 1e-6 / saturation_counts;
}

std::string channel_fault_text(std::uint32_t faults) {
  std::string text;
  auto add = [&](std::uint32_t bit, const char* name) {
    if (faults & bit) text += text.empty() ? name : std::string(", ") + name;
  };
  add(drivers::kLedFaultOverTemperature, "over-temperature");
  add(drivers::kLedFaultOpenCircuit, "open circuit (dead LED or cable)");
  add(drivers::kLedFaultShortCircuit, "short circuit");
  add(drivers::kLedFaultSupply, "supply");
  return text;
}

// The LED's spectrum as it is switched on at `level`, its junction still
// near the sphere's temperature. It warms while the light is integrated:
// the sensor is read as the measurement starts and again as the reader
// switches the light off for the dark, and the mean of the two recorded.
LedSpectrumSample measure_cold(drivers::SpectrometerReader& reader, drivers::LedController& leds,
                               const std::function<drivers::LedStatus()>& read_status, int led,
                               const spectral::Spectrum& correction, double level) {
  const double before_C = read_status().temperature_C[led];
  std::optional<double> light_off_C;
  const drivers::SpectrometerMeasurement m = reader.measure([&](bool on) {
    if (!on && !light_off_C) light_off_C = read_status().temperature_C[led];
    switch_led_output(leds, on);
  });
  LedSpectrumSample sample;
  sample.drive_level = level;
  sample.led_temperature_C = 0.5 * (before_C + light_off_C.value_or(before_C));
  sample.integration_time_us = static_cast<double>(m.integration_time_us);
  sample.spectrum = m.counts_per_s * correction;
  return sample;
}

}  // namespace

void switch_led_output(drivers::LedController& leds, bool on) {
  leds.set_output_enabled(on);
  (void)leds.read_status();
}

std::string utc_timestamp_now() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buffer[32];
  std::strftime(buffer, sizeof buffer, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buffer;
}

std::string_view calibration_termination_name(CalibrationTermination termination) {
  switch (termination) {
    case CalibrationTermination::kCompleted: return "completed";
    case CalibrationTermination::kCancelled: return "cancelled";
    case CalibrationTermination::kDeviceError: return "device error";
    case CalibrationTermination::kInvalidInput: return "invalid input";
  }
  return "?";
}

bool CalibrationRunOptions::IsValid(std::string* error) const {
  auto fail = [&](std::string message) {
    if (error) *error = std::move(message);
    return false;
  };
  if (drive_levels.empty()) return fail("drive_levels is empty");
  for (std::size_t i = 0; i < drive_levels.size(); ++i) {
    if (!(drive_levels[i] > 0 && drive_levels[i] <= 1)) return fail(fmt::format("drive_levels[{}] = {} is not in (0, 1]", i, drive_levels[i]));
    if (i > 0 && !(drive_levels[i] > drive_levels[i - 1])) return fail("drive_levels must be strictly increasing");
  }
  if (!(warm_up_s >= 0) || !(settle_s >= 0)) return fail("warm_up_s and settle_s must be ≥ 0");
  if (!(lamp_temperature_K >= 1000 && lamp_temperature_K <= 4000))
    return fail(fmt::format("lamp_temperature_K = {} is not a tungsten-halogen colour temperature (1000-4000 K)", lamp_temperature_K));
  if (!(max_linearity_deviation_percent > 0)) return fail("max_linearity_deviation_percent must be > 0");
  if (!(min_peak_fraction > 0 && min_peak_fraction < 1)) return fail("min_peak_fraction must be in (0, 1)");
  for (int i = 0; i < kLeds; ++i)
    if (!(max_drive_level[i] > 0 && max_drive_level[i] <= 1)) return fail(fmt::format("max_drive_level[{}] is not in (0, 1]", i));
  if (static_cast<int>(polarisation) >= drivers::kPolarisationCodeCount)
    return fail(fmt::format("polarisation: unknown code {}", static_cast<int>(polarisation)));
  std::string reader_error;
  if (!reader.IsValid(&reader_error)) return fail("reader: " + reader_error);
  return true;
}

CalibrationRun::CalibrationRun(drivers::LedController& leds, drivers::Spectrometer& spectrometer, LampSwitch lamp,
                               CalibrationRunOptions options)
    : leds_(leds), spectrometer_(spectrometer), lamp_(std::move(lamp)), options_(std::move(options)) {
  std::string error;
  if (!options_.IsValid(&error)) throw std::invalid_argument("CalibrationRunOptions: " + error);
  if (!lamp_) throw std::invalid_argument("CalibrationRun: no lamp switch");
}

CalibrationSummary CalibrationRun::run(const files::Progress& progress) {
  const auto start = std::chrono::steady_clock::now();
  CalibrationSummary summary;
  const int rungs = static_cast<int>(options_.drive_levels.size());
  const int total_steps = 1 + kLeds * (rungs + 1);  // lamp, then warm-up + rungs per LED
  int step = 0;
  auto report = [&](const std::string& text) {
    if (progress.cancelled()) throw files::Cancelled{};
    progress.report(static_cast<double>(step) / total_steps, text);
  };
  auto off_state = [] {
    drivers::LedState state;
    state.drive.fill(0.0);
    return state;
  };

  try {
    drivers::SpectrometerReader reader(spectrometer_, options_.reader);
    const drivers::SpectrometerInfo spectrometer_info = spectrometer_.info();
    LedLibrary& library = summary.library;
    library.source = "measured";
    library.created_utc = utc_timestamp_now();
    library.instrument.spectrometer_model = spectrometer_info.model;
    library.instrument.spectrometer_serial = spectrometer_info.serial;
    library.conditions.ambient_temperature_C = options_.ambient_temperature_C;
    library.conditions.warm_up_s = options_.warm_up_s;
    library.conditions.notes = options_.notes;

    // 1. The spectrometer's relative spectral response against the lamp.
    report(fmt::format("reference lamp ({:.0f} K): spectrometer response", options_.lamp_temperature_K));
    leds_.set_state(off_state());
    switch_led_output(leds_, false);
    lamp_(true);
    drivers::SpectrometerMeasurement lamp_measurement;
    try {
      lamp_measurement = reader.measure(lamp_);
    } catch (...) {
      lamp_(false);
      throw;
    }
    lamp_(false);
    ++summary.spectra_measured;
    std::vector<double> grid_nm(spectral::kGridSize);
    for (int i = 0; i < spectral::kGridSize; ++i) grid_nm[i] = spectral::grid_wavelength_nm(i);
    const SpectralResponseCorrection correction =
        spectral_response_correction(grid_nm, lamp_measurement.counts_per_s.to_vector(), options_.lamp_temperature_K);
    const spectral::Spectrum correction_grid = correction_on_grid(correction);
    library.instrument.response_calibration =
        ResponseCalibrationRecord{options_.lamp_description, options_.lamp_temperature_K, library.created_utc, correction_grid};
    ++step;

    // 2. Each LED type: warm-up, then the ladder from the top down.
    for (int led = 0; led < kLeds; ++led) {
      const auto type = static_cast<LedType>(led);
      const std::string name(spectral::led_type_name(type));
      LedRecord& record = library.leds[led];
      record.type = type;
      record.description = options_.polarisation == drivers::Polarisation::kUnpolarised
                               ? "measured by CalibrationRun"
                               : std::string("measured by CalibrationRun through the ") +
                                     drivers::polarisation_name(options_.polarisation) + " banks";
      record.max_drive_level = options_.max_drive_level[led];
      record.ladder.resize(rungs);

      auto drive = [&](double level) {
        drivers::LedState state = off_state();
        state.drive[led] = level;
        state.polarisation[led] = options_.polarisation;
        leds_.set_state(state);
        switch_led_output(leds_, true);
      };
      auto check_faults = [&]() -> drivers::LedStatus {
        const drivers::LedStatus status = leds_.read_status();
        if (status.channel_faults[led] != drivers::kLedFaultNone)
          throw drivers::DeviceError(drivers::DeviceError::Kind::kFault, "LED controller", "drive " + name,
                                     "channel " + name + " reports " + channel_fault_text(status.channel_faults[led]));
        return status;
      };

      report(fmt::format("{}: cold spectrum, then warm-up {:.1f} s", name, options_.warm_up_s));
      drive(options_.drive_levels.back());
      const auto switched_on = std::chrono::steady_clock::now();
      const LedSpectrumSample cold =
          measure_cold(reader, leds_, check_faults, led, correction_grid, options_.drive_levels.back());
      ++summary.spectra_measured;
      // The warm-up counts from switch-on: the cold spectrum is taken within it.
      sleep_s(options_.warm_up_s -
              std::chrono::duration<double>(std::chrono::steady_clock::now() - switched_on).count());
      check_faults();
      ++step;
      for (int r = rungs - 1; r >= 0; --r) {
        const double level = options_.drive_levels[r];
        report(fmt::format("{}: drive {:.2f}", name, level));
        drive(level);
        sleep_s(options_.settle_s);
        const drivers::LedStatus status = check_faults();
        const drivers::SpectrometerMeasurement m =
            reader.measure([this](bool on) { switch_led_output(leds_, on); });
        ++summary.spectra_measured;
        if (signal_fraction(m, spectrometer_info.saturation_counts) < options_.min_peak_fraction)
          throw drivers::DeviceError(drivers::DeviceError::Kind::kFault, "LED controller", "drive " + name,
                                     fmt::format("channel {} gives no light at drive {:.2f} (dead LED?)", name, level));
        LedSpectrumSample& sample = record.ladder[r];
        sample.drive_level = level;
        sample.led_temperature_C = status.temperature_C[led];
        sample.integration_time_us = static_cast<double>(m.integration_time_us);
        sample.dark_subtracted = true;
        sample.spectrum = m.counts_per_s * correction_grid;
        ++step;
      }
      record.thermal = thermal_coefficients(cold, record.ladder.back());
      leds_.set_state(off_state());
    }
    leds_.set_output_enabled(false);

    // 3. Linearity.
    summary.linearity_ok = true;
    std::string nonlinear;
    for (int led = 0; led < kLeds; ++led) {
      summary.linearity[led] = check_linearity(library.leds[led]);
      const auto& lin = summary.linearity[led];
      if (lin.assessable && lin.max_deviation_percent > options_.max_linearity_deviation_percent) {
        summary.linearity_ok = false;
        nonlinear += fmt::format(" {} ({:.2f} %)", spectral::led_type_name(lin.type), lin.max_deviation_percent);
      }
    }
    if (const std::string invalid = validate(library); !invalid.empty())
      throw std::runtime_error("measured library is not valid: " + invalid);
    summary.termination = CalibrationTermination::kCompleted;
    summary.message = fmt::format("measured {} spectra; ", summary.spectra_measured) +
                      (summary.linearity_ok ? fmt::format("all LEDs linear within {:.1f} %", options_.max_linearity_deviation_percent)
                                            : "non-linear beyond " + fmt::format("{:.1f} %:", options_.max_linearity_deviation_percent) + nonlinear);
    progress.report(1.0, "done");
  } catch (const files::Cancelled&) {
    summary.termination = CalibrationTermination::kCancelled;
    summary.message = "cancelled";
    summary.library = {};
  } catch (const std::exception& e) {
    summary.termination = CalibrationTermination::kDeviceError;
    summary.message = e.what();
    summary.library = {};
  }
  if (summary.termination != CalibrationTermination::kCompleted) {
    try {  // leave the sphere dark whatever happened
      leds_.set_output_enabled(false);
      lamp_(false);
    } catch (...) {
    }
  }
  summary.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace chromo::calibration
