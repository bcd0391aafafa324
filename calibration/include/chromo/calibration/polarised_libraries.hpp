#pragma once
// LED libraries and mixes per polarisation state (docs/polarisation.md,
// "Calibration per state"). On a sphere with polariser banks every state
// emits a different spectrum: a bank's light has passed its polariser film,
// whose transmission depends on wavelength (lower in the blue), and the
// unpolarised state drives both banks. Each state is therefore measured (or,
// before it is, predicted from the unpolarised library through the film's
// transmission) and each state gets its own mix. A plain value type.

#include <functional>
#include <map>
#include <optional>

#include "chromo/calibration/led_library.hpp"
#include "chromo/calibration/mix_solver.hpp"
#include "chromo/calibration/mix_target.hpp"
#include "chromo/drivers/led_controller.hpp"

namespace chromo::calibration {

struct PolarisedLedLibraries {
  std::optional<LedLibrary> unpolarised, cross, parallel;

  // The library of `state`; std::invalid_argument naming the state when it
  // has none (e.g. cross asked of a sphere calibrated unpolarised only).
  const LedLibrary& for_state(drivers::Polarisation state) const;
};

// A bank's library predicted from the unpolarised one: every rung's spectrum
// times the film's transmission of unpolarised light (on the grid, each value
// in (0, 1]); source "<source> through polariser". std::invalid_argument
// naming the first wavelength whose transmission is out of range.
LedLibrary library_through_polariser(const LedLibrary& unpolarised, const spectral::Spectrum& transmission);

// One mix per state that has a library: solve_mix on that state's library,
// against the target `target_for` builds from it (a W57 + blue target
// depends on the library it is reached with; d65 does not).
std::map<drivers::Polarisation, MixSummary> solve_mix_per_state(
    const PolarisedLedLibraries& libraries, const std::function<MixTarget(const LedLibrary&)>& target_for,
    const MixSolverOptions& options);

}  // namespace chromo::calibration
