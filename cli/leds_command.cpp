// chromo leds: the LED library and the mix solver (issue "Calibration").
//   chromo leds solve   --target d65|w57+blue[:R]|cct:K|FILE.csv --objective spectral|xyz|camera
//                       [--hold-chromaticity] [--library FILE] [--json]
//   chromo leds compare OLD NEW [--json]
//   chromo leds plot    (solve's options) [--out FILE.png]   (chromod's library when a daemon answers)
//   chromo leds measure [--out FILE] [--json]          (leds_measure.cpp)
#include <fmt/format.h>

#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>

#include "chromo/calibration/led_library_analysis.hpp"
#include "chromo/calibration/led_library_io.hpp"
#include "chromo/spectral/table.hpp"
#include "commands.hpp"
#include "leds_common.hpp"

namespace chromo::cli {
namespace {

using calibration::MixSummary;
using spectral::kAllLedTypes;
using spectral::led_type_name;

template <typename T>
nlohmann::ordered_json per_led(const T& values) {
  nlohmann::ordered_json out;
  for (int i = 0; i < spectral::kLedTypeCount; ++i) out[std::string(led_type_name(kAllLedTypes[i]))] = values[i];
  return out;
}

nlohmann::ordered_json summary_json(const SolvedMix& solved) {
  const MixSummary& s = solved.summary;
  nlohmann::ordered_json out;
  out["library"] = solved.library_description;
  out["library_source"] = solved.library.source;
  out["target"] = s.target_name;
  out["objective"] = calibration::mix_objective_name(s.objective);
  out["hold_chromaticity"] = s.hold_chromaticity;
  out["termination"] = calibration::mix_termination_name(s.termination);
  out["message"] = s.message;
  out["iterations"] = s.iterations;
  out["weights"] = per_led(s.weights);
  out["at_drive_limit"] = per_led(s.at_drive_limit);
  std::vector<double> grid;
  for (int i = 0; i < spectral::kGridSize; ++i) grid.push_back(spectral::grid_wavelength_nm(i));
  out["wavelength_nm"] = grid;
  out["mix"] = s.mix.to_vector();
  out["target_spectrum"] = s.target.to_vector();
  out["rmse"] = s.rmse;
  out["delta_uv_prime"] = s.delta_uv_prime;
  out["ra"] = s.rendering.ra;
  out["r1_r14"] = s.rendering.r;
  out["cct_K"] = s.rendering.cct_K;
  out["target_ra"] = s.target_ra;
  out["camera_de00_mean"] = s.camera_de00.mean;
  out["camera_de00_max"] = s.camera_de00.max;
  out["camera_de00_per_patch"] = s.camera_de00.delta_e00;
  nlohmann::ordered_json bands = nlohmann::ordered_json::array();
  for (const auto& b : s.unreachable)
    bands.push_back({{"start_nm", b.start_nm}, {"end_nm", b.end_nm}, {"target_power_fraction", b.target_power_fraction},
                     {"deficit_power_fraction", b.deficit_power_fraction}});
  out["unreachable"] = bands;
  out["unreachable_deficit_fraction"] = s.unreachable_deficit_fraction;
  if (s.stability) {
    out["stability_trials"] = s.stability->trials;
    out["spectrometer_noise"] = s.stability->spectrometer_noise;
    out["weight_std"] = per_led(s.stability->weight_std);
    nlohmann::ordered_json relative;  // null for a zero weight that noise turns on (std / 0)
    for (int i = 0; i < spectral::kLedTypeCount; ++i) {
      const double r = s.stability->relative_weight_std[i];
      relative[std::string(led_type_name(kAllLedTypes[i]))] = std::isfinite(r) ? nlohmann::ordered_json(r) : nullptr;
    }
    out["relative_weight_std"] = relative;
  } else {
    out["stability_trials"] = 0;
    out["weight_std"] = nullptr;
  }
  return out;
}

void print_summary_text(const SolvedMix& solved) {
  const MixSummary& s = solved.summary;
  fmt::print("library: {}\n", solved.library_description);
  fmt::print("target {} | objective {}{} | {} after {} QP steps\n", s.target_name, calibration::mix_objective_name(s.objective),
             s.hold_chromaticity ? " (chromaticity held)" : "", calibration::mix_termination_name(s.termination),
             s.iterations);
  fmt::print("{:>4} {:>10} {:>10} {:>9}\n", "LED", "drive", "noise std", "trust");
  for (int i = 0; i < spectral::kLedTypeCount; ++i) {
    std::string std_text = "-", trust = "-";
    if (s.stability) {
      const double rel = s.stability->relative_weight_std[i];
      std_text = fmt::format("{:.4f}", s.stability->weight_std[i]);
      trust = s.at_drive_limit[i] ? "at limit" : s.weights[i] == 0 ? "off" : rel < 0.05 ? "good" : rel < 0.2 ? "fair" : "poor";
    }
    fmt::print("{:>4} {:>10.5f} {:>10} {:>9}\n", led_type_name(kAllLedTypes[i]), s.weights[i], std_text, trust);
  }
  fmt::print("spectral RMSE {:.4f} of target peak | du'v' {:.2e} | Ra {:.2f} (target {:.2f}), CCT {:.0f} K\n", s.rmse,
             s.delta_uv_prime, s.rendering.ra, s.target_ra, s.rendering.cct_K);
  fmt::print("R1-R14:");
  for (double r : s.rendering.r) fmt::print(" {:.1f}", r);
  fmt::print("\ncamera ColorChecker dE00 mean {:.3f} max {:.3f}\n", s.camera_de00.mean, s.camera_de00.max);
  for (const auto& b : s.unreachable)
    fmt::print("UNREACHABLE {:.0f}-{:.0f} nm: the target has {:.1f}% of its power there; the mix falls short by {:.1f}% of "
               "the total\n",
               b.start_nm, b.end_nm, 100 * b.target_power_fraction, 100 * b.deficit_power_fraction);
}

int run_solve(const LedsSolveArguments& arguments) {
  int exit_status = kExitOk;
  const auto solved = solve_from_arguments(arguments, "chromo leds solve", exit_status);
  if (!solved) return exit_status;
  if (arguments.json) std::cout << summary_json(*solved).dump(2) << "\n";
  else print_summary_text(*solved);
  return exit_status;
}

int run_compare(const std::string& old_path, const std::string& new_path, bool json) {
  calibration::LedLibrary old_lib, new_lib;
  try {
    old_lib = calibration::load_led_library(old_path);
    new_lib = calibration::load_led_library(new_path);
  } catch (const spectral::DataError& e) {
    std::cerr << "chromo leds compare: " << e.what() << "\n";
    return kExitBadInput;
  }
  const auto drift = calibration::compare(old_lib, new_lib);
  if (json) {
    nlohmann::ordered_json out;
    out["old"] = {{"path", old_path}, {"created_utc", old_lib.created_utc}};
    out["new"] = {{"path", new_path}, {"created_utc", new_lib.created_utc}};
    for (int i = 0; i < spectral::kLedTypeCount; ++i) {
      const auto lin = calibration::check_linearity(new_lib.leds[i]);
      out["leds"][std::string(led_type_name(kAllLedTypes[i]))] = {
          {"peak_shift_nm", drift[i].peak_shift_nm},
          {"centroid_shift_nm", drift[i].centroid_shift_nm},
          {"flux_change_percent", drift[i].flux_change_percent},
          {"rmse_relative_to_peak", drift[i].rmse_relative_to_peak},
          {"linearity_max_deviation_percent", lin.assessable ? nlohmann::ordered_json(lin.max_deviation_percent) : nullptr}};
    }
    std::cout << out.dump(2) << "\n";
    return kExitOk;
  }
  fmt::print("old {} ({})\nnew {} ({})\n", old_path, old_lib.created_utc, new_path, new_lib.created_utc);
  fmt::print("{:>4} {:>10} {:>14} {:>10} {:>12} {:>16}\n", "LED", "peak nm", "centroid nm", "flux %", "RMSE/peak",
             "new linearity %");
  for (int i = 0; i < spectral::kLedTypeCount; ++i) {
    const auto lin = calibration::check_linearity(new_lib.leds[i]);
    fmt::print("{:>4} {:>+10.2f} {:>+14.2f} {:>+10.2f} {:>12.4f} {:>16}\n", led_type_name(kAllLedTypes[i]),
               drift[i].peak_shift_nm, drift[i].centroid_shift_nm, drift[i].flux_change_percent,
               drift[i].rmse_relative_to_peak,
               lin.assessable ? fmt::format("{:.2f}", lin.max_deviation_percent) : std::string("n/a (<3 rungs)"));
  }
  return kExitOk;
}

void add_solve_options(CLI::App* cmd, LedsSolveArguments& a) {
  cmd->add_option("--target", a.target, "d65, w57+blue[:R], cct:K (daylight, 4000-25000) or a CSV (wavelength_nm,value)")
      ->capture_default_str();
  cmd->add_option("--objective", a.objective, "spectral, xyz or camera")->capture_default_str();
  cmd->add_flag("--hold-chromaticity", a.hold_chromaticity, "camera objective: hold the mix's chromaticity at the target's");
  cmd->add_option("--library", a.library_path,
                  "LED library JSON, 'nominal' for the built-in one, or 'daemon' for the one chromod uses (default: "
                  + std::string(a.daemon_first ? "chromod's when a daemon answers, else " : "") +
                  "the latest measured in the library directory, else one measured at once on the virtual lab)");
  add_daemon_options(*cmd, a.daemon);
  cmd->add_option("--camera", a.camera, "built-in camera of the camera objective and ΔE00 report")->capture_default_str();
  cmd->add_option("--stability-trials", a.stability_trials, "re-solves with perturbed spectra for the weight std (0: off)")
      ->capture_default_str();
  cmd->add_option("--spectrometer-noise", a.spectrometer_noise, "relative spectrometer noise at the peak for those re-solves")
      ->capture_default_str();
}

}  // namespace

std::optional<SolvedMix> solve_from_arguments(const LedsSolveArguments& a, const char* command, int& exit_status) {
  auto bad = [&](const std::string& message) {
    std::cerr << command << ": " << message << "\n";
    exit_status = kExitBadInput;
    return std::nullopt;
  };
  SolvedMix solved;
  calibration::MixSolverOptions options;
  const auto objective = calibration::parse_mix_objective(a.objective);
  if (!objective) return bad("--objective: unknown objective '" + a.objective + "' (expected spectral, xyz or camera)");
  options.objective = *objective;
  options.hold_chromaticity = a.hold_chromaticity;
  options.stability_trials = a.stability_trials;
  options.spectrometer_noise = a.spectrometer_noise;
  try {
    options.camera = spectral::builtin_camera(a.camera);
  } catch (const spectral::DataError& e) {
    return bad(std::string("--camera: ") + e.what());
  }
  if (std::string error; !options.IsValid(&error)) {
    const std::string flag = error.rfind("hold_chromaticity", 0) == 0 ? "--hold-chromaticity"
                             : error.rfind("stability_trials", 0) == 0 ? "--stability-trials"
                             : error.rfind("spectrometer_noise", 0) == 0 ? "--spectrometer-noise"
                                                                         : "options";
    return bad(flag + ": " + error);
  }
  try {
    std::optional<DaemonLedLibrary> from_daemon;
    if (a.library_path == "daemon" || (a.library_path.empty() && a.daemon_first)) {
      std::string why_not;
      from_daemon = daemon_led_library(a.daemon, &why_not);
      if (!from_daemon && a.library_path == "daemon") {
        std::cerr << command << ": --library daemon: " << why_not << "\n";
        exit_status = kExitFailure;
        return std::nullopt;
      }
      if (!from_daemon) std::cerr << command << ": " << why_not << "; using this machine's libraries\n";
    }
    if (from_daemon) {
      solved.library = from_daemon->library;
      solved.library_description = from_daemon->description;
    } else if (a.library_path == "nominal") {
      solved.library = calibration::nominal_led_library();
      solved.library_description = "nominal (built-in, --library nominal)";
    } else if (!a.library_path.empty()) {
      solved.library = calibration::load_led_library(a.library_path);
      solved.library_description = a.library_path;
    } else if (const auto latest = calibration::latest_led_library_path(); !latest.empty()) {
      solved.library = calibration::load_led_library(latest);
      solved.library_description = latest.string() + " (latest measured)";
    } else {
      std::cerr << command << ": no measured library in " << calibration::led_library_directory().string()
                << "; measuring one now on the virtual lab\n";
      const MeasuredOnVirtualLab measured = measure_on_virtual_lab({}, !a.json);
      if (!measured.summary.IsLibraryUsable()) {
        std::cerr << command << ": virtual-lab measurement failed: " << measured.summary.message << "\n";
        exit_status = kExitFailure;
        return std::nullopt;
      }
      solved.library = measured.summary.library;
      solved.library_description = measured.path.string() + " (measured now on the virtual lab)";
    }
  } catch (const spectral::DataError& e) {
    return bad(std::string("--library: ") + e.what());
  } catch (const std::exception& e) {
    std::cerr << command << ": " << e.what() << "\n";
    exit_status = kExitFailure;
    return std::nullopt;
  }
  calibration::MixTarget target;
  try {
    target = calibration::parse_mix_target(a.target, solved.library, options.camera);
  } catch (const spectral::DataError& e) {
    return bad(std::string("--target: ") + e.what());
  }
  solved.summary = calibration::solve_mix(solved.library, target, options);
  switch (solved.summary.termination) {
    case calibration::MixTermination::kOptimal: break;
    case calibration::MixTermination::kInfeasible:
    case calibration::MixTermination::kInvalidInput:
      return bad("--target " + a.target + ": " + std::string(calibration::mix_termination_name(solved.summary.termination)) +
                 ": " + solved.summary.message);
    case calibration::MixTermination::kIterationLimit:
      std::cerr << command << ": " << solved.summary.message << "\n";
      exit_status = kExitFailure;
      return std::nullopt;
  }
  return solved;
}

void add_leds_command(CLI::App& app, int& exit_status) {
  CLI::App* leds = app.add_subcommand("leds", "LED spectral library and mix solver (D65', W57+blue)");
  leds->require_subcommand(1);

  auto solve_args = std::make_shared<LedsSolveArguments>();
  CLI::App* solve = leds->add_subcommand("solve", "Solve LED drive weights for a target and print the figures of merit");
  add_solve_options(solve, *solve_args);
  solve->add_flag("--json", solve_args->json, "print one JSON object");
  solve->callback([solve_args, &exit_status] { exit_status = run_solve(*solve_args); });

  add_leds_measure_command(leds, exit_status);

  auto compare_paths = std::make_shared<std::array<std::string, 2>>();
  auto compare_json = std::make_shared<bool>(false);
  CLI::App* compare = leds->add_subcommand("compare", "Per-LED drift between two libraries, and the new one's linearity");
  compare->add_option("OLD", (*compare_paths)[0], "earlier library")->required();
  compare->add_option("NEW", (*compare_paths)[1], "later library")->required();
  compare->add_flag("--json", *compare_json, "print one JSON object");
  compare->callback([compare_paths, compare_json, &exit_status] {
    exit_status = run_compare((*compare_paths)[0], (*compare_paths)[1], *compare_json);
  });

  auto plot_args = std::make_shared<LedsSolveArguments>();
  plot_args->daemon_first = true;  // the library the daemon estimates with, when one runs
  CLI::App* plot = leds->add_subcommand("plot", "PNG of target vs mix spectra and per-patch camera dE00 (gnuplot) "
                                                "with chromod's LED library when a daemon runs");
  add_solve_options(plot, *plot_args);
  plot->add_option("--out", plot_args->out_png, "PNG file to write")->capture_default_str();
  plot->callback([plot_args, &exit_status] {
    const auto solved = solve_from_arguments(*plot_args, "chromo leds plot", exit_status);
    if (solved) exit_status = plot_mix(*solved, plot_args->out_png);
  });
}

}  // namespace chromo::cli
