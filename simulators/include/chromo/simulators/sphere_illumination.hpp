#pragma once
// SphereIllumination: the ground truth of what the sphere emits at this
// moment, shared by the simulators of the virtual lab. The LED simulator
// (which knows the drive levels, temperatures, drift and faults) implements
// it; the spectrometer and camera simulators read it when they measure or
// expose. Never derived from a driver or from calibration: it is the truth
// those are tested against.
//
// Units: spectral irradiance at the sample plane in arbitrary but fixed units
// (W57 alone at full drive, warmed up, peaks near 1). Thread-safe: simulators
// call it from their own threads.

#include <optional>

#include "chromo/simulators/polarisation/polariser_optics.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::simulators {

// The irradiance of a sphere with polariser banks (docs/polarisation.md),
// split by the polarisation state the light leaves in: light of types driven
// cross, light of types driven parallel, and unpolarised light (types driven
// through both banks, and types without banks). The three add up to
// irradiance_now(); the films' transmission is already in them.
struct PolarisedIrradiance {
  spectral::Spectrum unpolarised, cross, parallel;
  PolariserFilm light_film;  // the film in front of the banks
};

class SphereIllumination {
 public:
  virtual ~SphereIllumination() = default;
  // On the project grid (5 nm bins, MODEL.md's rule applied to the true fine spectrum).
  virtual spectral::Spectrum irradiance_now() const = 0;
  // At any wavelength (nm), from the true fine-resolution spectra: what a
  // spectrometer pixel at that wavelength sees.
  virtual double irradiance_at_nm(double wavelength_nm) const = 0;
  // The same light split by polarisation state; none for a sphere without
  // polariser banks (the default: every illumination but such a sphere's).
  virtual std::optional<PolarisedIrradiance> polarised_irradiance_now() const { return std::nullopt; }
};

}  // namespace chromo::simulators
