#pragma once
// Shared by the `chromo leds` subcommands: which library to use and the
// solve options that `solve` and `plot` both take.

#include <filesystem>
#include <optional>
#include <string>

#include "chromo/calibration/calibration_run.hpp"
#include "chromo/calibration/led_library.hpp"
#include "chromo/calibration/mix_solver.hpp"
#include "daemon_client.hpp"

namespace chromo::cli {

struct LedsSolveArguments {
  std::string target = "d65";
  // chromod's address: `--library daemon` (and plot without --library) asks it for its library.
  DaemonAddress daemon;
  bool daemon_first = false;  // without --library: chromod's library when a daemon answers (plot)
  std::string objective = "camera";
  bool hold_chromaticity = false;
  // empty: (daemon_first: chromod's when one answers, else) the latest
  // measured, else one measured at once on the virtual lab; "nominal":
  // built-in; "daemon": chromod's.
  std::string library_path;
  std::string camera = "nikon_d5100";
  int stability_trials = 32;
  double spectrometer_noise = 0.01;
  bool json = false;
  std::string out_png = "leds-plot.png";  // plot only
};

struct SolvedMix {
  calibration::LedLibrary library;
  std::string library_description;  // "nominal (built-in ...)" or the file path
  calibration::MixSummary summary;
};

// The LED library chromod uses (CalibrationService.GetLedLibrary; the
// built-in nominal one when chromod has none), with a description naming
// chromod and its file. std::nullopt and *why_not when no daemon answers;
// std::runtime_error when its answer is not a valid library.
struct DaemonLedLibrary {
  calibration::LedLibrary library;
  std::string description;  // "chromod's: FILE (measured 2026-...)"
};
std::optional<DaemonLedLibrary> daemon_led_library(const DaemonAddress& address, std::string* why_not);

// Resolves the library and target, validates, solves. On bad input prints a
// message naming the option to stderr and returns nullopt with exit_status set.
std::optional<SolvedMix> solve_from_arguments(const LedsSolveArguments& arguments, const char* command, int& exit_status);

// A calibration run on the in-process virtual lab, saved to out_path (empty:
// a new file in the library directory). DeviceError/DataError propagate.
struct MeasuredOnVirtualLab {
  calibration::CalibrationSummary summary;
  std::filesystem::path path;  // where it was saved; empty when the run failed
};
MeasuredOnVirtualLab measure_on_virtual_lab(const std::filesystem::path& out_path, bool progress_bar);

// PNG of target vs mix spectra and the per-patch camera ΔE00, via gnuplot.
// Returns an exit status (0, or 1 with a message when gnuplot fails).
int plot_mix(const SolvedMix& solved, const std::string& out_png);

}  // namespace chromo::cli
