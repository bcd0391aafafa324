#pragma once
// What a calibration run is checked for: how far each LED has drifted since
// an earlier library, and how linear its output is in drive level.

#include <array>
#include <optional>
#include <string>

#include "chromo/calibration/led_library.hpp"

namespace chromo::calibration {

// Drift of one LED type between two libraries, both taken at one unit of
// drive (LedRecord::spectrum_per_unit_drive).
struct LedDrift {
  LedType type = LedType::kW57;
  double peak_shift_nm = 0;        // new − old wavelength of the maximum (parabolic sub-sample fit)
  double centroid_shift_nm = 0;    // new − old of Σλs/Σs
  double flux_change_percent = 0;  // 100·(∫new/∫old − 1)
  // RMS of (new − old) over the grid divided by old's peak: shape and flux change together.
  double rmse_relative_to_peak = 0;
};
std::array<LedDrift, spectral::kLedTypeCount> compare(const LedLibrary& old_library, const LedLibrary& new_library);

// Radiant flux ∫s dλ against drive level over one LED's ladder, fitted by a
// straight line (least squares, with intercept). max_deviation_percent is the
// largest |flux − line| over the rungs, in percent of the line's value at the
// top rung; intercept_percent is the line at zero drive in the same units (a
// dark-subtracted linear LED gives ~0). Needs at least 3 rungs to say
// anything: with fewer, `assessable` is false and the numbers are 0.
struct LinearityReport {
  LedType type = LedType::kW57;
  bool assessable = false;
  int rungs = 0;
  double slope_flux_per_drive = 0;
  double intercept_percent = 0;
  double max_deviation_percent = 0;
};
LinearityReport check_linearity(const LedRecord& led);

// The thermal coefficients of one LED from a cold and a warm spectrum at the
// same drive level (both with led_temperature_C): nullopt when either has
// no temperature or the warm one is less than kMinThermalRiseK warmer (too
// little rise to tell a coefficient from the spectrometer's noise).
inline constexpr double kMinThermalRiseK = 5.0;
std::optional<LedThermalRecord> thermal_coefficients(const LedSpectrumSample& cold, const LedSpectrumSample& warm);

// Wavelength of the maximum with a parabola through the three samples around
// it (the grid step is 5 nm; this resolves drifts well below that).
double peak_wavelength_nm(const spectral::Spectrum& spectrum);
double centroid_wavelength_nm(const spectral::Spectrum& spectrum);

}  // namespace chromo::calibration
