#pragma once
// SpectrometerReader: turns any Spectrometer into calibrated-shape spectra on
// the project grid. One measure() does, in order:
//
//  1. Auto-ranging (unless disabled): starting at options.integration_time_us,
//     take a spectrum; if any pixel is saturated divide the time by 4; if the
//     brightest pixel is outside [accept_low_fraction, accept_high_fraction] of
//     full scale, scale the time to put it at target_peak_fraction; repeat (at
//     most max_auto_range_steps). Still saturated at the shortest time (or,
//     without auto-ranging, at the given time) → DeviceError(kSaturated).
//  2. Stale-spectrum rule: after every integration-time change the first
//     spectrum is read and discarded (on real units it was integrated, at
//     least partly, with the old time).
//  3. Light spectrum, averaged over scans_to_average; then light(false), the
//     dark spectrum at the same time and averaging, light(true).
//  4. Per pixel: x = light − dark; the EEPROM non-linearity correction
//     x / Σ k_i·x^i (applied to dark-subtracted counts); divided by the
//     integration time → counts per second.
//  5. Pixel wavelengths from the EEPROM polynomial; resampled onto the
//     project grid by spectral::resample_to_grid (5 nm bin means, MODEL.md).
//
// The result still carries the detector's spectral response and stray light:
// a calibration (irradiance response from a reference source) must divide it
// out. Thread rules: one thread at a time, like the Spectrometer it reads.
// Lifetime: the Spectrometer must outlive the reader.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "chromo/drivers/spectrometer.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::drivers {

struct SpectrometerReaderOptions {
  bool auto_range = true;
  std::uint32_t integration_time_us = 100000;  // fixed time, or where auto-ranging starts
  double target_peak_fraction = 0.7;           // of the saturation count
  double accept_low_fraction = 0.4;
  double accept_high_fraction = 0.9;
  int max_auto_range_steps = 10;
  int scans_to_average = 1;

  bool IsValid(std::string* error) const;
};

struct SpectrometerMeasurement {
  spectral::Spectrum counts_per_s;            // on the project grid
  std::vector<double> wavelength_nm;          // per pixel
  std::vector<double> pixel_counts_per_s;     // per pixel: dark-subtracted, linearised, per second
  std::uint32_t integration_time_us = 0;      // the time used
  double peak_fraction = 0;                   // brightest raw light pixel / saturation count
  int auto_range_steps = 0;                   // spectra taken to find the time
  int discarded_spectra = 0;                  // stale spectra thrown away
};

class SpectrometerReader {
 public:
  // Switches the measured light on (true) or off (false) for the dark frame,
  // returning once it has settled (e.g. LedController::set_output_enabled).
  using LightSwitch = std::function<void(bool on)>;

  // Throws std::invalid_argument if !options.IsValid().
  SpectrometerReader(Spectrometer& spectrometer, SpectrometerReaderOptions options);

  SpectrometerMeasurement measure(const LightSwitch& light);

  // Per-pixel wavelengths from the device's calibration polynomial.
  std::vector<double> pixel_wavelengths_nm() const;

 private:
  RawSpectrum acquire(std::uint32_t integration_time_us, int* discarded);
  std::vector<double> average(std::uint32_t integration_time_us, int* discarded);

  Spectrometer& spectrometer_;
  SpectrometerReaderOptions options_;
  SpectrometerInfo info_;
  std::uint32_t current_time_us_ = 0;  // 0: unknown, set before the first spectrum
};

}  // namespace chromo::drivers
