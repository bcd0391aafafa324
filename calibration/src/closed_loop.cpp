#include "chromo/calibration/closed_loop.hpp"

#include <algorithm>
#include <chrono>
#include <thread>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "chromo/drivers/device_error.hpp"
#include "chromo/spectral/colorimetry.hpp"
#include "led_count.hpp"

namespace chromo::calibration {
namespace {

std::string names(const std::vector<LedType>& types) {
  std::string text;
  for (LedType t : types) text += (text.empty() ? "" : ", ") + std::string(spectral::led_type_name(t));
  return text;
}

// Least-squares gains g_j with m ≈ Σ g_j·w_j·a_j over the channels driven
// at least min_weight; 0 for the others.
std::array<double, kLeds> channel_gains(const std::array<spectral::Spectrum, kLeds>& columns,
                                        const std::array<double, kLeds>& weights, const spectral::Spectrum& measured,
                                        double min_weight) {
  std::vector<int> driven;
  for (int j = 0; j < kLeds; ++j)
    if (weights[j] >= min_weight) driven.push_back(j);
  std::array<double, kLeds> gains{};
  if (driven.empty()) return gains;
  Eigen::MatrixXd a(spectral::kGridSize, driven.size());
  for (std::size_t c = 0; c < driven.size(); ++c) a.col(c) = columns[driven[c]].values().matrix() * weights[driven[c]];
  const Eigen::VectorXd g = a.colPivHouseholderQr().solve(measured.values().matrix());
  for (std::size_t c = 0; c < driven.size(); ++c) gains[driven[c]] = g[c];
  return gains;
}

}  // namespace

std::string_view closed_loop_termination_name(ClosedLoopTermination termination) {
  switch (termination) {
    case ClosedLoopTermination::kConverged: return "converged";
    case ClosedLoopTermination::kIterationLimit: return "iteration limit";
    case ClosedLoopTermination::kDeadChannel: return "dead channel";
    case ClosedLoopTermination::kOutOfGamut: return "out of gamut";
    case ClosedLoopTermination::kCancelled: return "cancelled";
    case ClosedLoopTermination::kDeviceError: return "device error";
    case ClosedLoopTermination::kInvalidInput: return "invalid input";
  }
  return "?";
}

bool ClosedLoopOptions::IsValid(std::string* error) const {
  auto fail = [&](std::string message) {
    if (error) *error = std::move(message);
    return false;
  };
  std::string inner;
  if (!solver.IsValid(&inner)) return fail("solver: " + inner);
  if (!reader.IsValid(&inner)) return fail("reader: " + inner);
  if (!(luminance_fraction > 0 && luminance_fraction <= 1)) return fail("luminance_fraction must be in (0, 1]");
  if (max_iterations < 1) return fail("max_iterations must be ≥ 1");
  if (!(max_delta_uv_prime > 0) || !(camera_de00_mean_margin >= 0) || !(rmse_margin >= 0))
    return fail("tolerances must be positive (margins ≥ 0)");
  if (!(dead_gain_threshold > 0 && dead_gain_threshold < 1)) return fail("dead_gain_threshold must be in (0, 1)");
  if (!(min_weight_for_gain >= 0) || !(settle_s >= 0)) return fail("min_weight_for_gain and settle_s must be ≥ 0");
  return true;
}

ClosedLoopSummary run_closed_loop(drivers::LedController& leds, drivers::Spectrometer& spectrometer,
                                  const LedLibrary& library, const MixTarget& target, const ClosedLoopOptions& options,
                                  const files::Progress& progress) {
  ClosedLoopSummary summary;
  std::string error;
  if (!options.IsValid(&error)) {
    summary.message = "invalid options: " + error;
    return summary;
  }
  if (!library.instrument.response_calibration) {
    summary.message = "the library carries no spectrometer response calibration (measure it with CalibrationRun)";
    return summary;
  }
  const spectral::Spectrum& correction = library.instrument.response_calibration->correction;

  // The plan: the brightest mix, then luminance_fraction of it.
  MixSolverOptions solver = options.solver;
  summary.planned = solve_mix(library, target, solver);
  if (summary.planned.termination == MixTermination::kOptimal) {
    solver.target_luminance_Y = options.luminance_fraction * spectral::xyz_of_light(summary.planned.target).Y;
    summary.planned = solve_mix(library, target, solver);
  }
  if (summary.planned.termination != MixTermination::kOptimal) {
    summary.termination = summary.planned.termination == MixTermination::kInfeasible ? ClosedLoopTermination::kOutOfGamut
                                                                                      : ClosedLoopTermination::kInvalidInput;
    summary.message = "planning solve: " + summary.planned.message;
    return summary;
  }
  const spectral::Spectrum t = summary.planned.target;  // at the planned luminance
  std::array<spectral::Spectrum, kLeds> columns;
  for (int j = 0; j < kLeds; ++j) columns[j] = library.leds[j].spectrum_per_unit_drive();
  double max_de00 = summary.planned.camera_de00.mean + options.camera_de00_mean_margin;
  double max_rmse = summary.planned.rmse + options.rmse_margin;

  std::array<double, kLeds> weights = summary.planned.weights;
  LedLibrary working = library;  // columns updated by the channel re-measurement
  bool leave_on = false;
  try {
    drivers::SpectrometerReader reader(spectrometer, options.reader);
    for (int k = 0; k < options.max_iterations; ++k) {
      if (progress.cancelled()) throw files::Cancelled{};
      drivers::LedState state;
      for (int j = 0; j < kLeds; ++j) state.drive[j] = weights[j];
      try {
        leds.set_state(state);
      } catch (const drivers::DeviceError& e) {
        // The driver refuses to call a faulted state applied; name the channels from the status.
        if (e.kind() != drivers::DeviceError::Kind::kFault) throw;
      }
      switch_led_output(leds, true);
      if (options.settle_s > 0) std::this_thread::sleep_for(std::chrono::duration<double>(options.settle_s));
      const drivers::LedStatus status = leds.read_status();
      for (int j = 0; j < kLeds; ++j)
        if (weights[j] > 0 && (status.channel_faults[j] & drivers::kLedFaultOpenCircuit))
          summary.dead_channels.push_back(static_cast<LedType>(j));
      if (!summary.dead_channels.empty()) {
        summary.termination = ClosedLoopTermination::kDeadChannel;
        summary.message = "the controller reports open circuit on channel(s) " + names(summary.dead_channels);
        break;
      }
      ClosedLoopIteration it;
      it.weights = weights;
      it.measured = reader.measure([&leds](bool on) { switch_led_output(leds, on); }).counts_per_s * correction;
      it.figures = mix_figures(t, it.measured, options.solver);
      it.channel_gain = channel_gains(columns, weights, it.measured, options.min_weight_for_gain);
      it.meets_tolerance = it.figures.delta_uv_prime <= options.max_delta_uv_prime &&
                           it.figures.camera_de00.mean <= max_de00 && it.figures.rmse <= max_rmse;
      summary.iterations.push_back(it);
      progress.report(static_cast<double>(k + 1) / options.max_iterations,
                      fmt::format("iteration {}: du'v' {:.5f}, camera dE00 mean {:.3f}, RMSE {:.4f}", k + 1,
                                  it.figures.delta_uv_prime, it.figures.camera_de00.mean, it.figures.rmse));
      for (int j = 0; j < kLeds; ++j)
        if (weights[j] >= options.min_weight_for_gain && it.channel_gain[j] < options.dead_gain_threshold)
          summary.dead_channels.push_back(static_cast<LedType>(j));
      if (!summary.dead_channels.empty()) {
        summary.termination = ClosedLoopTermination::kDeadChannel;
        summary.message = "channel(s) " + names(summary.dead_channels) + " give less than " +
                          fmt::format("{:.0f} %", 100 * options.dead_gain_threshold) + " of their library output";
        break;
      }
      if (it.meets_tolerance) {
        summary.termination = ClosedLoopTermination::kConverged;
        summary.message = fmt::format("met the target after {} measurement(s): du'v' {:.5f}, camera dE00 mean {:.3f} "
                                      "(planned {:.3f}), RMSE {:.4f} (planned {:.4f})",
                                      k + 1, it.figures.delta_uv_prime, it.figures.camera_de00.mean,
                                      summary.planned.camera_de00.mean, it.figures.rmse, summary.planned.rmse);
        if (summary.replanned && summary.replanned->IsSolutionUsable() &&
            summary.replanned->camera_de00.mean > summary.planned.camera_de00.mean + options.camera_de00_mean_margin)
          summary.message += fmt::format("; the LEDs have drifted: at best they now reach camera dE00 mean {:.3f}",
                                         summary.replanned->camera_de00.mean);
        leave_on = true;
        break;
      }
      if (k + 1 == options.max_iterations) break;
      if (k == 0 && options.remeasure_channels) {
        // Re-measure each driven channel alone at its weight: the library's
        // columns at the operating point (flux loss and peak shift included).
        for (int j = 0; j < kLeds; ++j) {
          if (weights[j] < options.min_weight_for_gain) continue;
          if (progress.cancelled()) throw files::Cancelled{};
          drivers::LedState alone;
          alone.drive.fill(0.0);
          alone.drive[j] = weights[j];
          leds.set_state(alone);
          if (options.settle_s > 0) std::this_thread::sleep_for(std::chrono::duration<double>(options.settle_s));
          columns[j] = reader.measure([&leds](bool on) { switch_led_output(leds, on); }).counts_per_s * correction *
                       (1.0 / weights[j]);
          LedSpectrumSample sample;
          sample.drive_level = weights[j];
          sample.spectrum = columns[j] * weights[j];
          working.leds[j].ladder = {sample};
        }
        ++summary.channel_remeasurements;
        // What the LEDs as they are now can reach at best: the tolerance
        // follows it when it is worse than the plan (drift the loop cannot undo).
        MixSolverOptions replan_options = solver;
        replan_options.target_luminance_Y = spectral::xyz_of_light(t).Y;
        summary.replanned = solve_mix(working, MixTarget{target.name, t}, replan_options);
        if (summary.replanned->IsSolutionUsable()) {
          max_de00 = std::max(max_de00, summary.replanned->camera_de00.mean + options.camera_de00_mean_margin);
          max_rmse = std::max(max_rmse, summary.replanned->rmse + options.rmse_margin);
        }
      }
      // Correct: re-solve against the target plus the model error at w_k.
      spectral::Spectrum predicted;
      for (int j = 0; j < kLeds; ++j) predicted += columns[j] * weights[j];
      MixTarget corrected{target.name + " (loop-corrected)", t + (predicted - it.measured)};
      solver.target_luminance_Y = spectral::xyz_of_light(corrected.spectrum).Y;
      const MixSummary next = solve_mix(working, corrected, solver);
      if (next.termination != MixTermination::kOptimal) {
        for (int j = 0; j < kLeds; ++j)
          if (weights[j] >= library.leds[j].max_drive_level * (1 - 1e-6)) summary.saturated_channels.push_back(static_cast<LedType>(j));
        summary.termination = ClosedLoopTermination::kOutOfGamut;
        summary.message = "the corrected target cannot be reached within the drive limits (" + next.message + ")" +
                          (summary.saturated_channels.empty() ? "" : "; saturated: " + names(summary.saturated_channels));
        break;
      }
      weights = next.weights;
    }
    if (summary.iterations.size() == static_cast<std::size_t>(options.max_iterations) && !summary.iterations.back().meets_tolerance &&
        summary.termination == ClosedLoopTermination::kInvalidInput) {
      const auto& last = summary.iterations.back();
      for (int j = 0; j < kLeds; ++j)
        if (last.weights[j] >= library.leds[j].max_drive_level * (1 - 1e-6)) summary.saturated_channels.push_back(static_cast<LedType>(j));
      std::string gains;
      for (int j = 0; j < kLeds; ++j)
        if (last.channel_gain[j] != 0) gains += fmt::format(" {}={:.3f}", spectral::led_type_name(static_cast<LedType>(j)), last.channel_gain[j]);
      summary.termination = summary.saturated_channels.empty() ? ClosedLoopTermination::kIterationLimit
                                                               : ClosedLoopTermination::kOutOfGamut;
      summary.message = fmt::format("not met after {} measurements: du'v' {:.5f} (max {:.5f}), camera dE00 mean {:.3f} "
                                    "(max {:.3f}), RMSE {:.4f} (max {:.4f}); channel gains vs library:{}",
                                    options.max_iterations, last.figures.delta_uv_prime, options.max_delta_uv_prime,
                                    last.figures.camera_de00.mean, max_de00, last.figures.rmse, max_rmse, gains) +
                        (summary.saturated_channels.empty() ? "; drift the loop cannot follow"
                                                            : "; saturated at the drive limit: " + names(summary.saturated_channels));
    }
  } catch (const files::Cancelled&) {
    summary.termination = ClosedLoopTermination::kCancelled;
    summary.message = "cancelled";
  } catch (const std::exception& e) {
    summary.termination = ClosedLoopTermination::kDeviceError;
    summary.message = e.what();
  }
  if (!leave_on) {
    try {
      leds.set_output_enabled(false);
    } catch (...) {
    }
  }
  return summary;
}

}  // namespace chromo::calibration
