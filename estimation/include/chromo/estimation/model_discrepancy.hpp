#pragma once
// The skin model's discrepancy on real skin: how far the 4D model's best
// full-spectrum fit stays from measured skin spectra, learned from those
// spectra and turned, for any plan, into a covariance in its channels
// (docs/estimation.md, "Real skin: the model's discrepancy").
//
// Why: on skin rendered by the model itself the channels fit up to the
// camera noise; on real skin the best 4D fit of the whole spectrum still
// misses by about 0.2 ΔE94 under D65 (the NIST forearms), which a
// well-exposed capture resolves. Treated as noise-free, that shortfall flags
// ordinary skin. The estimator adds it to the camera noise wherever it
// weighs a residual (estimator.hpp).
//
// The statistic. For each training spectrum R_i, fit_spectrum (4D, its
// default weighting) gives F_i; the residual r_i(λ) = R_i − F_i (albedo
// units) on the 81-sample grid. Σ_r = the second moment of r about zero
// over the subjects (a shared bias counts as discrepancy too), shrunk towards
// its diagonal with the Schäfer-Strimmer estimate of the optimal weight λ*
// (Schäfer & Strimmer 2005, target "D": the correlations shrunk towards 0,
// the variances kept): 50 subjects estimate an 81 × 81 matrix.
// Absolute, not relative: on the NIST forearms the residual's size barely
// depends on the skin's lightness (RMS over 430-680 nm: median 0.0081, max
// 0.0133; the two darkest subjects 0.0080 and 0.0053), while the relative
// residual of those two (0.052, 0.057) is 2.5× the median (0.021); a
// statistic relative to the albedo flagged them whole when they were held
// out (docs/estimation.md "Real skin").
// In a plan's channels (MeasurementSet) channel c sees Σ_λ w_c(λ) R(λ), so
// its discrepancy covariance is Σ_disc = W Σ_r Wᵀ (W = MeasurementSet::weights()),
// the same for every pixel.
//
// Thread rules: a ModelDiscrepancy is immutable; every function is reentrant.

#include <Eigen/Core>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "chromo/estimation/measurement.hpp"
#include "chromo/estimation/spectrum_fit.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::estimation {

// One measured skin albedo spectrum with its name ("subject_017").
struct NamedSpectrum {
  std::string name;
  spectral::Spectrum albedo;
};

// The NIST forearm spectra shipped with the library (data/skin_reflectance_nist.csv,
// subjects 001-050, the mean of each subject's three repeats), on the grid.
const std::vector<NamedSpectrum>& nist_forearm_spectra();

// A spectrum's best 4D full-spectrum fit and its residual r(λ).
struct SpectrumResidual {
  std::string name;
  spectral::Spectrum fitted;
  spectral::Spectrum residual;  // measured − fitted, albedo units
};

// Fits every spectrum (fit_spectrum with `options`) on `threads` threads
// (0: all cores); the order of `spectra` is kept. Throws as fit_spectrum.
std::vector<SpectrumResidual> fit_residuals(std::span<const NamedSpectrum> spectra, const SpectrumFitOptions& options = {},
                                            int threads = 0);

// The residuals of nist_forearm_spectra() as shipped in
// data/skin_model_residuals.csv (written by `chromo discrepancy learn`; a
// test refits subjects and compares).
const std::vector<SpectrumResidual>& nist_forearm_residuals();
// The CSV of residuals: wavelength_nm, then fitted_<name> and residual_<name> per spectrum.
std::string residuals_csv(std::span<const SpectrumResidual> residuals, const std::string& provenance);
// Parses residuals_csv's format; throws std::invalid_argument naming the problem.
std::vector<SpectrumResidual> parse_residuals_csv(std::string_view text, const std::string& source);

class ModelDiscrepancy {
 public:
  // Learns the statistic of the header from residuals (at least 3; std::invalid_argument otherwise).
  static ModelDiscrepancy learn(std::span<const SpectrumResidual> residuals);
  // Learned from every shipped NIST residual: what chromod and `chromo estimate` use by default.
  static std::shared_ptr<const ModelDiscrepancy> standard();

  // Σ_disc = W Σ_r Wᵀ: the covariance in the set's channels (C × C, albedo² units, symmetric, positive semi-definite).
  Eigen::MatrixXd channel_covariance(const MeasurementSet& set) const;

  int subjects() const { return subjects_; }
  double shrinkage() const { return shrinkage_; }                   // λ* in [0, 1]
  const Eigen::MatrixXd& covariance() const { return covariance_; }  // Σ_r, 81 × 81
  spectral::Spectrum sigma() const;                                  // √diag(Σ_r), albedo units
  const spectral::Spectrum& mean_fitted() const { return mean_fitted_; }  // the fits' mean, for reports
  // μ_d: the residuals' mean spectrum (albedo units); and Σ_d, their covariance
  // about μ_d, shrunk the same way (81 × 81): the Gaussian the relit layer's
  // posterior discrepancy uses (discrepancy_posterior.hpp). The χ² keeps Σ_r.
  const spectral::Spectrum& mean_residual() const { return mean_residual_; }
  const Eigen::MatrixXd& centred_covariance() const { return centred_covariance_; }
  // The training residuals r_i, one row per subject (subjects() × 81, albedo
  // units): what discrepancy_calibration.hpp's nested cross-validation splits.
  const Eigen::MatrixXd& training_residuals() const { return residuals_; }

 private:
  Eigen::MatrixXd residuals_;
  Eigen::MatrixXd covariance_;
  Eigen::MatrixXd centred_covariance_;
  spectral::Spectrum mean_residual_ = spectral::Spectrum::constant(0);
  spectral::Spectrum mean_fitted_;
  int subjects_ = 0;
  double shrinkage_ = 0;
};

}  // namespace chromo::estimation
