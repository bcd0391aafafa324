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

#include "chromo/spectral/spectrum.hpp"

namespace chromo::simulators {

class SphereIllumination {
 public:
  virtual ~SphereIllumination() = default;
  // On the project grid (5 nm bins, MODEL.md's rule applied to the true fine spectrum).
  virtual spectral::Spectrum irradiance_now() const = 0;
  // At any wavelength (nm), from the true fine-resolution spectra: what a
  // spectrometer pixel at that wavelength sees.
  virtual double irradiance_at_nm(double wavelength_nm) const = 0;
};

}  // namespace chromo::simulators
