#include "chromo/calibration/camera_sensitivity_estimation.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "chromo/calibration/quadratic_program.hpp"

namespace chromo::calibration {

bool SensitivityEstimationOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* message) {
    if (error) *error = message;
    return false;
  };
  if (chart.reflectance.empty()) return fail("chart has no patches");
  if (!(log10_lambda_min < log10_lambda_max) || lambda_steps < 2) return fail("lambda grid must have min < max and ≥ 2 steps");
  return true;
}

SensitivityEstimate estimate_camera_sensitivity(std::span<const ChartCapture> captures,
                                                const SensitivityEstimationOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("SensitivityEstimationOptions: " + error);
  if (captures.empty()) throw std::invalid_argument("estimate_camera_sensitivity: no captures");
  const int patches = static_cast<int>(options.chart.reflectance.size());
  const int n = patches * static_cast<int>(captures.size());
  constexpr int kN = spectral::kGridSize;
  Eigen::MatrixXd a(n, kN);
  Eigen::MatrixXd y(n, 3);
  int row = 0;
  for (const auto& capture : captures) {
    if (static_cast<int>(capture.patch_rgb.size()) != patches)
      throw std::invalid_argument(fmt::format("capture '{}' has {} patches, the chart {}", capture.light_name,
                                              capture.patch_rgb.size(), patches));
    for (int p = 0; p < patches; ++p, ++row) {
      a.row(row) = (capture.light.values() * options.chart.reflectance[p].values() * spectral::kGridStepNm).matrix().transpose();
      y.row(row) = capture.patch_rgb[p].transpose();
    }
  }
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(kN - 2, kN);
  for (int i = 0; i < kN - 2; ++i) d.row(i).segment(i, 3) << 1, -2, 1;
  const Eigen::MatrixXd ata = a.transpose() * a;
  const Eigen::MatrixXd dtd = d.transpose() * d;
  const double mu = ata.trace() / dtd.trace();

  SensitivityEstimate estimate;
  estimate.observations = n;
  estimate.sensitivity.name = "estimated";
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd yc = y.col(c);
    const Eigen::VectorXd aty = a.transpose() * yc;
    double best_gcv = std::numeric_limits<double>::infinity(), best_lambda = 0;
    for (int k = 0; k < options.lambda_steps; ++k) {
      const double lambda = std::pow(10.0, options.log10_lambda_min + (options.log10_lambda_max - options.log10_lambda_min) * k /
                                                                          (options.lambda_steps - 1));
      const Eigen::LDLT<Eigen::MatrixXd> m(ata + lambda * mu * dtd);
      const Eigen::VectorXd s = m.solve(aty);
      const double trace_h = m.solve(ata).trace();
      const double gcv = n * (a * s - yc).squaredNorm() / std::pow(n - trace_h, 2);
      if (gcv < best_gcv) best_gcv = gcv, best_lambda = lambda;
    }
    QuadraticProgram qp;
    qp.G = ata + best_lambda * mu * dtd;
    qp.a = -aty;
    qp.E.resize(0, kN);
    qp.f.resize(0);
    qp.lower = Eigen::VectorXd::Zero(kN);
    qp.upper = Eigen::VectorXd::Constant(kN, std::numeric_limits<double>::infinity());
    const QpResult result = solve_dual_active_set(qp, 1000);
    if (result.termination != QpTermination::kOptimal)
      throw std::runtime_error(std::string("estimate_camera_sensitivity: QP ") + qp_termination_name(result.termination));
    estimate.lambda[c] = best_lambda;
    estimate.residual_relative[c] = (a * result.x - yc).norm() / yc.norm();
    for (int i = 0; i < kN; ++i) estimate.sensitivity.rgb[c].values()[i] = result.x[i];
  }
  return estimate;
}

}  // namespace chromo::calibration
