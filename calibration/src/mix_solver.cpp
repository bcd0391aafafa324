#include "chromo/calibration/mix_solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>

#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/colorimetry.hpp"
#include "led_count.hpp"

namespace chromo::calibration {
namespace {

using SpectraArray = std::array<spectral::Spectrum, spectral::kLedTypeCount>;
using DriveArray = std::array<double, spectral::kLedTypeCount>;
double luminance(const spectral::Spectrum& s) { return spectral::xyz_of_light(s).Y; }

struct SolveOutcome {
  MixTermination termination = MixTermination::kInvalidInput;
  std::string message;
  int iterations = 0;
  double objective_value = 0;
  DriveArray weights{};
  spectral::Spectrum target;  // scaled as the solution's
};

// One solve of the posed problem in the brightness mode the options ask for.
SolveOutcome solve_once(const SpectraArray& spectra, const DriveArray& max_drive, const spectral::Spectrum& target,
                        const MixSolverOptions& options) {
  SolveOutcome out;
  const bool fixed_y = options.target_luminance_Y.has_value();
  // Brightest-mix mode works at the target normalised to a peak of 1 (well scaled), then rescales.
  const double y = fixed_y ? *options.target_luminance_Y : luminance(target) / target.max();
  const MixProblem problem = build_mix_problem(spectra, max_drive, target, y, options, fixed_y);
  const QpResult qp = solve_dual_active_set(problem.qp, options.max_iterations);
  out.iterations = qp.iterations;
  out.target = problem.target;
  switch (qp.termination) {
    case QpTermination::kOptimal: break;
    case QpTermination::kIterationLimit:
      out.termination = MixTermination::kIterationLimit;
      out.message = "the QP did not finish within max_iterations = " + std::to_string(options.max_iterations);
      return out;
    case QpTermination::kNotConvex:
      out.termination = MixTermination::kInvalidInput;
      out.message = "the objective is not strictly convex: the LED spectra (as the objective sees them) are linearly dependent";
      return out;
    case QpTermination::kInfeasible:
      out.termination = MixTermination::kInfeasible;
      out.message = fixed_y ? "no mix within the drive limits reaches the target's Y" +
                                  std::string(problem.qp.E.rows() > 1 ? " and chromaticity" : "")
                            : "the target's chromaticity is outside the gamut of the LEDs";
      return out;
  }
  double scale = 1.0;
  if (!fixed_y) {
    scale = std::numeric_limits<double>::infinity();
    for (int i = 0; i < kLeds; ++i) {
      const double w = qp.x[i] * problem.drive_per_variable[i];
      if (w > 0) scale = std::min(scale, max_drive[i] / w);
    }
  }
  for (int i = 0; i < kLeds; ++i) {
    const double w = qp.x[i] * problem.drive_per_variable[i] * scale;
    // Rounding residue at either bound: below 1e-12 of the range is zero, and
    // w · (max/w) may come out one ulp above max (a controller refuses that).
    out.weights[i] = w > 1e-12 * max_drive[i] ? std::min(w, max_drive[i]) : 0.0;
  }
  out.target = problem.target * scale;
  out.objective_value = qp.objective * scale * scale + 0.0;
  out.termination = MixTermination::kOptimal;
  out.message = "optimal: exact KKT point of the QP";
  return out;
}

std::vector<UnreachableBand> unreachable_bands(const spectral::Spectrum& target, const spectral::Spectrum& mix) {
  std::vector<UnreachableBand> bands;
  const double total = target.values().sum(), floor = 0.01 * target.max();
  for (int i = 0; i < spectral::kGridSize; ++i) {
    if (!(target[i] > floor && mix[i] < 0.5 * target[i])) continue;
    const double lambda = spectral::grid_wavelength_nm(i);
    if (bands.empty() || bands.back().end_nm + spectral::kGridStepNm < lambda - 1e-9) bands.push_back({lambda, lambda, 0, 0});
    UnreachableBand& band = bands.back();
    band.end_nm = lambda;
    band.target_power_fraction += target[i] / total;
    band.deficit_power_fraction += std::max(0.0, target[i] - mix[i]) / total;
  }
  return bands;
}

WeightStability weight_stability(const SpectraArray& spectra, const DriveArray& max_drive,
                                 const spectral::Spectrum& target, const MixSolverOptions& options,
                                 const DriveArray& weights) {
  WeightStability result;
  result.spectrometer_noise = options.spectrometer_noise;
  std::mt19937_64 random(options.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  DriveArray sum{}, sum_squares{};
  for (int trial = 0; trial < options.stability_trials; ++trial) {
    SpectraArray noisy = spectra;
    for (auto& s : noisy) {
      const double peak = s.max();
      for (int k = 0; k < spectral::kGridSize; ++k)
        s[k] += options.spectrometer_noise * peak * std::sqrt(std::max(0.0, s[k] / peak)) * normal(random);
    }
    const SolveOutcome outcome = solve_once(noisy, max_drive, target, options);
    if (outcome.termination != MixTermination::kOptimal) continue;
    ++result.trials;
    for (int i = 0; i < kLeds; ++i) sum[i] += outcome.weights[i], sum_squares[i] += outcome.weights[i] * outcome.weights[i];
  }
  for (int i = 0; i < kLeds; ++i) {
    if (result.trials < 2) break;
    const double n = result.trials, mean = sum[i] / n;
    result.weight_std[i] = std::sqrt(std::max(0.0, (sum_squares[i] - n * mean * mean) / (n - 1)));
    result.relative_weight_std[i] = weights[i] > 0 ? result.weight_std[i] / weights[i]
                                    : result.weight_std[i] > 0 ? std::numeric_limits<double>::infinity() : 0.0;
  }
  return result;
}

}  // namespace

std::string_view mix_objective_name(MixObjective objective) {
  switch (objective) {
    case MixObjective::kSpectral: return "spectral";
    case MixObjective::kColorimetric: return "xyz";
    case MixObjective::kCamera: return "camera";
  }
  return "unknown";
}

std::optional<MixObjective> parse_mix_objective(std::string_view name) {
  for (MixObjective o : {MixObjective::kSpectral, MixObjective::kColorimetric, MixObjective::kCamera})
    if (mix_objective_name(o) == name) return o;
  return std::nullopt;
}

std::string_view mix_termination_name(MixTermination termination) {
  switch (termination) {
    case MixTermination::kOptimal: return "optimal";
    case MixTermination::kInfeasible: return "infeasible";
    case MixTermination::kIterationLimit: return "iteration_limit";
    case MixTermination::kInvalidInput: return "invalid_input";
  }
  return "unknown";
}

bool MixSolverOptions::IsValid(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (hold_chromaticity && objective != MixObjective::kCamera)
    return fail("hold_chromaticity applies to the camera objective only (the xyz objective already holds XYZ)");
  if (!spectral_weight.values().allFinite() || spectral_weight.min() < 0 || !(spectral_weight.max() > 0))
    return fail("spectral_weight must be finite, non-negative and not all zero");
  if (chart.reflectance.size() < 3) return fail("chart needs at least 3 patches (the ΔE00 report fits a 3×3 matrix)");
  for (const auto& s : camera.rgb)
    if (!s.values().allFinite() || !(s.max() > 0)) return fail("camera '" + camera.name + "' has an empty or non-finite channel");
  if (target_luminance_Y && !(*target_luminance_Y > 0 && std::isfinite(*target_luminance_Y)))
    return fail("target_luminance_Y must be a positive number");
  if (max_iterations < 1) return fail("max_iterations must be at least 1");
  if (stability_trials < 0 || stability_trials == 1) return fail("stability_trials must be 0 or at least 2");
  if (!(spectrometer_noise >= 0 && spectrometer_noise < 1)) return fail("spectrometer_noise must be in [0, 1)");
  return true;
}

MixProblem build_mix_problem(const SpectraArray& spectra, const DriveArray& max_drive, const spectral::Spectrum& target,
                             double target_Y, const MixSolverOptions& options, bool upper_limits) {
  MixProblem problem;
  problem.target = target * (target_Y / luminance(target));
  Eigen::Matrix<double, spectral::kGridSize, kLeds> basis;  // columns scaled to a peak of 1
  problem.drive_per_variable.resize(kLeds);
  for (int i = 0; i < kLeds; ++i) {
    problem.drive_per_variable[i] = 1.0 / spectra[i].max();
    basis.col(i) = spectra[i].values().matrix() * problem.drive_per_variable[i];
  }
  const Eigen::VectorXd t = problem.target.values().matrix();
  QuadraticProgram& qp = problem.qp;
  if (options.objective == MixObjective::kCamera) {
    const Eigen::MatrixXd rows = camera_chart_rows(options.camera, options.chart, problem.target);
    const Eigen::MatrixXd seen = rows * basis;
    qp.G = seen.transpose() * seen;
    qp.a = -seen.transpose() * (rows * t);
  } else {
    const Eigen::VectorXd weight = options.spectral_weight.values().matrix();
    qp.G = basis.transpose() * weight.asDiagonal() * basis;
    qp.a = -basis.transpose() * weight.asDiagonal() * t;
  }
  const bool hold_xyz =
      options.objective == MixObjective::kColorimetric || (options.objective == MixObjective::kCamera && options.hold_chromaticity);
  const spectral::Observer& observer = spectral::cie1931_observer();
  std::vector<const spectral::Spectrum*> cmfs{&observer.y_bar};
  if (hold_xyz) cmfs = {&observer.x_bar, &observer.y_bar, &observer.z_bar};
  qp.E.resize(static_cast<Eigen::Index>(cmfs.size()), kLeds);
  qp.f.resize(static_cast<Eigen::Index>(cmfs.size()));
  for (std::size_t j = 0; j < cmfs.size(); ++j) {
    const Eigen::RowVectorXd row = cmfs[j]->values().matrix().transpose() * basis;
    const double norm = row.norm();  // unit rows keep the KKT systems balanced
    qp.E.row(static_cast<Eigen::Index>(j)) = row / norm;
    qp.f[static_cast<Eigen::Index>(j)] = cmfs[j]->values().matrix().dot(t) / norm;
  }
  qp.lower = Eigen::VectorXd::Zero(kLeds);
  qp.upper = Eigen::VectorXd::Constant(kLeds, std::numeric_limits<double>::infinity());
  if (upper_limits)
    for (int i = 0; i < kLeds; ++i) qp.upper[i] = max_drive[i] / problem.drive_per_variable[i];
  return problem;
}

MixSummary solve_mix(const LedLibrary& library, const MixTarget& target, const MixSolverOptions& options) {
  MixSummary summary;
  summary.objective = options.objective;
  summary.hold_chromaticity = options.hold_chromaticity;
  summary.target_name = target.name;
  std::string error;
  if (!options.IsValid(&error)) {
    summary.message = "invalid options: " + error;
    return summary;
  }
  if (error = validate(library); !error.empty()) {
    summary.message = "invalid LED library: " + error;
    return summary;
  }
  if (!target.spectrum.values().allFinite() || !(luminance(target.spectrum) > 0)) {
    summary.message = "target '" + target.name + "' must be finite with positive luminance";
    return summary;
  }
  SpectraArray spectra;
  DriveArray max_drive;
  for (int i = 0; i < kLeds; ++i) {
    spectra[i] = library.leds[i].spectrum_per_unit_drive();
    max_drive[i] = library.leds[i].max_drive_level;
  }
  const SolveOutcome outcome = solve_once(spectra, max_drive, target.spectrum, options);
  summary.termination = outcome.termination;
  summary.message = outcome.message;
  summary.iterations = outcome.iterations;
  if (outcome.termination != MixTermination::kOptimal) return summary;

  summary.objective_value = outcome.objective_value;
  summary.weights = outcome.weights;
  summary.target = outcome.target;
  for (int i = 0; i < kLeds; ++i) {
    summary.mix += spectra[i] * outcome.weights[i];
    summary.at_drive_limit[i] = outcome.weights[i] >= max_drive[i] * (1.0 - 1e-9);
  }
  const spectral::Spectrum& t = summary.target;
  const MixFigures figures = mix_figures(t, summary.mix, options);
  summary.rmse = figures.rmse;
  summary.delta_uv_prime = figures.delta_uv_prime;
  summary.camera_de00 = figures.camera_de00;
  summary.rendering = colour_rendering_index(summary.mix);
  summary.target_ra = colour_rendering_index(t).ra;
  summary.unreachable = unreachable_bands(t, summary.mix);
  for (const auto& band : summary.unreachable) summary.unreachable_deficit_fraction += band.deficit_power_fraction;
  if (options.stability_trials > 0)
    summary.stability = weight_stability(spectra, max_drive, target.spectrum, options, summary.weights);
  return summary;
}

MixFigures mix_figures(const spectral::Spectrum& target, const spectral::Spectrum& mix, const MixSolverOptions& options) {
  MixFigures figures;
  figures.rmse = std::sqrt((mix.values() - target.values()).square().mean()) / target.max();
  const spectral::UvPrime uv_mix = spectral::uv_prime(spectral::xyz_of_light(mix));
  const spectral::UvPrime uv_target = spectral::uv_prime(spectral::xyz_of_light(target));
  figures.delta_uv_prime = std::hypot(uv_mix.u - uv_target.u, uv_mix.v - uv_target.v);
  figures.camera_de00 = camera_chart_delta_e00(options.camera, options.chart, target, mix);
  return figures;
}

std::string MixSummary::BriefReport() const {
  std::ostringstream out;
  out.precision(4);
  out << "mix solver: objective " << mix_objective_name(objective) << (hold_chromaticity ? " (chromaticity held)" : "")
      << ", target " << target_name << ": " << mix_termination_name(termination) << " after " << iterations
      << " QP steps (" << message << ")";
  if (termination != MixTermination::kOptimal) return out.str();
  out << "; weights";
  for (int i = 0; i < kLeds; ++i)
    out << " " << spectral::led_type_name(spectral::kAllLedTypes[i]) << "=" << weights[i] << (at_drive_limit[i] ? "(limit)" : "");
  out << "; RMSE " << rmse << " of peak, du'v' " << delta_uv_prime << ", Ra " << rendering.ra << " (target " << target_ra
      << "), camera dE00 mean " << camera_de00.mean << " max " << camera_de00.max;
  if (!unreachable.empty()) {
    out << "; UNREACHABLE:";
    for (const auto& band : unreachable)
      out << " " << band.start_nm << "-" << band.end_nm << " nm (target " << 100 * band.target_power_fraction
          << "% of its power there, mix short by " << 100 * band.deficit_power_fraction << "% of the total)";
  }
  return out.str();
}

}  // namespace chromo::calibration
