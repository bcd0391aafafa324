#pragma once
// ReferenceLamp: the virtual lab's tungsten-halogen calibration lamp, mounted
// in a port of the sphere. Its spectral irradiance is Planck's law at
// `colour_temperature_K`, scaled so that it is `peak_irradiance` at its
// maximum over 380-780 nm (SphereIllumination units). A real lamp is taken as
// a Planckian radiator at its stated colour temperature; here it is exactly
// one, so the spectrometer's response calibration can be checked against
// truth. Planck's law is evaluated here independently of calibration/.
//
// SummedIllumination adds several sources (the lamp and the LED lab): what a
// spectrometer looking into the sphere sees. It holds references: the
// sources must outlive it.
//
// Thread rules: every method may be called from any thread.

#include <atomic>
#include <vector>

#include "chromo/simulators/sphere_illumination.hpp"

namespace chromo::simulators {

class ReferenceLamp final : public SphereIllumination {
 public:
  explicit ReferenceLamp(double colour_temperature_K = 3000.0, double peak_irradiance = 0.8);

  void set_on(bool on) { on_.store(on); }
  bool on() const { return on_.load(); }
  double colour_temperature_K() const { return colour_temperature_K_; }

  spectral::Spectrum irradiance_now() const override;
  double irradiance_at_nm(double wavelength_nm) const override;

 private:
  double planck_relative(double wavelength_nm) const;
  double colour_temperature_K_;
  double scale_ = 1;
  std::atomic<bool> on_{false};
};

class SummedIllumination final : public SphereIllumination {
 public:
  explicit SummedIllumination(std::vector<const SphereIllumination*> sources) : sources_(std::move(sources)) {}
  spectral::Spectrum irradiance_now() const override;
  double irradiance_at_nm(double wavelength_nm) const override;

 private:
  std::vector<const SphereIllumination*> sources_;
};

}  // namespace chromo::simulators
