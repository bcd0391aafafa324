#pragma once
// Internal to estimation/: the two quantities of the auto model's order rule
// (estimator.hpp, step 3), both in CIELAB ΔE*ab averaged over the reference
// illuminants of AppearanceTable.

#include "chromo/estimation/appearance.hpp"
#include "chromo/estimation/forward_table.hpp"

namespace chromo::estimation::detail {

// How far the 4D fit's appearance moves with the camera noise: the fit's
// parameter covariance Σ = (Jᵀ V⁻¹ J + P)⁻¹ (J the table's Jacobian at x4,
// V the camera noise variance alone, not the model-error term of the fit's
// weights; P the box the fit is bounded to, as the information of a uniform
// distribution over each axis: 12 / (nodes − 1)² in grid units), mapped to
// Lab by the appearance Jacobian G per illuminant: sqrt(trace(G Σ Gᵀ)), the
// RMS ΔE*ab of the 4D fit's appearance, averaged over the illuminants.
// Writes the appearance at x4 to `at4`.
double appearance_uncertainty(const ForwardTable& table, const AppearanceTable& appearance,
                              const double* camera_variance, const GridPoint& x4, AppearanceTable::Point& at4);

// Mean over the illuminants of ΔE*ab between the appearance at4 and that of
// x2, linearised at at4 (AppearanceTable::linear_delta_e).
double appearance_difference(const AppearanceTable& appearance, const AppearanceTable::Point& at4, const GridPoint& x2);

}  // namespace chromo::estimation::detail
