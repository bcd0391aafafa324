#include "chromo/estimation/residual_basis.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/SVD>

namespace chromo::estimation {

ResidualBasis ResidualBasis::learn(std::span<const ResidualSample> samples, const ResidualBasisOptions& options) {
  if (samples.empty()) throw std::invalid_argument("residual basis: no training samples");
  if (options.components < 1 || options.components > 20)
    throw std::invalid_argument("residual basis: components must be 1-20, not " + std::to_string(options.components));
  if (static_cast<std::size_t>(options.components) > samples.size())
    throw std::invalid_argument("residual basis: " + std::to_string(options.components) + " components need at least as many samples, got " +
                                std::to_string(samples.size()));
  if (!(options.ridge_relative >= 0)) throw std::invalid_argument("residual basis: ridge_relative must be >= 0");
  const Eigen::Index channels = samples.front().channel_residual.size();
  if (channels == 0) throw std::invalid_argument("residual basis: sample 0 has no channels");
  const Eigen::Index n = static_cast<Eigen::Index>(samples.size());
  Eigen::MatrixXd r(n, spectral::kGridSize), x(n, channels + 1);
  for (Eigen::Index i = 0; i < n; ++i) {
    const ResidualSample& s = samples[i];
    if (s.channel_residual.size() != channels)
      throw std::invalid_argument("residual basis: sample " + std::to_string(i) + " has " + std::to_string(s.channel_residual.size()) +
                                  " channels, sample 0 has " + std::to_string(channels));
    if (!s.channel_residual.allFinite() || !s.spectral_residual.values().allFinite())
      throw std::invalid_argument("residual basis: sample " + std::to_string(i) + " holds a non-finite value");
    r.row(i) = s.spectral_residual.values().matrix().transpose();
    x.row(i) << s.channel_residual.transpose(), 1.0;
  }
  ResidualBasis out;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(r, Eigen::ComputeThinV);
  out.basis_ = svd.matrixV().leftCols(options.components);
  const Eigen::VectorXd s2 = svd.singularValues().array().square();
  out.energy_share_ = s2.sum() > 0 ? s2.head(options.components).sum() / s2.sum() : 1.0;
  const Eigen::MatrixXd c = r * out.basis_;  // n × components
  Eigen::MatrixXd xtx = x.transpose() * x;
  const double lambda = options.ridge_relative * xtx.diagonal().head(channels).mean();
  xtx.diagonal().head(channels).array() += lambda;  // the intercept is not shrunk
  out.regression_ = xtx.ldlt().solve(x.transpose() * c).transpose();
  return out;
}

spectral::Spectrum ResidualBasis::basis_spectrum(int k) const {
  if (k < 0 || k >= components()) throw std::invalid_argument("residual basis: no basis spectrum " + std::to_string(k));
  return spectral::Spectrum(basis_.col(k).array());
}

Eigen::VectorXd ResidualBasis::coefficients(std::span<const double> channel_residual) const {
  if (static_cast<int>(channel_residual.size()) != channels())
    throw std::invalid_argument("residual basis: a pixel of " + std::to_string(channel_residual.size()) + " channels, the basis was learned on " +
                                std::to_string(channels()));
  const Eigen::Map<const Eigen::VectorXd> d(channel_residual.data(), channels());
  return regression_.leftCols(channels()) * d + regression_.col(channels());
}

spectral::Spectrum ResidualBasis::correction(const Eigen::VectorXd& coefficients) const {
  if (coefficients.size() != components())
    throw std::invalid_argument("residual basis: " + std::to_string(coefficients.size()) + " coefficients for a basis of " +
                                std::to_string(components()));
  return spectral::Spectrum((basis_ * coefficients).array());
}

}  // namespace chromo::estimation
