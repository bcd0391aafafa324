#pragma once
// Wavelength-only optical coefficients of MODEL.md (seed equations 2-7), in
// mm^-1, as scalar functions (for checking by hand) and as grid spectra.

#include "chromo/spectral/spectrum.hpp"

namespace chromo::estimation {

double sigma_a_eumelanin_per_mm(double lambda_nm);    // 6.6e10 · λ^-3.33
double sigma_a_pheomelanin_per_mm(double lambda_nm);  // 2.9e14 · λ^-4.75
double sigma_a_baseline_per_mm(double lambda_nm);     // 0.0244 + 8.53 · exp(-(λ-154)/66.2)
double sigma_s_reduced_epidermis_per_mm(double lambda_nm);  // 14.74 · λ^-0.22 + 2.2e11 · λ^-4
double sigma_s_reduced_dermis_per_mm(double lambda_nm);     // 7.37 · λ^-0.22 + 1.1e11 · λ^-4
// Whole blood (150 g/L, 64,500 g/mol) from a molar extinction coefficient in
// cm^-1/M (Prahl): 2.303 · ε · 150 / 64500 / 10.
double blood_sigma_a_per_mm(double molar_extinction_per_cm_per_molar);

struct ChromophoreSpectra {
  spectral::Spectrum sigma_a_eumelanin;
  spectral::Spectrum sigma_a_pheomelanin;
  spectral::Spectrum sigma_a_baseline;
  spectral::Spectrum sigma_a_oxy_blood;    // from data/hemoglobin.csv, bin-averaged onto the grid
  spectral::Spectrum sigma_a_deoxy_blood;
  spectral::Spectrum sigma_a_blood;        // γ·oxy + (1-γ)·deoxy, γ = 0.75
  spectral::Spectrum sigma_s_reduced_epidermis;
  spectral::Spectrum sigma_s_reduced_dermis;
};

// Built once from the compiled-in hemoglobin table; thread-safe.
const ChromophoreSpectra& chromophore_spectra();

}  // namespace chromo::estimation
