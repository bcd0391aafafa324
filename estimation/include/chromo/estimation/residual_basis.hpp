#pragma once
// Past the model's floor: the part of a real skin's spectrum that the 4D
// model cannot produce, predicted from what a many-channel plan measured.
//
// Learned from training pixels (real spectra of subjects other than the ones
// it will be used on): each gives the pixel's channel residual d (measured
// channels − the plan's channels of the model albedo at the estimated
// parameters, albedo units) and its spectral residual r(λ) (the true
// spectrum − that model albedo). The basis is the first `components` right
// singular vectors of the r's (uncentred, so the mean residual is in it); each
// training r's coefficients c = Bᵀ r are regressed on [d, 1] by ridge least
// squares. Used on a new pixel, coefficients(d) = G·[d, 1] and correction(c)
// = B·c; the corrected appearance is model albedo + correction.
//
// Only meaningful where the plan has more channels than the model has
// parameters (the residual of a 4-channel fit of 4 parameters is ~0): the
// caller decides; learn() only needs at least one channel. The chromophore
// maps stay the model's: this is an appearance correction, labelled as such
// wherever it is offered (docs/estimation.md, "Past the model's floor").
//
// Typed, in-process: no file format (a learned basis is rebuilt from its
// training data; the bench does so per fold).

#include <span>
#include <vector>

#include <Eigen/Core>

#include "chromo/spectral/spectrum.hpp"

namespace chromo::estimation {

struct ResidualSample {
  Eigen::VectorXd channel_residual;  // measured − predicted, one per channel, albedo units
  spectral::Spectrum spectral_residual;  // true albedo − model albedo at the fitted parameters
};

struct ResidualBasisOptions {
  int components = 3;            // basis spectra kept, 1-20
  double ridge_relative = 1e-3;  // ridge λ = ridge_relative × trace(XᵀX)/columns
};

class ResidualBasis {
 public:
  // Throws std::invalid_argument naming the problem: no samples, a sample
  // whose channel count differs from the first's or is 0, a non-finite
  // value, components outside 1-20 or more than the samples, ridge < 0.
  static ResidualBasis learn(std::span<const ResidualSample> samples, const ResidualBasisOptions& options = {});

  int components() const { return static_cast<int>(basis_.cols()); }
  int channels() const { return static_cast<int>(regression_.cols()) - 1; }
  // Basis spectrum k (unit norm over the 81 samples).
  spectral::Spectrum basis_spectrum(int k) const;
  // The share of the training residuals' energy (Σ r²) the basis holds, 0-1.
  double energy_share() const { return energy_share_; }

  // Coefficients predicted from one pixel's channel residual; throws
  // std::invalid_argument when its size is not channels().
  Eigen::VectorXd coefficients(std::span<const double> channel_residual) const;
  // Σ c_k · basis_k(λ); throws std::invalid_argument when c.size() != components().
  spectral::Spectrum correction(const Eigen::VectorXd& coefficients) const;

 private:
  Eigen::MatrixXd basis_;       // kGridSize × components, orthonormal columns
  Eigen::MatrixXd regression_;  // components × (channels + 1), last column the intercept
  double energy_share_ = 0;
};

}  // namespace chromo::estimation
