#include "chromo/calibration/response_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "chromo/calibration/planck.hpp"
#include "chromo/spectral/grid.hpp"

namespace chromo::calibration {
namespace {

// Linear interpolation of (x, y) at `at`; x strictly increasing, at inside.
double interpolate(const std::vector<double>& x, const std::vector<double>& y, double at) {
  const auto upper = std::upper_bound(x.begin(), x.end(), at);
  if (upper == x.begin()) return y.front();
  if (upper == x.end()) return y.back();
  const std::size_t i = static_cast<std::size_t>(upper - x.begin());
  const double t = (at - x[i - 1]) / (x[i] - x[i - 1]);
  return y[i - 1] + t * (y[i] - y[i - 1]);
}

}  // namespace

std::vector<double> SpectralResponseCorrection::apply(const std::vector<double>& counts) const {
  if (counts.size() != correction.size())
    throw std::invalid_argument("spectral response correction: " + std::to_string(counts.size()) +
                                " counts for a correction of " + std::to_string(correction.size()) + " pixels");
  std::vector<double> out(counts.size());
  for (std::size_t i = 0; i < counts.size(); ++i) out[i] = counts[i] * correction[i];
  return out;
}

SpectralResponseCorrection spectral_response_correction(const std::vector<double>& wavelength_nm,
                                                        const std::vector<double>& lamp_counts,
                                                        double lamp_temperature_K, double min_relative_signal) {
  const std::string what = "spectral response calibration: ";
  if (wavelength_nm.size() != lamp_counts.size() || wavelength_nm.size() < 2)
    throw std::invalid_argument(what + "need at least two pixels and as many counts as wavelengths (got " +
                                std::to_string(wavelength_nm.size()) + " wavelengths, " +
                                std::to_string(lamp_counts.size()) + " counts)");
  for (std::size_t i = 1; i < wavelength_nm.size(); ++i)
    if (!(wavelength_nm[i] > wavelength_nm[i - 1]) || !(wavelength_nm[i - 1] > 0))
      throw std::invalid_argument(what + "wavelengths must be positive and strictly increasing (pixel " +
                                  std::to_string(i) + ")");
  if (!(wavelength_nm.front() <= 560.0 && wavelength_nm.back() >= 560.0))
    throw std::invalid_argument(what + "the wavelength axis must include 560 nm (the normalisation point)");
  if (!(lamp_temperature_K > 0.0)) throw std::invalid_argument(what + "lamp temperature must be positive");
  if (!(min_relative_signal > 0.0 && min_relative_signal < 1.0))
    throw std::invalid_argument(what + "min_relative_signal must be in (0, 1)");
  double peak = 0;
  for (double c : lamp_counts) {
    if (!std::isfinite(c)) throw std::invalid_argument(what + "lamp counts hold a non-finite value");
    peak = std::max(peak, c);
  }
  const double threshold = min_relative_signal * peak;
  if (!(interpolate(wavelength_nm, lamp_counts, 560.0) > threshold))
    throw std::invalid_argument(what + "the lamp gives no usable signal at 560 nm");

  SpectralResponseCorrection result;
  result.wavelength_nm = wavelength_nm;
  result.lamp_temperature_K = lamp_temperature_K;
  result.correction.resize(wavelength_nm.size());
  result.usable.resize(wavelength_nm.size());
  std::vector<double> raw(wavelength_nm.size());
  for (std::size_t i = 0; i < wavelength_nm.size(); ++i) {
    result.usable[i] = lamp_counts[i] > threshold;
    raw[i] = planck_radiance_W_per_m2_sr_nm(wavelength_nm[i], lamp_temperature_K) / std::max(lamp_counts[i], threshold);
  }
  const double at_560 = interpolate(wavelength_nm, raw, 560.0);
  for (std::size_t i = 0; i < raw.size(); ++i) result.correction[i] = result.usable[i] ? raw[i] / at_560 : 0.0;
  return result;
}

spectral::Spectrum correction_on_grid(const SpectralResponseCorrection& correction) {
  spectral::Spectrum s;
  for (int i = 0; i < spectral::kGridSize; ++i) {
    const double lambda = spectral::grid_wavelength_nm(i);
    if (lambda >= correction.wavelength_nm.front() && lambda <= correction.wavelength_nm.back())
      s[i] = interpolate(correction.wavelength_nm, correction.correction, lambda);
  }
  return s;
}

}  // namespace chromo::calibration
