#pragma once
// The closed loop (issue "Calibration", item 3): set the solved weights,
// measure the mix with the spectrometer, correct the weights until the
// measured mix meets the target within tolerance, or say why not.
//
// Method. The library A predicts the mix A·w; the sphere emits m(w). After
// measuring m_k at weights w_k, the model error e_k = A·w_k − m_k (drift,
// flux loss, peak shift since the library was measured) is added to the
// target and the same convex problem is re-solved: min ‖B(A·w − (t + e_k))‖²,
// so that A·w − e_k, the predicted *real* mix, meets t. This is a fixed-point
// iteration on w that converges when the error changes little with w (it is
// exactly E·w for a library error E). It works for all three objectives,
// since each is linear in the target. Its fixed point is not the optimum for
// the drifted LEDs when the target cannot be met exactly (camera ΔE00 is
// never 0), so when the first measurement misses, each driven channel is
// first measured alone at its weight (remeasure_channels) and those spectra
// replace the library's columns: the next solve is the exact optimum for the
// LEDs as they are now, and the additive correction only mops up what the
// single-channel spectra do not explain (thermal interaction, noise).
//
// Brightness: the loop plans at luminance_fraction of the brightest mix the
// library allows (headroom: a channel that lost flux needs more drive), and
// holds that luminance (MixSolverOptions::target_luminance_Y).
//
// Tolerance: the measured mix meets the target when Δu'v' ≤
// max_delta_uv_prime, camera ΔE00 mean ≤ planned + camera_de00_mean_margin
// and RMSE ≤ planned + rmse_margin, "planned" being the library's prediction
// of the first solve: the loop restores the figures the library promised.
// When the re-measured channels show that the LEDs as they are now cannot
// reach those (a peak shift changes what the best mix can do), "planned"
// becomes that best (`replanned`) and the message says so.
//
// Diagnosis (named in the Summary):
//  - dead channel: the controller flags open circuit on a driven channel, or
//    the per-channel gains (least squares of m_k on the driven columns
//    w_j·a_j) put one below dead_gain_threshold → kDeadChannel;
//  - saturated channel / out of gamut: the corrected problem is infeasible,
//    or the loop ends unconverged with channels at their drive limit →
//    kOutOfGamut naming them;
//  - otherwise at the limit: kIterationLimit with the remaining figures and
//    the channel gains (drift the loop cannot follow).
//
// Units: measured spectra are counts/s × the library's response correction
// (the library must carry one: measure it with CalibrationRun). Thread rules
// and device errors: as CalibrationRun (device failures end the loop with
// kDeviceError; the LEDs are left at the last weights set, output enabled,
// when converged, and switched off otherwise).

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "chromo/calibration/calibration_run.hpp"
#include "chromo/calibration/mix_solver.hpp"

namespace chromo::calibration {

struct ClosedLoopOptions {
  MixSolverOptions solver;          // objective, camera...; target_luminance_Y is set by the loop
  double luminance_fraction = 0.9;  // of the brightest mix the library allows, in (0, 1]
  int max_iterations = 6;           // measurements
  double max_delta_uv_prime = 0.0002;
  double camera_de00_mean_margin = 0.01;
  double rmse_margin = 0.002;
  double dead_gain_threshold = 0.3;
  double min_weight_for_gain = 0.02;  // channels driven less than this are not judged
  double settle_s = 0.1;              // after each weight change (wall clock)
  // After the first measurement misses: measure each driven channel alone at
  // its weight and use those spectra as the model's columns from then on.
  bool remeasure_channels = true;
  drivers::SpectrometerReaderOptions reader;

  bool IsValid(std::string* error) const;
};

enum class ClosedLoopTermination { kConverged, kIterationLimit, kDeadChannel, kOutOfGamut, kCancelled, kDeviceError, kInvalidInput };
std::string_view closed_loop_termination_name(ClosedLoopTermination termination);

struct ClosedLoopIteration {
  std::array<double, spectral::kLedTypeCount> weights{};
  spectral::Spectrum measured;  // response-corrected
  MixFigures figures;           // measured vs target
  std::array<double, spectral::kLedTypeCount> channel_gain{};  // measured/library per channel (1 = as in the library; 0 when not judged)
  bool meets_tolerance = false;
};

struct ClosedLoopSummary {
  ClosedLoopTermination termination = ClosedLoopTermination::kInvalidInput;
  std::string message;
  MixSummary planned;                   // the first solve (library prediction)
  std::vector<ClosedLoopIteration> iterations;
  // The solve with the re-measured channels: what the LEDs as they are now
  // can reach at best (absent when no re-measurement was needed).
  std::optional<MixSummary> replanned;
  int channel_remeasurements = 0;       // 0 or 1 (rounds of six single-channel measurements)
  std::vector<LedType> dead_channels;
  std::vector<LedType> saturated_channels;
  bool converged() const { return termination == ClosedLoopTermination::kConverged; }
};

// Progress (files/progress.hpp): after each iteration, the fraction of
// max_iterations done and "iteration k: du'v' …"; cancelled() is polled before
// each iteration and each channel re-measurement and ends with kCancelled.
ClosedLoopSummary run_closed_loop(drivers::LedController& leds, drivers::Spectrometer& spectrometer,
                                  const LedLibrary& library, const MixTarget& target, const ClosedLoopOptions& options,
                                  const files::Progress& progress = {});

}  // namespace chromo::calibration
