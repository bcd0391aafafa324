#pragma once
// The illuminants the estimator reports against: the six LED types of the
// virtual lab (measured spectra compiled into spectral/), D65, D50 and A.

#include <string>
#include <vector>

#include "chromo/spectral/led_type.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::spectral {

// Measured emission spectrum of one LED type (peak-normalised, on the grid).
const Spectrum& led_spectrum(LedType type);

struct NamedIlluminant {
  std::string name;  // "W57", ..., "B", "D65", "D50", "A"
  Spectrum spectrum;
};
// The six LED types in kAllLedTypes order, then D65.
std::vector<NamedIlluminant> relight_illuminants();

// A D65 metamer mixed from the six LEDs: non-negative least squares on the
// spectrum over 400-700 nm (what the calibration's mix solver does with
// measured spectra; used where a D65' is needed without a calibration).
Spectrum led_d65_metamer();

}  // namespace chromo::spectral
