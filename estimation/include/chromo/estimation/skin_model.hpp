#pragma once
// SkinModel: the pinned forward model of MODEL.md, parameters → diffuse albedo
// spectrum on the 380-780 nm grid.
//
// Contract:
//  - albedo() evaluates one parameter set; albedo_batch() many, on up to
//    `threads` threads (0 = all cores). Both give bit-identical results for
//    the same parameters.
//  - Parameters are NOT range-checked here (lookup tables and solvers probe
//    the edges); callers that take user input check range_violation() first.
//    Non-finite parameters give non-finite albedo, never a crash.
//  - A SkinModel is immutable after construction and safe to share between
//    threads. Construction computes the wavelength-only terms once.

#include <span>

#include "chromo/estimation/chromophores.hpp"
#include "chromo/estimation/skin_parameters.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::estimation {

// The per-layer quantities behind one albedo, for inspection and for the
// renderer profiles: epidermis R1, T1 (light entering from the surface) and
// dermis R2.
struct LayerSpectra {
  spectral::Spectrum epidermis_reflectance;
  spectral::Spectrum epidermis_transmittance;
  spectral::Spectrum dermis_reflectance;
  spectral::Spectrum albedo;
};

class SkinModel {
 public:
  SkinModel();

  spectral::Spectrum albedo(const SkinParameters& parameters) const;
  LayerSpectra layers(const SkinParameters& parameters) const;

  // out.size() must equal parameters.size() (std::invalid_argument otherwise).
  void albedo_batch(std::span<const SkinParameters> parameters, std::span<spectral::Spectrum> out,
                    int threads = 0) const;

  const ChromophoreSpectra& chromophores() const { return chromophores_; }

 private:
  ChromophoreSpectra chromophores_;
  double skin_air_a_;  // A at η = 1.4
};

}  // namespace chromo::estimation
