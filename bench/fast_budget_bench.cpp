// The fast 4D inverter's budget against its accuracy, on the estimation
// bench's rendered 5-MP virtual-lab session (its 1.08 M skin cells,
// noise-free and noisy): the stopping settings of FastInverterOptions from
// the default (≤ 3 chord steps, ≤ 16 Gauss-Newton iterations, the search
// path where the pre-solved fit did not converge within the flag test's χ²
// 10.83), the previous default (the search path above χ² 4) and down to the
// pre-solved linear step alone, each run by the Estimator (fast, model 4d,
// 2 threads) on the same cells. Per budget: cells/s (wall, 2 threads), CPU
// µs per cell and core (process CPU time, steadier on a shared machine),
// relit ΔE94 against the truth (six LEDs + D65, D65 alone), D65 against the
// exhaustive search's (on a fixed subsample, as estimation_bench), the share
// of skin flagged and the mean χ² of the explained cells. This is the curve
// on which the two fast-method targets (≥ 10 MP/s on 2 cores, i.e.
// ≤ 0.2 µs CPU per cell, and D65 within 0.1 of exhaustive) are read off.
//
//   build/release/bin/fast_budget_bench [--out DIR] [--exhaustive-pixels N] [--scene-size W H]
//                                       [--frame-cache DIR | --no-frame-cache] [--budgets NAME,...]
//                                       [--whole-frame]
//
// The session is the one estimation_bench renders (same options, same disk
// cache: no rendering when cached). --budgets runs only the named budgets
// (e.g. for a profile of one; the first one run is the ratios' reference).
// --whole-frame: the fast budgets run on every cell of the frame (its
// tattoo, marker, hair and highlight cells take the flagging path: the
// speed a session gets), still scored on the skin cells, and the default's
// CPU time per cell of each scene region (one thread) is printed; the files
// are then fast_budget_whole_frame.{csv,png}. Writes DIR/fast_budget.csv and
// DIR/fast_budget.png (gnuplot); DIR defaults to bench/results.
#include <stdexcept>
#include <iostream>
#include <chrono>

#include "bench_cli.hpp"
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "guarded_main.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/estimation/estimator.hpp"
#include "chromo/files/gnuplot_chart.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "clocks.hpp"
#include "lab_session.hpp"
#include "relit_accuracy.hpp"

using namespace chromo;
using namespace chromo::estimation;
namespace fs = std::filesystem;

namespace {

struct Budget {
  const char* name;
  int newton_steps, chord_steps;
  bool search_fallback;
  double presolved_accept_chi2 = 0;  // 0: the default (the Estimator's 4D flag threshold)
};

// The default, the previous default's search trigger (a pre-solved fit above
// χ² 4 also searched), then down to the linear step alone (each a FastInverterOptions).
constexpr Budget kBudgets[] = {{"default", 16, 3, true},      {"accept-4", 16, 3, true, 4},
                               {"no-search", 16, 3, false},   {"GN-4", 4, 3, false},
                               {"GN-2", 2, 3, false},         {"GN-1", 1, 3, false},
                               {"chord-only", 0, 3, false},   {"linear-step", 0, 0, false}};

constexpr double kTargetCpuUsPerCell = 0.2;  // 10 MP/s on 2 cores
constexpr double kTargetD65VersusExhaustive = 0.1;

struct Row {
  std::string budget, noise;
  double cells_per_second = 0, cpu_us = 0, flagged_share = 0, mean_chi2 = 0;
  bench::Accuracy acc;
};

// The cells a run estimates (every step-th skin cell, or the whole frame) and
// the skin cells among them it is scored on (their index, truth and relit truth).
struct Cells {
  std::vector<float> measured;
  std::vector<std::size_t> scored;
  std::vector<SkinParameters> truth;
  bench::Relit relit;
};
Cells lab_cells(const simulators::RenderedSession& lab, const session::Measurement& m, const std::vector<std::size_t>& skin,
                const bench::Relit& skin_relit, std::size_t step, bool whole_frame) {
  Cells c;
  if (whole_frame) c.measured = m.measured;
  c.relit.lab.resize(skin_relit.lab.size());
  for (std::size_t k = 0; k < skin.size(); k += step) {
    if (whole_frame) {
      c.scored.push_back(skin[k]);
    } else {
      c.scored.push_back(c.measured.size() / 4);
      c.measured.insert(c.measured.end(), m.measured.begin() + skin[k] * 4, m.measured.begin() + skin[k] * 4 + 4);
    }
    c.truth.push_back(lab.truth[skin[k]]);
    for (std::size_t l = 0; l < skin_relit.lab.size(); ++l) c.relit.lab[l].push_back(skin_relit.lab[l][k]);
  }
  return c;
}

// Speed over every cell run; flags, χ² and accuracy over the scored skin cells.
Row run(const std::shared_ptr<const ForwardTable>& table, const MeasurementSet& set, const EstimatorOptions& options,
        const Cells& cells) {
  const Estimator estimator(table, set, options);
  std::vector<PixelEstimate> all(cells.measured.size() / 4);
  const bench::CpuClock cpu;
  const EstimateSummary summary = estimator.estimate(cells.measured, all);
  Row r;
  r.cpu_us = 1e6 * cpu.seconds() / all.size();
  r.cells_per_second = all.size() / summary.seconds;
  std::vector<PixelEstimate> e;
  for (std::size_t i : cells.scored) e.push_back(all[i]);
  std::size_t explained = 0;
  double chi2 = 0;
  for (const PixelEstimate& p : e)
    if (p.flag == PixelFlag::kExplained) chi2 += p.chi2, ++explained;
  r.flagged_share = 1.0 - double(explained) / e.size();
  r.mean_chi2 = chi2 / std::max<std::size_t>(explained, 1);
  r.acc = bench::accuracy(cells.relit, cells.truth, e, std::vector<bool>(e.size(), true));
  return r;
}

// --whole-frame: the default fast 4D Estimator's CPU time per cell of each
// scene region, one thread (thread CPU time): which cells a frame's time goes to.
void print_region_costs(const std::shared_ptr<const ForwardTable>& table, const simulators::RenderedSession& lab,
                        const session::Measurement& m, const char* noise) {
  EstimatorOptions eo;
  eo.method = InverterMethod::kFast, eo.model = ModelChoice::k4d, eo.threads = 1;
  const Estimator estimator(table, m.set, eo);
  std::printf("  %s, default budget, one thread, CPU µs per cell by region:", noise);
  for (int region = 0; region < 8; ++region) {
    std::vector<float> measured;
    for (std::size_t i = 0; i < lab.pixels(); ++i)
      if ((lab.region[i] == simulators::kMixedCell ? 7 : lab.region[i]) == region)
        measured.insert(measured.end(), m.measured.begin() + i * 4, m.measured.begin() + i * 4 + 4);
    if (measured.empty()) continue;
    std::vector<PixelEstimate> e(measured.size() / 4);
    const bench::ThreadCpuClock cpu;
    estimator.estimate_tile(measured, e);
    const double us = 1e6 * cpu.seconds() / e.size();
    std::printf(" %s %.2f (%zu)", region == 7 ? "mixed_cell" : simulators::region_name(static_cast<simulators::SceneRegion>(region)),
                us, e.size());
  }
  std::printf("\n");
}

}  // namespace

static int bench_main(int argc, char** argv) {
  fs::path out = fs::path(CHROMO_SOURCE_DIR) / "bench" / "results";
  fs::path frame_cache = ForwardTable::default_cache_dir();
  int exhaustive_pixels = 20000, sensor_width = 2592, sensor_height = 1944;
  std::string budgets;  // empty: all
  bool whole_frame = false, no_frame_cache = false;
  std::vector<int> scene_size;
  CLI::App app{"The fast 4D inverter's budget against accuracy on the lab session (see the source's header)"};
  app.add_option("--out", out, "where the CSV and the chart go");
  app.add_option("--exhaustive-pixels", exhaustive_pixels, "the exhaustive reference's subsample of skin cells");
  app.add_option("--scene-size", scene_size, "the virtual lab's sensor, W H")->expected(2);
  auto* cache = app.add_option("--frame-cache", frame_cache, "the rendered session's cache directory");
  app.add_flag("--no-frame-cache", no_frame_cache, "render the session, cache nothing")->excludes(cache);
  app.add_option("--budgets", budgets, "NAME,...: only these budgets (default: all)");
  app.add_flag("--whole-frame", whole_frame, "time the whole frame, not only the skin cells");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    const int status = app.exit(error);
    return status == 0 ? 0 : 2;
  }
  if (!budgets.empty()) budgets = "," + budgets + ",";
  if (!scene_size.empty()) sensor_width = scene_size[0], sensor_height = scene_size[1];
  if (no_frame_cache) frame_cache.clear();
  if (exhaustive_pixels < 1 || sensor_width < 16 || sensor_height < 16) {
    std::fprintf(stderr, "fast_budget_bench: --exhaustive-pixels must be >= 1 and --scene-size at least 16 16\n");
    return 2;
  }
  fs::create_directories(out);

  const simulators::RenderedSessionOptions ro = bench::lab_session_options(sensor_width, sensor_height, frame_cache);
  const simulators::RenderedSession lab = bench::load_lab_session(ro);
  const auto table = std::make_shared<const ForwardTable>(ForwardTable::build(lab.noisy.set, TableGrid{}, 2));
  std::vector<std::size_t> skin;
  for (std::size_t i = 0; i < lab.pixels(); ++i)
    if (lab.region[i] == static_cast<std::uint8_t>(simulators::SceneRegion::kSkin)) skin.push_back(i);
  std::vector<SkinParameters> skin_truth;
  for (std::size_t i : skin) skin_truth.push_back(lab.truth[i]);
  const bench::Relit skin_relit = bench::relight(skin_truth);
  const std::size_t stride = std::max<std::size_t>(1, skin.size() / exhaustive_pixels);
  std::printf("%zu skin cells; exhaustive 4d on every %zu-th (%zu cells)\n\n", skin.size(), stride,
              (skin.size() + stride - 1) / stride);

  std::vector<Row> rows;
  const std::string stem = whole_frame ? "fast_budget_whole_frame" : "fast_budget";
  std::ofstream csv(out / (stem + ".csv"));
  csv << "# budget noise cells_per_second cpu_us_per_cell de94_relit_mean de94_d65 d65_minus_exhaustive "
         "flagged_share mean_chi2\n";
  for (const bool noisy : {false, true}) {
    const session::Measurement& m = noisy ? lab.noisy : lab.noise_free;
    const char* noise = noisy ? "noisy" : "noise-free";
    EstimatorOptions exhaustive;
    exhaustive.method = InverterMethod::kExhaustive, exhaustive.model = ModelChoice::k4d, exhaustive.threads = 2;
    const Row ex = run(table, m.set, exhaustive, lab_cells(lab, m, skin, skin_relit, stride, false));
    std::printf("%s: exhaustive 4d %.1f CPU µs/cell, relit ΔE94 %.4f, D65 %.4f\n", noise, ex.cpu_us, ex.acc.de_all,
                ex.acc.de_d65);
    std::printf("  %-12s %11s %8s %9s %8s %9s %8s %8s %6s\n", "budget", "cells/s", "CPU µs", "x target", "relit",
                "D65", "D65-exh", "flagged", "chi2");
    if (whole_frame) print_region_costs(table, lab, m, noise);
    const Cells cells = lab_cells(lab, m, skin, skin_relit, 1, whole_frame);
    const std::size_t reference = rows.size();  // this noise's default budget
    for (const Budget& b : kBudgets) {
      if (!budgets.empty() && budgets.find("," + std::string(b.name) + ",") == std::string::npos) continue;
      EstimatorOptions eo;
      eo.method = InverterMethod::kFast, eo.model = ModelChoice::k4d, eo.threads = 2;
      eo.fast.newton_steps = b.newton_steps, eo.fast.chord_steps = b.chord_steps;
      eo.fast.search_fallback = b.search_fallback;
      if (b.presolved_accept_chi2 > 0) eo.fast.presolved_accept_chi2 = b.presolved_accept_chi2;
      Row r = run(table, m.set, eo, cells);
      r.budget = b.name, r.noise = noise;
      rows.push_back(r);
      const double versus = r.acc.de_d65 - ex.acc.de_d65;
      std::printf("  %-12s %11.0f %8.3f %9.2f %8.4f %9.4f %+8.4f %7.2f%% %6.2f   speed x%.2f of default, relit %+.4f\n",
                  b.name, r.cells_per_second, r.cpu_us, r.cpu_us / kTargetCpuUsPerCell, r.acc.de_all, r.acc.de_d65,
                  versus, 100 * r.flagged_share, r.mean_chi2, rows[reference].cpu_us / r.cpu_us,
                  r.acc.de_all - rows[reference].acc.de_all);
      csv << b.name << " " << noise << " " << r.cells_per_second << " " << r.cpu_us << " " << r.acc.de_all << " "
          << r.acc.de_d65 << " " << versus << " " << r.flagged_share << " " << r.mean_chi2 << "\n";
    }
    // The cheapest budget within each target, and whether one meets both.
    const Row* fastest_within = nullptr;
    for (const Row& r : rows)
      if (r.noise == noise && r.acc.de_d65 - ex.acc.de_d65 <= kTargetD65VersusExhaustive &&
          (!fastest_within || r.cpu_us < fastest_within->cpu_us))
        fastest_within = &r;
    if (fastest_within)
      std::printf("  %s: cheapest budget within D65 %.1f of exhaustive: %s, %.3f CPU µs per cell (%s the %.1f µs "
                  "target, x%.2f)\n\n",
                  noise, kTargetD65VersusExhaustive, fastest_within->budget.c_str(), fastest_within->cpu_us,
                  fastest_within->cpu_us <= kTargetCpuUsPerCell ? "meets" : "misses", kTargetCpuUsPerCell,
                  fastest_within->cpu_us / kTargetCpuUsPerCell);
  }
  csv.close();

  const fs::path script = out / (stem + ".gp");
  const std::string data = "'" + (out / (stem + ".csv")).string() + "'";
  std::ostringstream commands;
  commands
      << "set multiplot layout 1,3 title 'Fast 4D inverter: budget against accuracy on the 5-MP lab session, "
      << (whole_frame ? "speed over the whole frame, " : "") << "scored on its " << skin.size()
      << " skin cells (circles noise-free, squares noisy; dashed: the 0.2 µs target)'\n"
      << "set grid\nset logscale x\nset xlabel 'CPU µs per cell and core'\nset arrow from " << kTargetCpuUsPerCell
      << ", graph 0 to " << kTargetCpuUsPerCell << ", graph 1 nohead dt 2\n"
      << "set ylabel 'relit ΔE94 under D65 minus exhaustive (target <= 0.1)'\n"
      << "set arrow 2 from graph 0, first " << kTargetD65VersusExhaustive << " to graph 1, first "
      << kTargetD65VersusExhaustive << " nohead dt 2\n"
      << "plot " << data << " u 4:(stringcolumn(2) eq 'noise-free' ? $7 : 1/0):1 w labels point pt 7 offset 1,0.5 "
      << "font ',8' notitle, '' u 4:(stringcolumn(2) eq 'noisy' ? $7 : 1/0):1 w labels point pt 5 offset 1,-0.5 "
      << "font ',8' tc rgb 'red' notitle\n"
      << "unset arrow 2\nset ylabel 'mean relit ΔE94 (six LEDs + D65)'\n"
      << "plot " << data << " u 4:(stringcolumn(2) eq 'noise-free' ? $5 : 1/0):1 w labels point pt 7 offset 1,0.5 "
      << "font ',8' notitle, '' u 4:(stringcolumn(2) eq 'noisy' ? $5 : 1/0):1 w labels point pt 5 offset 1,-0.5 "
      << "font ',8' tc rgb 'red' notitle\n"
      << "set ylabel 'share of skin cells flagged'\n"
      << "plot " << data << " u 4:(stringcolumn(2) eq 'noise-free' ? $8 : 1/0):1 w labels point pt 7 offset 1,0.5 "
      << "font ',8' notitle, '' u 4:(stringcolumn(2) eq 'noisy' ? $8 : 1/0):1 w labels point pt 5 offset 1,-0.5 "
      << "font ',8' tc rgb 'red' notitle\nunset multiplot\n";
  const std::string failed =
      files::draw_chart({out / (stem + ".png"), "pngcairo noenhanced size 1400,500", commands.str()}, script);
  if (!failed.empty()) std::fprintf(stderr, "%s: no chart\n", failed.c_str());
  std::printf("wrote %s.csv and %s.png in %s\n", stem.c_str(), stem.c_str(), out.string().c_str());
  return 0;
}

int main(int argc, char** argv) { return chromo::bench::guarded_main("fast_budget_bench", bench_main, argc, argv); }
