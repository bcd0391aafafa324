#include "chromo/estimation/parameter_prior.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "chromo/estimation/model_discrepancy.hpp"

namespace chromo::estimation {

Eigen::Vector4d ParameterPrior::coordinates(const SkinParameters& p) {
  return {std::log(p.cm), std::log(p.ch), p.bm, p.che};
}

ParameterPrior ParameterPrior::learn(std::span<const SkinParameters> fits, double widen) {
  const int n = static_cast<int>(fits.size());
  if (n < 5) throw std::invalid_argument("ParameterPrior::learn: needs at least 5 parameter sets, got " + std::to_string(n));
  if (!(widen >= 1)) throw std::invalid_argument("ParameterPrior::learn: widen must be >= 1");
  Eigen::Matrix<double, Eigen::Dynamic, 4> u(n, 4);
  for (int i = 0; i < n; ++i) {
    const SkinParameters& p = fits[static_cast<std::size_t>(i)];
    if (!(p.cm > 0) || !(p.ch > 0) || !std::isfinite(p.bm) || !std::isfinite(p.che) || !std::isfinite(p.cm) ||
        !std::isfinite(p.ch))
      throw std::invalid_argument("ParameterPrior::learn: parameter set " + std::to_string(i) +
                                  " is not finite with Cm, Ch > 0");
    u.row(i) = coordinates(p).transpose();
  }
  ParameterPrior prior;
  prior.subjects_ = n;
  prior.mean_ = u.colwise().mean().transpose();
  const Eigen::Matrix<double, Eigen::Dynamic, 4> centred = u.rowwise() - prior.mean_.transpose();
  Eigen::Vector4d scale;
  for (int k = 0; k < 4; ++k) scale(k) = std::sqrt(std::max(centred.col(k).squaredNorm() / (n - 1), 1e-12));
  const Eigen::Matrix<double, Eigen::Dynamic, 4> z = centred * scale.cwiseInverse().asDiagonal();
  const Eigen::Matrix4d r = z.transpose() * z / (n - 1);
  // Schäfer-Strimmer λ* for the target "correlations 0" (model_discrepancy.cpp's estimate).
  double variance_sum = 0, square_sum = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) {
      const Eigen::ArrayXd w = z.col(i).array() * z.col(j).array();
      variance_sum += (w - w.mean()).square().sum() * n / std::pow(static_cast<double>(n - 1), 3);
      square_sum += r(i, j) * r(i, j);
    }
  prior.shrinkage_ = square_sum > 0 ? std::clamp(variance_sum / square_sum, 0.0, 1.0) : 1.0;
  Eigen::Matrix4d shrunk = (1 - prior.shrinkage_) * r;
  shrunk.diagonal().setOnes();
  const Eigen::Vector4d widened = widen * scale;
  prior.covariance_ = widened.asDiagonal() * shrunk * widened.asDiagonal();
  prior.information_ = prior.covariance_.inverse();
  return prior;
}

double ParameterPrior::penalty(const SkinParameters& p) const {
  const Eigen::Vector4d d = coordinates(p) - mean_;
  return d.dot(information_ * d);
}

}  // namespace chromo::estimation
