#include "appearance_order.hpp"

#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>
#include <limits>

#include "chromo/estimation/channel_buffer.hpp"

namespace chromo::estimation::detail {

double appearance_uncertainty(const ForwardTable& table, const AppearanceTable& appearance, const double* weight,
                              const double* camera_variance, const GridPoint& x4, double* lab4) {
  constexpr int kLab = AppearanceTable::kChannels;
  const int channels = table.channels();
  ChannelBuffer<double> value(channels), jacobian(channels * 4);
  table.predict(x4, value, jacobian);
  Eigen::Matrix4d a = Eigen::Matrix4d::Zero(), b = Eigen::Matrix4d::Zero();
  for (int c = 0; c < channels; ++c) {
    const Eigen::Map<const Eigen::Vector4d> j(jacobian.data() + 4 * c);
    const double w2 = weight[c] * weight[c];
    const Eigen::Matrix4d jj = j * j.transpose();
    a += w2 * jj;
    b += w2 * w2 * camera_variance[c] * jj;
  }
  double g[kLab * 4];
  appearance.lab(x4, lab4, g);
  // Scale A to a unit diagonal so that the singularity check does not depend
  // on the units of the grid axes or the weights.
  Eigen::Vector4d scale;
  for (int k = 0; k < 4; ++k) {
    if (!(a(k, k) > 0)) return std::numeric_limits<double>::infinity();
    scale(k) = 1 / std::sqrt(a(k, k));
  }
  const Eigen::Matrix4d unit = scale.asDiagonal() * a * scale.asDiagonal();
  Eigen::Matrix4d unit_inverse;
  bool invertible = false;
  double determinant = 0;
  unit.computeInverseAndDetWithCheck(unit_inverse, determinant, invertible, 1e-12);
  if (!invertible || !(determinant > 1e-12)) return std::numeric_limits<double>::infinity();
  const Eigen::Matrix4d a_inverse = scale.asDiagonal() * unit_inverse * scale.asDiagonal();
  const Eigen::Matrix4d covariance = a_inverse * b * a_inverse;
  double sum = 0;
  for (int l = 0; l < AppearanceTable::kIlluminants; ++l) {
    double variance = 0;
    for (int i = 3 * l; i < 3 * l + 3; ++i) {
      const Eigen::Map<const Eigen::Vector4d> row(g + 4 * i);
      variance += row.dot(covariance * row);
    }
    sum += std::sqrt(std::max(variance, 0.0));
  }
  return sum / AppearanceTable::kIlluminants;
}

double appearance_difference(const AppearanceTable& appearance, const double* lab4, const GridPoint& x2) {
  double lab2[AppearanceTable::kChannels];
  appearance.lab(x2, lab2);
  double sum = 0;
  for (int l = 0; l < AppearanceTable::kIlluminants; ++l) {
    const double dl = lab2[3 * l] - lab4[3 * l], da = lab2[3 * l + 1] - lab4[3 * l + 1],
                 db = lab2[3 * l + 2] - lab4[3 * l + 2];
    sum += std::sqrt(dl * dl + da * da + db * db);
  }
  return sum / AppearanceTable::kIlluminants;
}

}  // namespace chromo::estimation::detail
