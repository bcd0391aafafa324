#pragma once
// Internal: the Monte Carlo check's estimator — bounded weighted least
// squares of a plan's channels (Ceres, MODEL.md's ranges as bounds, the
// inverse channel covariance as the weight), started at a given point.

#include <Eigen/Core>

#include "chromo/estimation/skin_model.hpp"
#include "chromo/estimation/skin_parameters.hpp"
#include "plan_model.hpp"

namespace chromo::planning {

struct BoundedFit {
  estimation::SkinParameters parameters;
  bool usable = false;    // Ceres' solution is usable
  bool on_bound = false;  // some parameter ended within 1e-9 of its range's edge
};

BoundedFit fit_bounded(const PlanModel& model, const Eigen::VectorXd& observed, const Eigen::MatrixXd& covariance,
                       const estimation::SkinParameters& start, int max_iterations,
                       const estimation::SkinModel& skin_model);

}  // namespace chromo::planning
