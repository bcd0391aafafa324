#include "chromo/estimation/discrepancy_posterior.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>

namespace chromo::estimation {

DiscrepancyPosterior::DiscrepancyPosterior(const ModelDiscrepancy& discrepancy, const MeasurementSet& set,
                                           DiscrepancyPrior prior) {
  const Eigen::MatrixXd w = set.weights();
  const bool centred = prior == DiscrepancyPrior::kMeanAndCovariance;
  const Eigen::MatrixXd& covariance = centred ? discrepancy.centred_covariance() : discrepancy.covariance();
  mean_ = centred ? Eigen::VectorXd(discrepancy.mean_residual().values().matrix())
                  : Eigen::VectorXd::Zero(spectral::kGridSize);
  gain_ = covariance * w.transpose();
  seen_ = w * gain_;
  seen_mean_ = w * mean_;
}

spectral::Spectrum DiscrepancyPosterior::mean(std::span<const double> channel_residual,
                                              std::span<const double> noise_variance) const {
  const int c = channels();
  if (static_cast<int>(channel_residual.size()) != c || static_cast<int>(noise_variance.size()) != c)
    throw std::invalid_argument("posterior discrepancy: expected " + std::to_string(c) + " channel residuals and variances, got " +
                                std::to_string(channel_residual.size()) + " and " + std::to_string(noise_variance.size()));
  Eigen::MatrixXd total = seen_;
  Eigen::VectorXd innovation(c);
  for (int k = 0; k < c; ++k) {
    if (!std::isfinite(channel_residual[k]) || !std::isfinite(noise_variance[k]) || noise_variance[k] < 0)
      throw std::invalid_argument("posterior discrepancy: channel " + std::to_string(k) +
                                  " has a non-finite residual or a negative or non-finite noise variance");
    total(k, k) += noise_variance[k];
    innovation(k) = channel_residual[k] - seen_mean_(k);
  }
  // LDLT: W Σ_d Wᵀ is only semi-definite where channels see the same light; N makes it definite.
  const Eigen::VectorXd spectrum = mean_ + gain_ * total.ldlt().solve(innovation);
  spectral::Spectrum out;
  for (int k = 0; k < spectral::kGridSize; ++k) out[k] = spectrum(k);
  return out;
}

}  // namespace chromo::estimation
