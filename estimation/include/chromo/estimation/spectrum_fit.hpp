#pragma once
// Fitting the skin model to one measured reflectance spectrum (contact
// spectrophotometer), for `chromo fit-spectrum` and model validation.
//
// Objective (weights justified in docs/estimation.md "Fitting measured spectra";
// the whole sweep of weightings and σ: docs/estimation-notes.md section 3):
//   cost = Σ_λ w_λ² ((model_λ + specular − measured_λ) / spectral_sigma)² / Σ_λ w_λ²
//        + (ΔE94(measured, model) under D65 / lab_sigma)²
// with w_λ from SpectralWeighting (default: the colour-forming band).
// minimised with Ceres (bounded trust region, numeric derivatives of the pinned
// forward model) from the best few of a coarse grid of starting points. The
// spectral term keeps the spectrum's shape (so the fit carries over to other
// illuminants); the CIELAB term makes it match what an eye sees under D65.
// With specular_included (8°/hemispherical instruments that include the
// specular component, like the NIST set) the Fresnel reflectance of the
// skin-air surface at normal incidence, ((η−1)/(η+1))² = 0.0278 at η = 1.4,
// is added to the model's albedo (MODEL.md).
//
// Thread rules: fit_spectrum is reentrant; call it from any thread.

#include <string>
#include <vector>

#include "chromo/estimation/skin_parameters.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::estimation {

// How the spectral term weighs wavelengths. kFlat: every 5 nm sample alike.
// kColourBand (default): sample λ's squared error weighted by
// (x̄ + ȳ + z̄)(λ) · Ē(λ), Ē the mean relative power of the illuminants the fit
// is reported under (D65, A, the six LED types, each scaled to unit sum): an
// error counts as much as it can move a colour under those lights, so the fit
// does not spend its freedom on 380-400 or 700-780 nm where no reported colour
// is formed (docs/estimation.md). Normalised to a mean squared weight of 1,
// so that spectral_sigma keeps its meaning.
enum class SpectralWeighting { kFlat, kColourBand };

struct SpectrumFitOptions {
  int order = 4;                   // 4 or 2 (βm = 0.7, Che = 0)
  bool specular_included = false;
  bool free_specular = false;      // fit the surface constant (0-0.1) instead of fixing it
  double spectral_sigma = 0.01;    // reflectance units
  double lab_sigma = 0.55;         // ΔE94 units (docs/estimation-notes.md section 3: the weights and what they give)
  double spectral_min_nm = 380, spectral_max_nm = 780;  // wavelengths of the spectral term
  SpectralWeighting spectral_weighting = SpectralWeighting::kColourBand;
  int starts = 3;                  // Ceres runs from the best coarse-grid nodes
  bool IsValid(std::string* error) const;
};

struct SpectrumFitResult {
  SkinParameters parameters;
  double specular = 0;             // constant added to the model's albedo
  spectral::Spectrum fitted;       // model albedo + specular
  double rms = 0;                  // RMS spectral difference, reflectance units
  double de94_d65 = 0, de94_a = 0;
  double de94_led[6] = {};         // W57, W40, W27, R, G, B (spectral::kAllLedTypes order)
  double de94_led_mean = 0;
  double cost = 0;
  std::string solver_report;       // Ceres' brief report of the best run
};

// Fresnel reflectance at normal incidence for η = kSkinRefractiveIndex.
double surface_reflectance();

// The measured reflectance factor's accepted range.
inline constexpr double kMinFitReflectance = -0.1, kMaxFitReflectance = 1.5;
// Throws std::invalid_argument for invalid options, a non-finite spectrum or
// one outside [kMinFitReflectance, kMaxFitReflectance].
SpectrumFitResult fit_spectrum(const spectral::Spectrum& measured, const SpectrumFitOptions& options = {});

}  // namespace chromo::estimation
