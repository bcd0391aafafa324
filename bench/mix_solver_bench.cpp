// Mix solver: figures of merit per objective (the trade-off between spectral
// fit, what the camera sees and colour rendering) and solve time, with the
// production QP method (dual active set) against brute-force face
// enumeration of the same QP, in one run.
//
//   build/release/bin/mix_solver_bench [OUTPUT_DIR]   (default bench/results)
//
// Writes OUTPUT_DIR/mix_solver.csv and OUTPUT_DIR/mix_solver.png (gnuplot).
// Target (issue "Calibration"): one solve <= 1 ms.
#include <stdexcept>
#include <iostream>
#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "guarded_main.hpp"
#include "chromo/calibration/mix_solver.hpp"
#include "chromo/files/gnuplot_chart.hpp"
#include "chromo/spectral/colorimetry.hpp"

using namespace chromo::calibration;
using chromo::spectral::kLedTypeCount;

namespace {

// Median over `repeats` batches of the per-call time of f, in microseconds.
template <typename F>
double time_us(F&& f, int calls_per_batch = 50, int repeats = 15) {
  std::vector<double> batch_us;
  for (int r = 0; r < repeats; ++r) {
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < calls_per_batch; ++i) f();
    const auto stop = std::chrono::steady_clock::now();
    batch_us.push_back(std::chrono::duration<double, std::micro>(stop - start).count() / calls_per_batch);
  }
  std::nth_element(batch_us.begin(), batch_us.begin() + repeats / 2, batch_us.end());
  return batch_us[repeats / 2];
}

struct Case {
  std::string label;
  MixObjective objective;
  bool hold;
};

}  // namespace

static int bench_main(int argc, char** argv) {
  if (argc > 2 || (argc == 2 && argv[1][0] == '-'))
    throw std::invalid_argument(std::string("usage: mix_solver_bench [OUT_DIR] (default bench/results); got \"") +
                                argv[1] + "\"");
  const std::filesystem::path out_dir = argc > 1 ? argv[1] : "bench/results";
  std::filesystem::create_directories(out_dir);
  const LedLibrary library = nominal_led_library();
  const std::vector<Case> cases{{"spectral", MixObjective::kSpectral, false},
                                {"xyz", MixObjective::kColorimetric, false},
                                {"camera", MixObjective::kCamera, false},
                                {"camera+hold", MixObjective::kCamera, true}};
  const MixSolverOptions defaults;
  const std::vector<MixTarget> targets{d65_target(), w57_plus_blue_target(library, defaults.camera, 1.0),
                                       daylight_target(4000)};
  std::array<chromo::spectral::Spectrum, kLedTypeCount> spectra;
  std::array<double, kLedTypeCount> max_drive;
  for (int i = 0; i < kLedTypeCount; ++i)
    spectra[i] = library.leds[i].spectrum_per_unit_drive(), max_drive[i] = library.leds[i].max_drive_level;

  std::ofstream csv(out_dir / "mix_solver.csv");
  csv << "target,objective,rmse,camera_de00_mean,camera_de00_max,ra,delta_uv_prime,unreachable_deficit_percent,"
         "solve_mix_us,qp_dual_us,qp_enumeration_us,enumeration_over_dual,objective_rel_diff,stability32_us\n";
  std::printf("nominal LED library; camera %s; chart %s\n", defaults.camera.name.c_str(), defaults.chart.name.c_str());
  std::printf("%-11s %-12s %7s %8s %8s %6s %9s %8s | %9s %8s %10s %6s %9s %11s\n", "target", "objective", "RMSE",
              "dE00avg", "dE00max", "Ra", "du'v'", "unreach%", "solve_us", "QP_us", "enum_us", "ratio", "rel_diff",
              "stab32_us");
  for (const MixTarget& target : targets) {
    for (const Case& c : cases) {
      MixSolverOptions options;
      options.objective = c.objective;
      options.hold_chromaticity = c.hold;
      const MixSummary s = solve_mix(library, target, options);
      if (!s.IsSolutionUsable()) {
        std::printf("%-11s %-12s %s\n", target.name.c_str(), c.label.c_str(), s.message.c_str());
        continue;
      }
      // The QP alone, as solve_mix poses it (brightest-mix mode: no upper limits).
      const double y = chromo::spectral::xyz_of_light(target.spectrum).Y / target.spectrum.max();
      const MixProblem problem = build_mix_problem(spectra, max_drive, target.spectrum, y, options, false);
      const double solve_us = time_us([&] { volatile auto r = solve_mix(library, target, options).rmse; (void)r; });
      const double dual_us = time_us([&] { volatile auto r = solve_dual_active_set(problem.qp).objective; (void)r; }, 500);
      const double enum_us = time_us([&] { volatile auto r = solve_by_enumeration(problem.qp).objective; (void)r; }, 20, 7);
      const double rel_diff = std::abs(solve_dual_active_set(problem.qp).objective - solve_by_enumeration(problem.qp).objective) /
                              std::abs(solve_by_enumeration(problem.qp).objective);
      MixSolverOptions stable = options;
      stable.stability_trials = 32;
      const double stability_us = time_us([&] { volatile auto r = solve_mix(library, target, stable).rmse; (void)r; }, 3, 5);
      std::printf("%-11s %-12s %7.4f %8.3f %8.3f %6.2f %9.2e %8.2f | %9.1f %8.2f %10.1f %6.0fx %9.1e %11.0f\n",
                  target.name.c_str(), c.label.c_str(), s.rmse, s.camera_de00.mean, s.camera_de00.max, s.rendering.ra,
                  s.delta_uv_prime, 100 * s.unreachable_deficit_fraction, solve_us, dual_us, enum_us, enum_us / dual_us,
                  rel_diff, stability_us);
      csv << target.name << "," << c.label << "," << s.rmse << "," << s.camera_de00.mean << "," << s.camera_de00.max << ","
          << s.rendering.ra << "," << s.delta_uv_prime << "," << 100 * s.unreachable_deficit_fraction << "," << solve_us << ","
          << dual_us << "," << enum_us << "," << enum_us / dual_us << "," << rel_diff << "," << stability_us << "\n";
    }
  }
  csv.close();
  std::printf("solve_us: solve_mix with all figures of merit (CRI, ColorChecker dE00); QP_us: the QP alone (dual active set);\n"
              "enum_us: the same QP by face enumeration (independent check); ratio = enum/dual; rel_diff: |objective difference|/objective.\n"
              "stab32_us: solve_mix with 32 noisy re-solves for the weight std; unreach%%: target power the mix lacks in bands it cannot fill.\n");

  const std::string png = (out_dir / "mix_solver.png").string();
  const std::string data = (out_dir / "mix_solver.csv").string();
  const std::string script =
      "set datafile separator ','\nset key autotitle columnhead\nset grid\n"
      "set multiplot layout 1,2 title 'Mix solver trade-off, nominal LED library (D65 target; points: spectral, xyz, camera, camera+hold)'\n"
      "set xlabel 'spectral RMSE (fraction of target peak)'\nset ylabel 'camera ColorChecker dE00 (mean)'\n"
      "plot '" + data + "' every ::0::3 using 3:4:2 with labels point pt 7 ps 1.5 offset char 1,0.6 notitle, "
      "'' every ::0::3 using 3:4 with lines lw 1 dt 2 notitle\n"
      "set ylabel 'CIE Ra'\n"
      "plot '" + data + "' every ::0::3 using 3:6:2 with labels point pt 7 ps 1.5 offset char 1,0.6 notitle, "
      "'' every ::0::3 using 3:6 with lines lw 1 dt 2 notitle\n"
      "unset multiplot\n";
  if (const std::string failed = chromo::files::draw_chart({png, "pngcairo size 1200,520 font 'sans,10'", script}); !failed.empty()) {
    std::fprintf(stderr, "%s; figures are in %s\n", failed.c_str(), data.c_str());
    return 1;
  }
  std::printf("wrote %s and %s\n", data.c_str(), png.c_str());
  return 0;
}

int main(int argc, char** argv) { return chromo::bench::guarded_main("mix_solver_bench", bench_main, argc, argv); }
