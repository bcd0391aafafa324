#pragma once
// Relative spectral response of a spectrometer, calibrated against a
// reference lamp taken as a Planckian radiator (a tungsten-halogen lamp at its
// stated colour temperature):
//
//   correction(λ) = P(λ, T) / counts(λ), scaled to 1 at 560 nm,
//
// where counts are the lamp's dark-subtracted counts per unit integration
// time at pixel wavelength λ and P is Planck's law (planck.hpp). Multiplying
// any later dark-subtracted spectrum by the correction gives relative
// spectral irradiance. Pixels where the lamp gives less than
// `min_relative_signal` of its peak counts (the detector's dead ends, where
// noise would be amplified without bound) get correction 0 and usable=false.
//
// The measurement itself (lamp on, auto-ranged integration, dark frames)
// needs the spectrometer driver and is not here; this is the arithmetic.
// Works on any wavelength axis (the spectrometer's native pixels or the grid).

#include <string>
#include <vector>

#include "chromo/spectral/spectrum.hpp"

namespace chromo::calibration {

struct SpectralResponseCorrection {
  std::vector<double> wavelength_nm;
  std::vector<double> correction;  // multiply counts by this; 0 where not usable
  std::vector<bool> usable;
  double lamp_temperature_K = 0;

  // counts (same axis) × correction. std::invalid_argument on a size mismatch.
  std::vector<double> apply(const std::vector<double>& counts) const;
};

// std::invalid_argument when the sizes differ, wavelengths are not strictly
// increasing or do not contain 560 nm in their range, the temperature is not
// positive, min_relative_signal is not in (0, 1), or the counts near 560 nm
// are below the threshold (the lamp was not seen).
SpectralResponseCorrection spectral_response_correction(const std::vector<double>& wavelength_nm,
                                                        const std::vector<double>& lamp_counts,
                                                        double lamp_temperature_K,
                                                        double min_relative_signal = 0.01);

// The correction on the project grid (linear interpolation; 0 outside the
// calibrated axis), as stored in the LED library.
spectral::Spectrum correction_on_grid(const SpectralResponseCorrection& correction);

}  // namespace chromo::calibration
