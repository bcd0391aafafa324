#pragma once
// The mix solver: drive levels of the six LED types whose summed spectrum
// best reproduces a target (D65', W57+blue, a daylight CCT, any SPD), under
// one of three objectives. Method and its justification: docs/mix-solver.md.
//
// The problem. Let A be the 81×6 matrix of spectra per unit drive (the LED
// library), w the drive levels, t the target. Every objective is
//
//   minimise ‖B(A w − t)‖²  subject to  Y(A w) = Y(t)  [+ X, Z equalities]
//                                        0 ≤ w ≤ max_drive_level
//
//   spectral:      B = diag(√spectral_weight): weighted least squares on the grid;
//   colorimetric:  as spectral, plus X(Aw) = X(t), Z(Aw) = Z(t): the XYZ of
//                  the mix equals the target's, the spectral error breaks ties;
//   camera:        B = the chart rows of camera_chart.hpp (24 patches × RGB,
//                  white-normalised by the target's white); with
//                  hold_chromaticity also X and Z equalities (chromaticity of
//                  the mix held at the target's, with Y already equal).
//
// The Y equality is "the mix scaled to the target's Y": brightness is not
// part of the fit. It is chosen by `target_luminance_Y`: absent (default),
// the brightest mix of the optimal shape within the drive limits (solve
// without upper limits, then scale so that the most-driven channel sits at
// its limit; with zero lower bounds that scaled point is optimal for the
// limited problem too). Given, the target is scaled to that Y (library units:
// Σ ȳ·s·Δλ) and the drive limits enter the QP as bounds.
// The QP is solved exactly by quadratic_program.hpp's dual active-set method.
//
// Thread rules: solve_mix is a pure function of its arguments (the built-in
// data it reads are initialised once, thread-safely); call it from any thread.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "chromo/calibration/camera_chart.hpp"
#include "chromo/calibration/colour_rendering.hpp"
#include "chromo/calibration/led_library.hpp"
#include "chromo/calibration/mix_target.hpp"
#include "chromo/calibration/quadratic_program.hpp"
#include "chromo/spectral/camera.hpp"

namespace chromo::calibration {

enum class MixObjective { kSpectral, kColorimetric, kCamera };
// "spectral", "xyz", "camera" (the CLI's names).
std::string_view mix_objective_name(MixObjective objective);
std::optional<MixObjective> parse_mix_objective(std::string_view name);

struct MixSolverOptions {
  MixObjective objective = MixObjective::kSpectral;
  // Camera objective only: also hold the mix's chromaticity at the target's.
  bool hold_chromaticity = false;
  // Per-wavelength weight of the spectral objective and tie-break (≥ 0, not all 0).
  spectral::Spectrum spectral_weight = spectral::Spectrum::constant(1.0);
  // Camera and chart of the camera objective and of the ΔE00 report (always computed).
  spectral::CameraSensitivity camera = spectral::builtin_camera("nikon_d5100");
  ColourChart chart = ohta_colour_checker();
  // Absent: the brightest mix within the drive limits. Given (> 0): that Y.
  std::optional<double> target_luminance_Y;
  int max_iterations = 100;  // add/drop steps of the QP
  // Weight stability: re-solve `stability_trials` times with every LED
  // spectrum perturbed by simulated spectrometer noise, σ(λ) =
  // spectrometer_noise · peak · sqrt(s(λ)/peak) (shot-noise-like: the given
  // fraction of the peak at the peak), independent per wavelength and trial.
  int stability_trials = 0;
  double spectrometer_noise = 0.01;
  std::uint64_t seed = 1;

  bool IsValid(std::string* error) const;
};

enum class MixTermination {
  kOptimal,          // exact optimum of the posed QP
  kInfeasible,       // the equalities cannot be met within the drive limits (target outside the LEDs' gamut or too bright)
  kIterationLimit,   // max_iterations was not enough (should not happen for 6 LEDs)
  kInvalidInput,     // options, library or target rejected; see message
};
std::string_view mix_termination_name(MixTermination termination);

// A wavelength band the LEDs cannot fill: the mix gives less than half of
// what the target asks there (and the target is above 1% of its peak).
struct UnreachableBand {
  double start_nm = 0, end_nm = 0;
  double target_power_fraction = 0;   // of the target's total Σ t over the grid
  double deficit_power_fraction = 0;  // Σ max(0, t − mix) in the band / Σ t
};

struct WeightStability {
  int trials = 0;
  double spectrometer_noise = 0;
  std::array<double, spectral::kLedTypeCount> weight_std{};           // drive-level units
  std::array<double, spectral::kLedTypeCount> relative_weight_std{};  // std / |weight| (inf for a zero weight that moves)
};

struct MixSummary {
  MixTermination termination = MixTermination::kInvalidInput;
  std::string message;  // why it ended, in words
  MixObjective objective = MixObjective::kSpectral;
  bool hold_chromaticity = false;
  std::string target_name;
  int iterations = 0;
  double objective_value = 0;  // ‖B(Aw − t)‖² at the optimum (target at the mix's Y)

  std::array<double, spectral::kLedTypeCount> weights{};   // drive levels, indexed by led_type_index
  std::array<bool, spectral::kLedTypeCount> at_drive_limit{};
  spectral::Spectrum mix;     // A·w
  spectral::Spectrum target;  // the target scaled to the mix's Y

  // Figures of merit (all computed whatever the objective).
  double rmse = 0;            // RMS of (mix − target) over the grid / max(target)
  double delta_uv_prime = 0;  // CIE 1976 u'v' distance mix ↔ target
  ColourRendering rendering;  // of the mix: Ra, R1-R14, CCT
  double target_ra = 0;       // of the target, for reference
  ChartDeltaE camera_de00;    // per patch, mean, max
  std::vector<UnreachableBand> unreachable;
  double unreachable_deficit_fraction = 0;  // sum over the bands
  std::optional<WeightStability> stability;

  bool IsSolutionUsable() const { return termination == MixTermination::kOptimal; }
  // One paragraph: how it ended and the figures of merit.
  std::string BriefReport() const;
};

MixSummary solve_mix(const LedLibrary& library, const MixTarget& target, const MixSolverOptions& options);

// The figures of merit of any mix spectrum (predicted or measured) against a
// target at the brightness it should have: RMSE of (mix − target) over the
// grid / max(target), Δu'v', camera ColorChecker ΔE00 (options' camera and
// chart). solve_mix and the closed loop (closed_loop.hpp) both use it.
struct MixFigures {
  double rmse = 0;
  double delta_uv_prime = 0;
  ChartDeltaE camera_de00;
};
MixFigures mix_figures(const spectral::Spectrum& target, const spectral::Spectrum& mix, const MixSolverOptions& options);

// The QP solve_mix poses, exposed so that tests and the bench can hand the
// same problem to an independent solver. Variables are drive levels scaled
// by each LED's peak (v_i = w_i·peak_i) for conditioning; `drive_per_variable`
// maps back (w = v ∘ drive_per_variable). With upper_limits = false the drive
// limits are left out (the first stage of the brightest-mix mode).
struct MixProblem {
  QuadraticProgram qp;
  Eigen::VectorXd drive_per_variable;
  spectral::Spectrum target;  // the target at the Y the equality asks for
};
MixProblem build_mix_problem(const std::array<spectral::Spectrum, spectral::kLedTypeCount>& spectra_per_unit_drive,
                             const std::array<double, spectral::kLedTypeCount>& max_drive_level,
                             const spectral::Spectrum& target, double target_Y, const MixSolverOptions& options,
                             bool upper_limits);

}  // namespace chromo::calibration
