#include "appearance_order.hpp"

#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>

#include "chromo/estimation/channel_buffer.hpp"

namespace chromo::estimation::detail {

double appearance_uncertainty(const ForwardTable& table, const AppearanceTable& appearance,
                              const double* camera_variance, const GridPoint& x4, AppearanceTable::Point& at4) {
  const int channels = table.channels();
  ChannelBuffer<double> value(channels), jacobian(channels * 4);
  table.predict(x4, value, jacobian);
  // Information of the data (Jᵀ V⁻¹ J) plus that of the box the fit is held
  // in: a uniform distribution over an axis of n − 1 grid units has variance
  // (n − 1)²/12. Without it a parameter the channels barely see gets a
  // linearised spread far beyond its range (measured: the RMS ΔE*ab of noisy
  // synthetic 4D fits 1.6 where the unbounded covariance said 14).
  const auto nodes = table.nodes();
  Eigen::Matrix4d information = Eigen::Matrix4d::Zero();
  for (int k = 0; k < 4; ++k) information(k, k) = 12.0 / ((nodes[k] - 1.0) * (nodes[k] - 1.0));
  for (int c = 0; c < channels; ++c) {
    const Eigen::Map<const Eigen::Vector4d> j(jacobian.data() + 4 * c);
    information.noalias() += (j / camera_variance[c]) * j.transpose();
  }
  appearance.at(x4, at4);
  const double* g = at4.jacobian;
  // Scaled to a unit diagonal before the inverse: the information spans many
  // orders of magnitude between well and poorly determined axes.
  Eigen::Vector4d scale;
  for (int k = 0; k < 4; ++k) scale(k) = 1 / std::sqrt(information(k, k));
  const Eigen::Matrix4d unit = scale.asDiagonal() * information * scale.asDiagonal();
  const Eigen::Matrix4d covariance = scale.asDiagonal() * unit.inverse() * scale.asDiagonal();
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

double appearance_difference(const AppearanceTable& appearance, const AppearanceTable::Point& at4, const GridPoint& x2) {
  double xyz2[AppearanceTable::kChannels];
  appearance.xyz(x2, xyz2);
  double sum = 0;
  for (int l = 0; l < AppearanceTable::kIlluminants; ++l) sum += AppearanceTable::linear_delta_e(at4, xyz2, l);
  return sum / AppearanceTable::kIlluminants;
}

}  // namespace chromo::estimation::detail
