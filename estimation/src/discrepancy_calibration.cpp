#include "chromo/estimation/discrepancy_calibration.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <stdexcept>
#include <string>

#include "chromo/estimation/estimator.hpp"
#include "chromo/spectral/grid.hpp"

namespace chromo::estimation {

namespace {

// The q-quantile of sorted values (linear between order statistics).
double sorted_quantile(std::vector<double> values, double q) {
  std::sort(values.begin(), values.end());
  const double at = q * static_cast<double>(values.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(at);
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (at - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

// ModelDiscrepancy::learn on the rows of `u` outside inner fold `fold`.
ModelDiscrepancy learn_without_fold(const Eigen::MatrixXd& u, int folds, int fold) {
  std::vector<SpectrumResidual> train;
  for (int i = 0; i < u.rows(); ++i) {
    if (i % folds == fold) continue;
    SpectrumResidual r;
    r.fitted = spectral::Spectrum::constant(1);  // unused by the covariance
    for (int k = 0; k < spectral::kGridSize; ++k) r.residual[k] = u(i, k);
    train.push_back(std::move(r));
  }
  return ModelDiscrepancy::learn(train);
}

}  // namespace

DiscrepancyCalibration calibrate_discrepancy_scale(const ModelDiscrepancy& discrepancy, const Eigen::MatrixXd& weights,
                                                   const DiscrepancyCalibrationOptions& options) {
  const Eigen::MatrixXd& u = discrepancy.training_residuals();
  const int n = static_cast<int>(u.rows());
  if (options.folds < 2 || n < 2 * options.folds)
    throw std::invalid_argument("discrepancy calibration: " + std::to_string(options.folds) + " inner folds need at least " +
                                std::to_string(2 * std::max(options.folds, 2)) + " training subjects, the discrepancy holds " +
                                std::to_string(n));
  if (!(options.quantile > 0 && options.quantile < 1))
    throw std::invalid_argument("discrepancy calibration: the quantile must be in (0, 1), not " + std::to_string(options.quantile));
  if (weights.cols() != spectral::kGridSize || weights.rows() < 1)
    throw std::invalid_argument("discrepancy calibration: the weights must be C x " + std::to_string(spectral::kGridSize) +
                                ", not " + std::to_string(weights.rows()) + " x " + std::to_string(weights.cols()));
  DiscrepancyCalibration out;
  out.held_out_d2.assign(static_cast<std::size_t>(n), 0.0);
  for (int fold = 0; fold < options.folds; ++fold) {
    const Eigen::MatrixXd sigma = weights * learn_without_fold(u, options.folds, fold).covariance() * weights.transpose();
    const Eigen::LDLT<Eigen::MatrixXd> factor(sigma);
    for (int i = fold; i < n; i += options.folds) {
      const Eigen::VectorXd r = weights * u.row(i).transpose();
      out.held_out_d2[static_cast<std::size_t>(i)] = r.dot(factor.solve(r));
    }
  }
  out.held_out_quantile = sorted_quantile(out.held_out_d2, options.quantile);
  out.expected_quantile = chi_squared_quantile(options.quantile, static_cast<int>(weights.rows()));
  out.scale = std::max(1.0, out.held_out_quantile / out.expected_quantile);
  return out;
}

}  // namespace chromo::estimation
