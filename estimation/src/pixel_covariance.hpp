#pragma once
// Internal to estimation/: one pixel's total channel covariance
//   Σ = diag(v) + diag(a) Σ_ū diag(a)
// v the camera noise plus the table's model error per channel (the fit
// weights' variance without the discrepancy), a the pixel's albedo, Σ_ū the
// learned discrepancy in the plan's channels (model_discrepancy.hpp; empty:
// none). Factored once per pixel (Cholesky); every χ² and the parameter
// covariance of that pixel use it. Sizes up to kMaxChannels live on the
// stack; a larger plan keeps the diagonal of the discrepancy only.

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace chromo::estimation::detail {

class PixelCovariance {
 public:
  static constexpr int kMaxChannels = 32;
  using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxChannels, kMaxChannels>;
  using Vector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxChannels, 1>;

  // variance: `channels` values. discrepancy: channels × channels, or empty.
  PixelCovariance(const double* variance, const Eigen::MatrixXd& discrepancy, int channels);

  // rᵀ Σ⁻¹ r for a residual r (channels values).
  double chi2(const double* residual) const;
  // Jᵀ Σ⁻¹ J for the table's Jacobian (row-major, 4 values per channel).
  Eigen::Matrix4d information(const double* jacobian) const;
  // Jᵀ Σ⁻¹ r (half the gradient of rᵀ Σ⁻¹ r along the table's grid).
  Eigen::Vector4d gradient(const double* jacobian, const double* residual) const;

 private:
  int channels_ = 0;
  bool full_ = false;
  Vector diagonal_;               // !full_: Σ's diagonal
  Eigen::LLT<Matrix> cholesky_;   // full_
};

}  // namespace chromo::estimation::detail
