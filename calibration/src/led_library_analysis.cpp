#include "chromo/calibration/led_library_analysis.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace chromo::calibration {

double peak_wavelength_nm(const spectral::Spectrum& spectrum) {
  int peak = 0;
  spectrum.values().maxCoeff(&peak);
  double offset = 0;
  if (peak > 0 && peak < spectral::kGridSize - 1) {
    const double left = spectrum[peak - 1], centre = spectrum[peak], right = spectrum[peak + 1];
    const double curvature = left - 2.0 * centre + right;
    if (curvature < 0) offset = 0.5 * (left - right) / curvature;
  }
  return spectral::grid_wavelength_nm(peak) + offset * spectral::kGridStepNm;
}

double centroid_wavelength_nm(const spectral::Spectrum& spectrum) {
  double weighted = 0, total = 0;
  for (int i = 0; i < spectral::kGridSize; ++i) {
    weighted += spectral::grid_wavelength_nm(i) * spectrum[i];
    total += spectrum[i];
  }
  return weighted / total;
}

std::array<LedDrift, spectral::kLedTypeCount> compare(const LedLibrary& old_library, const LedLibrary& new_library) {
  std::array<LedDrift, spectral::kLedTypeCount> drifts;
  for (int i = 0; i < spectral::kLedTypeCount; ++i) {
    const spectral::Spectrum old_s = old_library.leds[i].spectrum_per_unit_drive();
    const spectral::Spectrum new_s = new_library.leds[i].spectrum_per_unit_drive();
    LedDrift& d = drifts[i];
    d.type = spectral::kAllLedTypes[i];
    d.peak_shift_nm = peak_wavelength_nm(new_s) - peak_wavelength_nm(old_s);
    d.centroid_shift_nm = centroid_wavelength_nm(new_s) - centroid_wavelength_nm(old_s);
    d.flux_change_percent = 100.0 * (new_s.integral() / old_s.integral() - 1.0);
    d.rmse_relative_to_peak = std::sqrt((new_s.values() - old_s.values()).square().mean()) / old_s.max();
  }
  return drifts;
}

LinearityReport check_linearity(const LedRecord& led) {
  LinearityReport report;
  report.type = led.type;
  report.rungs = static_cast<int>(led.ladder.size());
  if (report.rungs < 3) return report;
  report.assessable = true;
  const int n = report.rungs;
  double sum_d = 0, sum_f = 0, sum_dd = 0, sum_df = 0;
  std::vector<double> flux(n);
  for (int k = 0; k < n; ++k) {
    const double d = led.ladder[k].drive_level;
    flux[k] = led.ladder[k].spectrum.integral();
    sum_d += d, sum_f += flux[k], sum_dd += d * d, sum_df += d * flux[k];
  }
  const double slope = (n * sum_df - sum_d * sum_f) / (n * sum_dd - sum_d * sum_d);
  const double intercept = (sum_f - slope * sum_d) / n;
  const double top = intercept + slope * led.ladder.back().drive_level;
  report.slope_flux_per_drive = slope;
  report.intercept_percent = 100.0 * intercept / top;
  for (int k = 0; k < n; ++k)
    report.max_deviation_percent = std::max(
        report.max_deviation_percent, 100.0 * std::abs(flux[k] - (intercept + slope * led.ladder[k].drive_level)) / top);
  return report;
}

std::optional<LedThermalRecord> thermal_coefficients(const LedSpectrumSample& cold, const LedSpectrumSample& warm) {
  if (!cold.led_temperature_C || !warm.led_temperature_C) return std::nullopt;
  const double rise_K = *warm.led_temperature_C - *cold.led_temperature_C;
  const double cold_flux = cold.spectrum.integral(), warm_flux = warm.spectrum.integral();
  if (!(rise_K >= kMinThermalRiseK) || !(cold_flux > 0) || !(warm_flux > 0)) return std::nullopt;
  LedThermalRecord out;
  out.drive_level = warm.drive_level;
  out.cold_C = *cold.led_temperature_C;
  out.warm_C = *warm.led_temperature_C;
  out.flux_change_per_K = (1.0 - cold_flux / warm_flux) / rise_K;
  out.centroid_shift_nm_per_K =
      (centroid_wavelength_nm(warm.spectrum) - centroid_wavelength_nm(cold.spectrum)) / rise_K;
  return out;
}

}  // namespace chromo::calibration
