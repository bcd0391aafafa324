#pragma once
// DetectorModel: how the simulated USB2000+ turns the true irradiance into
// raw counts (documented with its values in docs/protocols/spectrometer.md,
// "Simulator"). Per pixel p at wavelength λ_p (EEPROM polynomial):
//
//   s_p   = E(λ_p) · response(λ_p) · counts_per_s_per_unit · t          (signal)
//         + stray_light_fraction · mean_q(E(λ_q) · response(λ_q)) · counts_per_s_per_unit · t
//   x_p   = the solution of x = s_p · N(x), N(x) = Σ k_i x^i            (non-linearity;
//           the driver's x / N(x) undoes it exactly)
//   raw_p = dark_level_counts + dark_current_counts_per_s · t + x_p
//           + shot noise (variance x_p / electrons_per_count, in counts²) + read noise
//   clamped to [0, 65535], rounded.
//
// response(λ) = response_floor + (1 − response_floor)·exp(−½((λ − response_peak_nm)/response_width_nm)²).

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "chromo/spectral/spectrum.hpp"

namespace chromo::simulators {

struct DetectorModel {
  int pixel_count = 2048;
  std::array<double, 4> wavelength_coefficients{339.5, 0.38, -1.5e-5, 0.0};
  std::vector<double> nonlinearity_coefficients{1.0, -1.5e-6, -5.0e-12};  // N(x), x in counts
  double response_floor = 0.3;
  double response_peak_nm = 600;
  double response_width_nm = 150;
  double counts_per_s_per_unit = 3.0e5;  // counts/s at response 1 for irradiance 1
  double stray_light_fraction = 0.001;
  double dark_level_counts = 1500;
  double dark_current_counts_per_s = 200;
  double read_noise_counts = 6;
  double electrons_per_count = 20;
  double saturation_counts = 65535;
  std::uint64_t noise_seed = 1;
  std::string serial = "USB2+SIM00001";

  double wavelength_nm(int pixel) const;
  double response_at_nm(double wavelength_nm) const;
  // The response on the project grid (for tests and calibration checks).
  spectral::Spectrum response_on_grid() const;
};

}  // namespace chromo::simulators
