#include "chromo/simulators/polarisation/polariser_optics.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace chromo::simulators {
namespace {

// 0 at 550 nm, 1 at 400 nm, linear in wavelength, clamped to 0 above 550 nm.
double blue_weight(double wavelength_nm) { return std::max(0.0, (550.0 - wavelength_nm) / 150.0); }

void require_valid(const PolariserFilm& film, const char* which) {
  std::string error;
  if (!film.IsValid(&error)) throw std::invalid_argument(std::string(which) + ": " + error);
}

}  // namespace

bool PolariserFilm::IsValid(std::string* error) const {
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  if (!(extinction_ratio_550nm >= 1) || !(extinction_ratio_400nm >= 1) || !std::isfinite(extinction_ratio_550nm) ||
      !std::isfinite(extinction_ratio_400nm))
    return fail("polariser extinction ratios must be finite and at least 1 (got " +
                std::to_string(extinction_ratio_550nm) + " at 550 nm, " + std::to_string(extinction_ratio_400nm) +
                " at 400 nm)");
  for (double t : {transmission_550nm, transmission_400nm})
    if (!(t > 0 && t <= 0.5))
      return fail("polariser transmission of unpolarised light must be in (0, 0.5] (got " + std::to_string(t) + ")");
  return true;
}

double PolariserFilm::extinction_ratio_at(double wavelength_nm) const {
  return extinction_ratio_550nm *
         std::pow(extinction_ratio_400nm / extinction_ratio_550nm, blue_weight(wavelength_nm));
}

double PolariserFilm::transmission_at(double wavelength_nm) const {
  const double t = transmission_550nm + (transmission_400nm - transmission_550nm) * blue_weight(wavelength_nm);
  return std::clamp(t, 1e-6, 0.5);
}

spectral::Spectrum PolariserFilm::transmission() const {
  spectral::Spectrum t;
  for (int i = 0; i < spectral::kGridSize; ++i) t[i] = transmission_at(spectral::grid_wavelength_nm(i));
  return t;
}

spectral::Spectrum PolariserFilm::axis_transmittance() const {
  spectral::Spectrum k1;
  for (int i = 0; i < spectral::kGridSize; ++i) {
    const double lambda = spectral::grid_wavelength_nm(i);
    k1[i] = 2.0 * transmission_at(lambda) / (1.0 + 1.0 / extinction_ratio_at(lambda));
  }
  return k1;
}

spectral::Spectrum PolariserFilm::cross_transmittance() const {
  spectral::Spectrum k1 = axis_transmittance(), k2;
  for (int i = 0; i < spectral::kGridSize; ++i) k2[i] = k1[i] / extinction_ratio_at(spectral::grid_wavelength_nm(i));
  return k2;
}

spectral::Spectrum diffuse_transmission(const PolariserFilm& light_film, const PolariserFilm& analyser_film) {
  require_valid(light_film, "light bank polariser");
  require_valid(analyser_film, "camera analyser");
  spectral::Spectrum t;
  for (int i = 0; i < spectral::kGridSize; ++i) {
    const double lambda = spectral::grid_wavelength_nm(i);
    t[i] = light_film.transmission_at(lambda) * analyser_film.transmission_at(lambda);
  }
  return t;
}

spectral::Spectrum surface_factor_in_albedo(drivers::Polarisation state, const PolariserFilm& light_film,
                                            const PolariserFilm& analyser_film, double leak) {
  if (!(leak >= 0 && leak <= 1))
    throw std::invalid_argument("surface_factor_in_albedo: leak " + std::to_string(leak) + " outside [0, 1]");
  const spectral::Spectrum diffuse = diffuse_transmission(light_film, analyser_film);
  const spectral::Spectrum k1p = light_film.axis_transmittance(), k2p = light_film.cross_transmittance();
  const spectral::Spectrum k1a = analyser_film.axis_transmittance(), k2a = analyser_film.cross_transmittance();
  spectral::Spectrum factor;
  for (int i = 0; i < spectral::kGridSize; ++i) {
    const double cross = 0.5 * (k1p[i] * (k2a[i] * (1 - leak) + k1a[i] * leak) +
                                k2p[i] * (k1a[i] * (1 - leak) + k2a[i] * leak));
    const double parallel = 0.5 * (k1p[i] * (k1a[i] * (1 - leak) + k2a[i] * leak) +
                                   k2p[i] * (k2a[i] * (1 - leak) + k1a[i] * leak));
    const double seen = state == drivers::Polarisation::kCross      ? cross
                        : state == drivers::Polarisation::kParallel ? parallel
                                                                    : 0.5 * (cross + parallel);
    factor[i] = seen / diffuse[i];
  }
  return factor;
}

}  // namespace chromo::simulators
