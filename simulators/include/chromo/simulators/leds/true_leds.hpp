#pragma once
// The true LEDs of the virtual lab: each type's measured spectrum (compiled
// into spectral/ from data/led_spectra_measured/), its flux, and how it drifts
// with temperature and (constant-current devices) with current. Documented
// with the chosen values in docs/virtual-lab-leds.md.
//
// Reference state: the measured spectrum file, scaled to `relative_flux` at its
// peak, is the emission at full drive, warmed up (junction at ambient +
// junction_rise_full_K). Any other state is derived from it:
//   ΔT  = T_junction − T_reference
//   Δλ  = peak_shift_nm_per_K·ΔT  (+ current_shift_nm·(level − 1) for constant current)
//   flux factor = (1 − flux_loss_per_K·ΔT) · level            (PWM duty)
//               = (1 − flux_loss_per_K·ΔT) · level·η(level)    (constant current)
//   η(level) = (1 − droop·level) / (1 − droop)                 (efficiency droop, η(1) = 1)
//   S(λ) = relative_flux · flux factor · file(λ − Δλ)
// The whole spectrum is shifted (for the phosphor whites this overstates the
// phosphor's own drift; their blue pump dominates the shift).

#include <array>
#include <string>
#include <vector>

#include "chromo/spectral/led_type.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::simulators {

struct TrueLedParameters {
  std::string spectrum_file;         // name of the embedded file (spectral::data::embedded_file)
  double relative_flux = 1;          // peak irradiance at full drive, warmed up
  double peak_shift_nm_per_K = 0;
  double flux_loss_per_K = 0;        // fraction of flux lost per kelvin of junction temperature
  double junction_rise_full_K = 30;  // junction rise above ambient at full drive, warmed up
  double current_shift_nm = 0;       // constant current only: Δλ = current_shift_nm·(level − 1)
  double droop = 0;                  // constant current only: efficiency droop (see above)
};

using TrueLedSet = std::array<TrueLedParameters, spectral::kLedTypeCount>;

// The defaults: W57, W40, W27, R, G, B as documented in docs/virtual-lab-leds.md.
TrueLedSet default_true_leds();

// One LED type's fine-resolution reference spectrum (peak 1), read from the
// embedded measured file: wavelengths (nm, strictly increasing) and values.
struct FineSpectrum {
  std::vector<double> wavelength_nm;
  std::vector<double> value;
  // Linear interpolation at `nm`, 0 outside the measured range.
  double at(double nm) const;
};
FineSpectrum load_reference_spectrum(const TrueLedParameters& parameters);

}  // namespace chromo::simulators
