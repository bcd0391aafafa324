#pragma once
// Internal to estimation/: the maximum a posteriori fit of one pixel under a
// ParameterPrior (parameter_prior.hpp; estimator.hpp step 4b).
//
// In the table's grid coordinates x the prior's coordinates u = (ln Cm,
// ln Ch, βm, Che) are affine per axis (Cm and Ch nodes are log-spaced, βm
// and Che linear): u_k = u_k(0) + b_k·x_k, so the prior is a Gaussian in x
// with mean (μ_k − u_k(0))/b_k and information B S⁻¹ B (GridPrior). The fit
// minimises
//   F(x) = rᵀ Σ⁻¹ r + (x − μ_x)ᵀ P_x (x − μ_x),   r = table(x) − measured,
// by projected Gauss-Newton (box [0, nodes − 1], step halving while F does
// not fall, ≤ kPriorFitIterations steps) from the given start and from the
// prior's mean, keeping the lower F.

#include <Eigen/Core>

#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/parameter_prior.hpp"
#include "pixel_covariance.hpp"

namespace chromo::estimation::detail {

struct GridPrior {
  Eigen::Vector4d mean = Eigen::Vector4d::Zero();             // μ_x (may lie outside the box)
  Eigen::Matrix4d information = Eigen::Matrix4d::Zero();      // P_x
  double penalty(const GridPoint& x) const;                   // (x − μ_x)ᵀ P_x (x − μ_x)
};

// The prior in the table's grid coordinates (throws std::invalid_argument if
// an axis of the grid is not affine in u within 1e-6 of a node step).
GridPrior grid_prior(const ForwardTable& table, const ParameterPrior& prior);

struct PriorFit {
  GridPoint x{};
  double chi2 = 0;     // the data's rᵀ Σ⁻¹ r at x
  double penalty = 0;  // the prior's at x
};

inline constexpr int kPriorFitIterations = 12;

// measured: table.channels() values; start: a grid point in the box.
PriorFit prior_fit(const ForwardTable& table, const PixelCovariance& covariance, const GridPrior& prior,
                   const double* measured, const GridPoint& start);

}  // namespace chromo::estimation::detail
