#include "chromo/drivers/spectrometer_reader.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "chromo/drivers/device_error.hpp"
#include "chromo/spectral/resample.hpp"

namespace chromo::drivers {

bool SpectrometerReaderOptions::IsValid(std::string* error) const {
  auto bad = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  if (integration_time_us == 0) return bad("integration_time_us must be positive");
  if (!(accept_low_fraction > 0 && accept_low_fraction < target_peak_fraction &&
        target_peak_fraction < accept_high_fraction && accept_high_fraction < 1))
    return bad("need 0 < accept_low_fraction < target_peak_fraction < accept_high_fraction < 1");
  if (max_auto_range_steps < 1) return bad("max_auto_range_steps must be at least 1");
  if (scans_to_average < 1) return bad("scans_to_average must be at least 1");
  return true;
}

SpectrometerReader::SpectrometerReader(Spectrometer& spectrometer, SpectrometerReaderOptions options)
    : spectrometer_(spectrometer), options_(options), info_(spectrometer.info()) {
  std::string error;
  if (!options_.IsValid(&error)) throw std::invalid_argument("SpectrometerReaderOptions: " + error);
}

std::vector<double> SpectrometerReader::pixel_wavelengths_nm() const {
  std::vector<double> nm(info_.pixel_count);
  const auto& c = info_.wavelength_coefficients;
  for (int p = 0; p < info_.pixel_count; ++p) nm[p] = c[0] + p * (c[1] + p * (c[2] + p * c[3]));
  return nm;
}

RawSpectrum SpectrometerReader::acquire(std::uint32_t integration_time_us, int* discarded) {
  if (integration_time_us != current_time_us_) {
    spectrometer_.set_integration_time_us(integration_time_us);
    current_time_us_ = integration_time_us;
    spectrometer_.read_raw_spectrum();  // stale: integrated (partly) with the old time
    ++*discarded;
  }
  return spectrometer_.read_raw_spectrum();
}

std::vector<double> SpectrometerReader::average(std::uint32_t integration_time_us, int* discarded) {
  std::vector<double> sum(info_.pixel_count, 0.0);
  for (int scan = 0; scan < options_.scans_to_average; ++scan) {
    RawSpectrum raw = acquire(integration_time_us, discarded);
    for (int p = 0; p < info_.pixel_count; ++p) sum[p] += raw.counts[p] / options_.scans_to_average;
  }
  return sum;
}

SpectrometerMeasurement SpectrometerReader::measure(const LightSwitch& light) {
  if (!light) throw std::invalid_argument("SpectrometerReader::measure needs a light switch for the dark frame");
  SpectrometerMeasurement m;
  const std::uint32_t min_us = info_.min_integration_time_us, max_us = info_.max_integration_time_us;
  std::uint32_t time_us = std::clamp(options_.integration_time_us, min_us, max_us);
  const double full = info_.saturation_counts;
  auto saturated_time = [&](std::uint32_t us, double peak) {
    return DeviceError(DeviceError::Kind::kSaturated, "spectrometer " + info_.model + " " + info_.serial,
                       "measure at " + std::to_string(us) + " us",
                       "saturated: brightest pixel at " + std::to_string(peak) + " of " + std::to_string(full) +
                           (options_.auto_range ? " at the shortest integration time" : " (auto-ranging off)"));
  };

  std::vector<double> light_counts;
  for (;;) {
    RawSpectrum raw = acquire(time_us, &m.discarded_spectra);
    ++m.auto_range_steps;
    double peak = *std::max_element(raw.counts.begin(), raw.counts.end());
    bool saturated = peak >= full;
    if (!options_.auto_range) {
      if (saturated) throw saturated_time(time_us, peak);
      break;
    }
    double fraction = peak / full;
    std::uint32_t next = time_us;
    if (saturated) {
      if (time_us == min_us) throw saturated_time(time_us, peak);
      next = std::max(min_us, time_us / 4);
    } else if (fraction < options_.accept_low_fraction || fraction > options_.accept_high_fraction) {
      double scaled = time_us * options_.target_peak_fraction / std::max(fraction, 1e-6);
      next = static_cast<std::uint32_t>(std::clamp(scaled, double(min_us), double(max_us)));
    }
    if (next == time_us) break;  // accepted, or at a limit that cannot do better
    if (m.auto_range_steps >= options_.max_auto_range_steps) {
      if (saturated) throw saturated_time(time_us, peak);
      break;
    }
    time_us = next;
  }
  light_counts = average(time_us, &m.discarded_spectra);
  m.peak_fraction = *std::max_element(light_counts.begin(), light_counts.end()) / full;
  if (m.peak_fraction >= 1.0) throw saturated_time(time_us, m.peak_fraction * full);

  light(false);
  std::vector<double> dark_counts = average(time_us, &m.discarded_spectra);
  light(true);

  m.integration_time_us = time_us;
  m.wavelength_nm = pixel_wavelengths_nm();
  m.pixel_counts_per_s.resize(info_.pixel_count);
  const auto& k = info_.nonlinearity_coefficients;
  const double seconds = time_us * 1e-6;
  for (int p = 0; p < info_.pixel_count; ++p) {
    double x = light_counts[p] - dark_counts[p];
    double ratio = 0;
    for (auto it = k.rbegin(); it != k.rend(); ++it) ratio = ratio * x + *it;
    if (k.empty() || ratio <= 0) ratio = 1;
    m.pixel_counts_per_s[p] = x / ratio / seconds;
  }
  m.counts_per_s = spectral::resample_to_grid(m.wavelength_nm, m.pixel_counts_per_s,
                                              "spectrometer " + info_.model + " " + info_.serial);
  return m;
}

}  // namespace chromo::drivers
