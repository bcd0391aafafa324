#include "chromo/calibration/polarised_libraries.hpp"

#include <stdexcept>
#include <string>

namespace chromo::calibration {
namespace {

const std::optional<LedLibrary>& library_slot(const PolarisedLedLibraries& libraries, drivers::Polarisation state) {
  return state == drivers::Polarisation::kCross      ? libraries.cross
         : state == drivers::Polarisation::kParallel ? libraries.parallel
                                                     : libraries.unpolarised;
}

}  // namespace

const LedLibrary& PolarisedLedLibraries::for_state(drivers::Polarisation state) const {
  const std::optional<LedLibrary>& library = library_slot(*this, state);
  if (!library)
    throw std::invalid_argument(std::string("no LED library for the ") + drivers::polarisation_name(state) +
                                " polarisation state: calibrate the sphere in that state first");
  return *library;
}

LedLibrary library_through_polariser(const LedLibrary& unpolarised, const spectral::Spectrum& transmission) {
  for (int i = 0; i < spectral::kGridSize; ++i)
    if (!(transmission[i] > 0 && transmission[i] <= 1))
      throw std::invalid_argument("polariser transmission " + std::to_string(transmission[i]) + " at " +
                                  std::to_string(spectral::grid_wavelength_nm(i)) + " nm is outside (0, 1]");
  LedLibrary library = unpolarised;
  library.source = unpolarised.source + " through polariser";
  for (LedRecord& led : library.leds)
    for (LedSpectrumSample& rung : led.ladder) rung.spectrum *= transmission;
  return library;
}

std::map<drivers::Polarisation, MixSummary> solve_mix_per_state(
    const PolarisedLedLibraries& libraries, const std::function<MixTarget(const LedLibrary&)>& target_for,
    const MixSolverOptions& options) {
  std::map<drivers::Polarisation, MixSummary> mixes;
  for (drivers::Polarisation state :
       {drivers::Polarisation::kUnpolarised, drivers::Polarisation::kCross, drivers::Polarisation::kParallel}) {
    const std::optional<LedLibrary>& library = library_slot(libraries, state);
    if (library) mixes.emplace(state, solve_mix(*library, target_for(*library), options));
  }
  return mixes;
}

}  // namespace chromo::calibration
