#pragma once
// The learned discrepancy's scale for one plan, calibrated by nested
// leave-subjects-out cross-validation inside its own training subjects
// (docs/estimation.md, "The discrepancy's scale by nested cross-validation").
//
// Why: Σ_r is learned from a few dozen subjects (model_discrepancy.hpp); a
// subject it has not seen lies, in the plan's channels, farther from the
// model than the training subjects' own scatter says (the shrunk second
// moment of n residuals underestimates the spread of the (n+1)-th). The
// training subjects can measure that themselves: split them into `folds`
// groups by index, learn Σ_r from the others, and compute each held-in
// held-out subject's Mahalanobis distance in the plan's channels,
//   D²_i = r_iᵀ (W Σ_r^(−i) Wᵀ)⁻¹ r_i,   r_i = W·(its residual spectrum),
// noise-free. The scale s makes the held-out distances match what the
// Gaussian with covariance s·W Σ_r Wᵀ predicts for them: the `quantile` of
// D²_i over the training subjects equals the same quantile of χ²(C) times s
// (s ≥ 1: never narrower than learned). No test subject enters: only the
// ModelDiscrepancy's own training residuals.
//
// Thread rules: pure functions, reentrant.

#include <Eigen/Core>
#include <vector>

#include "chromo/estimation/model_discrepancy.hpp"

namespace chromo::estimation {

struct DiscrepancyCalibrationOptions {
  int folds = 5;          // inner folds: subject i (training order) in fold i mod folds
  double quantile = 0.9;  // the held-out D² quantile matched (0 < q < 1)
};

struct DiscrepancyCalibration {
  double scale = 1;                  // s ≥ 1: the plan's Σ_disc × s
  double held_out_quantile = 0;      // the quantile of D²_i
  double expected_quantile = 0;      // the same quantile of χ²(C)
  std::vector<double> held_out_d2;   // D²_i per training subject, in training order
};

// weights: the plan's camera weights W (C × 81, MeasurementSet::weights()).
// Throws std::invalid_argument when the discrepancy holds fewer than 2 ×
// folds subjects, folds < 2, the quantile is outside (0, 1) or W is not C × 81.
DiscrepancyCalibration calibrate_discrepancy_scale(const ModelDiscrepancy& discrepancy, const Eigen::MatrixXd& weights,
                                                   const DiscrepancyCalibrationOptions& options = {});

}  // namespace chromo::estimation
