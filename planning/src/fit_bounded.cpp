#include "fit_bounded.hpp"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <cmath>

namespace chromo::planning {

namespace {

struct WhitenedResidual {
  const PlanModel* model;
  const estimation::SkinModel* skin;
  Eigen::VectorXd observed;
  Eigen::MatrixXd lower;  // Cholesky factor L of the covariance: residual = L⁻¹ (observed − model)
  bool operator()(double const* const* parameters, double* residuals) const {
    const double* p = parameters[0];
    const Eigen::VectorXd v = model->values(skin->albedo({p[0], p[1], p[2], p[3]}));
    const Eigen::VectorXd r = lower.triangularView<Eigen::Lower>().solve(observed - v);
    for (Eigen::Index i = 0; i < r.size(); ++i) residuals[i] = r[i];
    return r.allFinite();
  }
};

}  // namespace

BoundedFit fit_bounded(const PlanModel& model, const Eigen::VectorXd& observed, const Eigen::MatrixXd& covariance,
                       const estimation::SkinParameters& start, int max_iterations,
                       const estimation::SkinModel& skin_model) {
  BoundedFit fit;
  const Eigen::LLT<Eigen::MatrixXd> llt(covariance);
  if (llt.info() != Eigen::Success || !observed.allFinite()) return fit;
  auto* residual = new WhitenedResidual{&model, &skin_model, observed, llt.matrixL()};
  auto* cost = new ceres::DynamicNumericDiffCostFunction<WhitenedResidual, ceres::CENTRAL>(residual);
  cost->AddParameterBlock(4);
  cost->SetNumResiduals(model.channel_count());
  double p[4] = {start.cm, start.ch, start.bm, start.che};
  const estimation::ParameterRange ranges[4] = {estimation::kCmRange, estimation::kChRange, estimation::kBmRange,
                                                estimation::kCheRange};
  ceres::Problem problem;
  problem.AddResidualBlock(cost, nullptr, p);
  for (int j = 0; j < 4; ++j) {
    problem.SetParameterLowerBound(p, j, ranges[j].min);
    problem.SetParameterUpperBound(p, j, ranges[j].max);
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = max_iterations;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  fit.usable = summary.IsSolutionUsable();
  fit.parameters = {p[0], p[1], p[2], p[3]};
  for (int j = 0; j < 4; ++j)
    if (p[j] - ranges[j].min < 1e-9 || ranges[j].max - p[j] < 1e-9) fit.on_bound = true;
  return fit;
}

}  // namespace chromo::planning
