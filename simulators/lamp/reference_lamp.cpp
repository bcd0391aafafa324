#include "chromo/simulators/reference_lamp.hpp"

#include <cmath>
#include <stdexcept>

namespace chromo::simulators {

ReferenceLamp::ReferenceLamp(double colour_temperature_K, double peak_irradiance)
    : colour_temperature_K_(colour_temperature_K) {
  if (!(colour_temperature_K > 0) || !(peak_irradiance > 0))
    throw std::invalid_argument("ReferenceLamp: colour temperature and peak irradiance must be positive");
  double peak = 0;
  for (int i = 0; i < spectral::kGridSize; ++i) peak = std::max(peak, planck_relative(spectral::grid_wavelength_nm(i)));
  scale_ = peak_irradiance / peak;
}

double ReferenceLamp::planck_relative(double wavelength_nm) const {
  // Spectral radiance up to a constant: λ^-5 / (exp(c2 / (λ T)) − 1), c2 in m·K.
  constexpr double c2_m_K = 1.438776877e-2;
  const double lambda_m = wavelength_nm * 1e-9;
  return std::pow(wavelength_nm / 560.0, -5.0) / std::expm1(c2_m_K / (lambda_m * colour_temperature_K_));
}

double ReferenceLamp::irradiance_at_nm(double wavelength_nm) const {
  return on() && wavelength_nm > 0 ? scale_ * planck_relative(wavelength_nm) : 0.0;
}

spectral::Spectrum ReferenceLamp::irradiance_now() const {
  spectral::Spectrum s;
  for (int i = 0; i < spectral::kGridSize; ++i) s.values()[i] = irradiance_at_nm(spectral::grid_wavelength_nm(i));
  return s;
}

spectral::Spectrum SummedIllumination::irradiance_now() const {
  spectral::Spectrum sum;
  for (const auto* source : sources_) sum += source->irradiance_now();
  return sum;
}

double SummedIllumination::irradiance_at_nm(double wavelength_nm) const {
  double sum = 0;
  for (const auto* source : sources_) sum += source->irradiance_at_nm(wavelength_nm);
  return sum;
}

}  // namespace chromo::simulators
