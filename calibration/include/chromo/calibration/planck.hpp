#pragma once
// Planck's law and correlated colour temperature (CCT), the two pieces of
// black-body physics calibration needs: the reference lamp of the
// spectrometer's response calibration and the reference illuminant of the
// colour rendering index (CIE 13.3) are both Planckian radiators.

#include <span>

#include "chromo/spectral/colorimetry.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::calibration {

// Second radiation constant c2 = hc/k in m·K (CODATA/CIE 15:2004 value).
inline constexpr double kPlanckC2_mK = 1.4388e-2;
// First radiation constant for spectral radiance, c1L = 2hc² in W·m²/sr.
inline constexpr double kPlanckC1L_Wm2_per_sr = 1.191042972e-16;

// Spectral radiance of a black body at wavelength_nm and temperature_K, in
// W·m⁻²·sr⁻¹·nm⁻¹. Requires wavelength_nm > 0 and temperature_K > 0.
double planck_radiance_W_per_m2_sr_nm(double wavelength_nm, double temperature_K);

// The black body on the project grid, scaled to 100 at 560 nm (as CIE
// illuminants are). temperature_K must be > 0 (std::invalid_argument).
spectral::Spectrum planckian_spectrum(double temperature_K);

// CIE 1960 UCS (u, v): the space in which CCT and the CRI's chromatic
// adaptation are defined (v = 2/3 v').
struct Uv1960 {
  double u = 0, v = 0;
};
Uv1960 uv_1960(const spectral::Xyz& xyz);

// Correlated colour temperature: the temperature of the Planckian radiator
// (computed on the project grid with the CIE 1931 observer) whose (u, v) is
// nearest to the light's, searched over 1000-100000 K to 1e-3 K. duv is the
// signed distance (positive above the locus), as CIE 13.3's DC check needs.
struct CorrelatedColourTemperature {
  double cct_K = 0;
  double duv = 0;
};
CorrelatedColourTemperature correlated_colour_temperature(const spectral::Spectrum& spd);

}  // namespace chromo::calibration
