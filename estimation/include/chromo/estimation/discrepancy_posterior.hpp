#pragma once
// The relit layer "model + discrepancy": the skin model's shortfall on real
// skin, estimated per pixel from what the plan's channels left after the fit
// (docs/estimation.md, "Relighting past the model: the posterior
// discrepancy").
//
// The learned discrepancy (model_discrepancy.hpp) is a Gaussian over
// spectra: mean μ_d, covariance Σ_d (about μ_d, shrunk). A pixel's channel
// residual after its fit, r = measured − W·model albedo (W the plan's
// weights, MeasurementSet::weights()), sees it through the channels with
// the camera noise N = diag(noise variances). Its posterior mean spectrum
//   d̂ = μ_d + Σ_d Wᵀ (W Σ_d Wᵀ + N)⁻¹ (r − W μ_d)
// is what the relit output adds to the model's albedo.
//
// Two priors (DiscrepancyPrior):
//  kMeanAndCovariance  μ_d and Σ_d as above: a pixel whose channels the fit
//                      matched exactly still gets the part of μ_d its
//                      channels cannot see (on skin the model renders
//                      exactly, that part is an error);
//  kZeroMean           μ = 0 and Σ_r, the second moment about zero (the χ²'s
//                      statistic): nothing is added where the channels show
//                      no residual, so skin the model explains is left as it
//                      is; a shared bias is then learned only as far as the
//                      channels show it. The parameters stay
// the model's (MODEL.md is pinned): this changes appearance only.
//
// Thread rules: immutable after construction; every function is reentrant.

#include <span>

#include <Eigen/Core>

#include "chromo/estimation/measurement.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::estimation {

enum class DiscrepancyPrior { kMeanAndCovariance, kZeroMean };

class DiscrepancyPosterior {
 public:
  // The discrepancy as seen by `set`'s channels (precomputed once per plan).
  DiscrepancyPosterior(const ModelDiscrepancy& discrepancy, const MeasurementSet& set,
                       DiscrepancyPrior prior = DiscrepancyPrior::kZeroMean);

  int channels() const { return static_cast<int>(seen_.rows()); }
  // d̂ above. channel_residual: measured − W·model albedo, one per channel
  // (albedo units); noise_variance: the camera noise of each channel at
  // the pixel (≥ 0). Throws std::invalid_argument when either size is not
  // channels() or a value is not finite (a negative variance too).
  spectral::Spectrum mean(std::span<const double> channel_residual, std::span<const double> noise_variance) const;

 private:
  Eigen::VectorXd mean_;        // μ_d, 81
  Eigen::MatrixXd gain_;        // Σ_d Wᵀ, 81 × C
  Eigen::MatrixXd seen_;        // W Σ_d Wᵀ, C × C
  Eigen::VectorXd seen_mean_;   // W μ_d, C
};

}  // namespace chromo::estimation
