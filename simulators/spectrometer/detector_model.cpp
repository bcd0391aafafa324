#include "chromo/simulators/spectrometer/detector_model.hpp"

#include <cmath>

namespace chromo::simulators {

double DetectorModel::wavelength_nm(int pixel) const {
  const auto& c = wavelength_coefficients;
  return c[0] + pixel * (c[1] + pixel * (c[2] + pixel * c[3]));
}

double DetectorModel::response_at_nm(double nm) const {
  double z = (nm - response_peak_nm) / response_width_nm;
  return response_floor + (1.0 - response_floor) * std::exp(-0.5 * z * z);
}

spectral::Spectrum DetectorModel::response_on_grid() const {
  spectral::Spectrum response;
  for (int i = 0; i < spectral::kGridSize; ++i) response[i] = response_at_nm(spectral::grid_wavelength_nm(i));
  return response;
}

}  // namespace chromo::simulators
