#include "pixel_covariance.hpp"

namespace chromo::estimation::detail {

PixelCovariance::PixelCovariance(const double* variance, const Eigen::MatrixXd& discrepancy, int channels)
    : channels_(channels) {
  const bool has_discrepancy = discrepancy.rows() == channels && channels > 0;
  full_ = has_discrepancy && channels <= kMaxChannels;
  if (!full_) {
    diagonal_.resize(channels);
    for (int c = 0; c < channels; ++c) diagonal_(c) = variance[c] + (has_discrepancy ? discrepancy(c, c) : 0.0);
    return;
  }
  Matrix sigma = discrepancy;
  for (int c = 0; c < channels; ++c) sigma(c, c) += variance[c];
  cholesky_.compute(sigma);
}

double PixelCovariance::chi2(const double* residual) const {
  if (!full_) {
    double sum = 0;
    for (int c = 0; c < channels_; ++c) sum += residual[c] * residual[c] / diagonal_(c);
    return sum;
  }
  Vector r = Eigen::Map<const Eigen::VectorXd>(residual, channels_);
  cholesky_.matrixL().solveInPlace(r);
  return r.squaredNorm();
}

Eigen::Matrix4d PixelCovariance::information(const double* jacobian) const {
  using Jacobian = Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor, kMaxChannels, 4>;
  if (!full_) {
    Eigen::Matrix4d info = Eigen::Matrix4d::Zero();
    for (int c = 0; c < channels_; ++c) {
      const Eigen::Map<const Eigen::Vector4d> j(jacobian + 4 * c);
      info.noalias() += (j / diagonal_(c)) * j.transpose();
    }
    return info;
  }
  Jacobian j = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor>>(jacobian, channels_, 4);
  cholesky_.matrixL().solveInPlace(j);
  return j.transpose() * j;
}

Eigen::Vector4d PixelCovariance::gradient(const double* jacobian, const double* residual) const {
  using Jacobian = Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor, kMaxChannels, 4>;
  if (!full_) {
    Eigen::Vector4d g = Eigen::Vector4d::Zero();
    for (int c = 0; c < channels_; ++c) g += Eigen::Map<const Eigen::Vector4d>(jacobian + 4 * c) * (residual[c] / diagonal_(c));
    return g;
  }
  Jacobian j = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor>>(jacobian, channels_, 4);
  Vector r = Eigen::Map<const Eigen::VectorXd>(residual, channels_);
  cholesky_.matrixL().solveInPlace(j);
  cholesky_.matrixL().solveInPlace(r);
  return j.transpose() * r;
}

}  // namespace chromo::estimation::detail
