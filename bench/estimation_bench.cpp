// Estimation: speed against accuracy for every inverter on the same frames
// (known truth), noise-free and with the camera noise model: synthetic
// frames (random in-gamut skin, the estimation library's noise model) and
// virtual-lab frames (the standard session rendered from the lab's physics,
// simulators/scene/rendered_session.hpp); where each method fails (noise level,
// distance outside the gamut, Ch against Che); table and inverse-table build
// times and interpolation error; anomaly and vein flag shares.
//
//   build/release/bin/estimation_bench [--pixels N] [--exhaustive-pixels N] [--full] [--out DIR]
//                                      [--baseline FILE] [--methods fast,2d,exhaustive,scene]
//                                      [--scene-size W H] [--frame-cache DIR | --no-frame-cache]
//                                      [--speed-only] [--diagnose | --diagnose-only]
//                                      [--timing-grid CM CH BM CHE]
//
// Synthetic: a 256×192 frame (49,152 pixels) for the fast and 2D inverters,
// the exhaustive search on a fixed subsample of its first --exhaustive-pixels
// (default 20,000, the issue's); --full: a 5-megapixel synthetic frame.
// Virtual lab: a --scene-size sensor (default 2592×1944 = 5 MP, BayerRG12),
// the scene rendered at that size (truth per site), binned 2×2 and measured
// by the daemon's path into a 1296×972 measurement; every method on its skin
// cells (exhaustive on a fixed subsample of --exhaustive-pixels of them),
// fast 4D also on the whole frame; flag shares per scene region. Rendering
// takes minutes on 2 cores: the session is cached in --frame-cache (default
// ForwardTable::default_cache_dir()), keyed by its inputs.
// --methods: which of the synthetic runs (fast, 2d, exhaustive) and whether
// the virtual lab runs at all ("scene"); --speed-only skips the interpolation check and the
// failure sections; --diagnose: one thread, CPU time, how the fast
// inverter's fits end and where its time goes (cold and hot caches, the
// Estimator's share, one interpolation, the previous stopping rules against
// today's back to back; per path and inverse-table cell kind on the
// synthetic and the lab skin cells; the auto model's 2D fit by the search
// path against the pre-solved one, back to back on 200,000 lab skin cells); --diagnose-only: that and no method
// runs (nothing written); the environment variable HOT_REPEATS (default 100)
// sets how often the hot-cache measurement refits its 256 pixels. The summary lines give each fast 4D run's CPU time
// per pixel and core against the 200 ns that 10 MP/s on 2 cores needs.
// Speeds: wall clock of Estimator::estimate on 2 threads (pixels/s) and the
// process CPU time per pixel (both threads), steadier on a shared machine.
// Writes DIR/estimation_bench.json, *.csv and two PNG charts (gnuplot), DIR
// defaults to bench/results.
// --timing-grid: the table grid whose forward and inverse tables are timed
// (default the full 41×41×21×21 grid, which the methods always use; the
// ctest smoke times an 11×11×11×11 one so that its two inverse-table builds
// take seconds, not ~45 s).
// --baseline FILE: the estimation_speed_accuracy.csv of another build's run
// (e.g. the previous version of the inverters, run just before on the same
// machine): its points go on the speed/accuracy chart next to this run's,
// labelled "old ...", and the run prints new/old ratios per configuration.

#include <stdexcept>
#include <iostream>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include "bench_cli.hpp"
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <unordered_set>
#include <vector>

#include "guarded_main.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/estimation/estimator.hpp"
#include "chromo/files/gnuplot_chart.hpp"
#include "chromo/estimation/inverse_table.hpp"
#include "chromo/spectral/lab_illuminants.hpp"
#include "chromo/maps/reconstruction.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/estimation/spatial_flags.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "chromo/spectral/delta_e.hpp"
#include "clocks.hpp"
#include "interpolation_cost.hpp"
#include "lab_session.hpp"
#include "relit_accuracy.hpp"

using namespace chromo;
using namespace chromo::estimation;
using bench::Accuracy;
using bench::CpuClock;
using bench::ThreadCpuClock;
using bench::Relit;
using bench::accuracy;
using bench::relight;
using bench::seconds_since;
namespace fs = std::filesystem;

namespace {

// Every inverter, as the bench runs them (same order in every table).
struct MethodConfig {
  InverterMethod method;
  ModelChoice model;
};
constexpr MethodConfig kMethodConfigs[] = {{InverterMethod::kFast, ModelChoice::k4d},
                                           {InverterMethod::kFast, ModelChoice::kAuto},
                                           {InverterMethod::k2d, ModelChoice::k2d},
                                           {InverterMethod::kExhaustive, ModelChoice::k4d}};

MeasurementSet method_set() {
  return method_measurement_set(spectral::builtin_camera("nikon_d5100"), spectral::led_d65_metamer(),
                                spectral::led_spectrum(spectral::LedType::kBlue));
}

struct RunResult {
  std::string method, model, noise;
  double pixels_per_second = 0;
  std::size_t pixels = 0, flagged = 0, order2 = 0, order4 = 0;
  Accuracy acc;
  double cpu_us_per_pixel = 0;  // process CPU time (both threads) per pixel
};

// 10 MP/s on 2 cores is 200 ns of CPU per pixel and core.
constexpr double kTargetCpuUsPerPixel = 0.2;

// Estimator::estimate_tile on the calling thread: CPU ns per pixel, best of
// `rounds` (the least disturbed by other processes); the last round's estimates in *estimates when given.
double estimator_cpu_ns(const Estimator& estimator, std::span<const float> measured, int rounds = 3,
                        std::vector<PixelEstimate>* estimates = nullptr) {
  std::vector<PixelEstimate> local;
  std::vector<PixelEstimate>& e = estimates ? *estimates : local;
  e.resize(measured.size() / estimator.channels());
  double best = 1e30;
  for (int r = 0; r < rounds; ++r) {
    const ThreadCpuClock cpu;
    estimator.estimate_tile(measured, e);
    best = std::min(best, cpu.seconds());
  }
  return 1e9 * best / e.size();
}

// The auto model (fast, one thread) with its 2D fit by the search path
// (FastInverterOptions::presolved_slice false, the previous rule) and from
// the cell's pre-solved 2D fit (the default), back to back on `measured`:
// CPU per cell (best of two rounds each), the share of order 2, the mean χ²
// of the chosen fits and of the order statistic χ²₂ − χ²₄, and the cells
// whose order or flag differ.
nlohmann::ordered_json diagnose_auto_slice(std::shared_ptr<const ForwardTable> table, const MeasurementSet& set,
                                           std::span<const float> measured, const char* label) {
  const std::size_t n = measured.size() / 4;
  std::vector<PixelEstimate> e[2];
  double ns[2], order2[2], chi2[2], statistic[2];
  for (int presolved : {0, 1}) {
    EstimatorOptions eo;
    eo.method = InverterMethod::kFast;
    eo.model = ModelChoice::kAuto;
    eo.threads = 1;
    eo.fast.presolved_slice = presolved;
    const Estimator estimator(table, set, eo);
    ns[presolved] = estimator_cpu_ns(estimator, measured, 2, &e[presolved]);
    order2[presolved] = chi2[presolved] = statistic[presolved] = 0;
    for (const PixelEstimate& p : e[presolved])
      order2[presolved] += p.order == 2, chi2[presolved] += p.chi2, statistic[presolved] += p.order_statistic;
  }
  std::size_t order_differs = 0, flag_differs = 0;
  for (std::size_t i = 0; i < n; ++i)
    order_differs += e[0][i].order != e[1][i].order, flag_differs += e[0][i].flag != e[1][i].flag;
  std::printf("diagnose %s: auto model (one thread) %.0f CPU ns/cell with the 2D fit by the search path -> %.0f "
              "from the pre-solved 2D fit: x%.2f on %zu cells; order 2 %.2f%% -> %.2f%%, mean chi2 %.4f -> %.4f, "
              "mean chi2_2 - chi2_4 %.4f -> %.4f; order differs on %zu, flag on %zu\n",
              label, ns[0], ns[1], ns[0] / ns[1], n, 100 * order2[0] / n, 100 * order2[1] / n, chi2[0] / n, chi2[1] / n,
              statistic[0] / n, statistic[1] / n, order_differs, flag_differs);
  return {{"cells", n}, {"search_ns", ns[0]}, {"presolved_ns", ns[1]}, {"order2_search", order2[0] / n},
          {"order2_presolved", order2[1] / n}, {"order_differs", order_differs}, {"flag_differs", flag_differs}};
}

// The weights' model error, as the Estimator's default.
const double kModelSigmaRelative = EstimatorOptions{}.model_sigma_relative;

// The fast inverter's options as the Estimator completes them for `set`
// (its inverse table's pre-solved fits weigh with the set's noise).
FastInverterOptions fast_options_for(const MeasurementSet& set) {
  FastInverterOptions options;
  options.inverse_table = options.inverse_table.completed_for(set);
  return options;
}

// --diagnose on a frame's cells (one thread, thread CPU time): where the
// fast 4D fit's time goes. Cells are grouped by their inverse-table cell:
// one holding table nodes itself ("occupied"), an empty one pointing at a
// neighbour ("empty"), none (outside the key box, non-finite). Per group, the
// pre-solved path runs on all its cells, then the search path on those where
// fit() would run it too, each pass timed as a whole (per-cell clock reads
// would cost more than a fit).
nlohmann::ordered_json diagnose_fast_paths(const FastInverter& fast, const MeasurementSet& set,
                                           std::span<const float> measured, const char* label) {
  const std::size_t n = measured.size() / 4;
  std::vector<double> m(n * 4), w(n * 4);
  for (std::size_t i = 0; i < n * 4; ++i) {
    m[i] = measured[i];
    w[i] = set.channels[i % 4].noise.fit_weight(m[i], kModelSigmaRelative);
  }
  const char* names[3] = {"occupied", "empty", "none"};
  std::vector<std::size_t> group[3];
  std::unordered_set<std::uint32_t> boxes[3];  // distinct key-box cells reached per group
  for (std::size_t i = 0; i < n; ++i) {
    const float mf[4] = {measured[i * 4], measured[i * 4 + 1], measured[i * 4 + 2], measured[i * 4 + 3]};
    const int g = fast.inverse_table().cell_of(mf) == InverseTable::kNoCell ? 2 : fast.in_occupied_cell(&m[i * 4]) ? 0 : 1;
    group[g].push_back(i);
    boxes[g].insert(fast.inverse_table().box_of(mf));
  }
  const ThreadCpuClock thread_clock;
  auto thread_seconds = [&] { return thread_clock.seconds(); };
  const FastInverterOptions& o = fast.options();
  nlohmann::ordered_json out = {{"cells", n}};
  double total_s = 0;
  std::string lines;
  for (int k = 0; k < 3; ++k) {
    const std::vector<std::size_t>& cells = group[k];
    if (cells.empty()) continue;
    std::vector<Fit> presolved(cells.size());
    std::vector<char> converged(cells.size());
    const double t0 = thread_seconds();
    for (std::size_t j = 0; j < cells.size(); ++j)
      converged[j] = fast.fit_presolved(&m[cells[j] * 4], &w[cells[j] * 4], presolved[j]);
    const double t1 = thread_seconds();
    std::vector<std::size_t> searched;
    for (std::size_t j = 0; j < cells.size(); ++j)
      if (!(converged[j] && presolved[j].chi2 <= o.presolved_accept_chi2)) searched.push_back(j);
    std::vector<Fit> search(searched.size());
    const double t2 = thread_seconds();
    for (std::size_t j = 0; j < searched.size(); ++j)
      search[j] = fast.fit_by_search(&m[cells[searched[j]] * 4], &w[cells[searched[j]] * 4], 4);
    const double t3 = thread_seconds();
    total_s += (t1 - t0) + (t3 - t2);
    double chi2 = 0, iterations = 0, before = 0, after = 0;
    std::size_t unconverged = 0, better_01 = 0, better_1 = 0;
    for (std::size_t j = 0; j < cells.size(); ++j) chi2 += presolved[j].chi2, iterations += presolved[j].iterations;
    for (std::size_t j = 0; j < cells.size(); ++j) unconverged += !converged[j];
    for (std::size_t j = 0; j < searched.size(); ++j) {
      const Fit& p = presolved[searched[j]];
      const double pre = std::isfinite(p.chi2) ? p.chi2 : 0, best = std::min(search[j].chi2, p.chi2);
      chi2 += best - p.chi2;
      before += pre, after += best;
      better_01 += search[j].chi2 < p.chi2 - 0.1, better_1 += search[j].chi2 < p.chi2 - 1;
    }
    const double share = double(cells.size()) / n, searched_share = double(searched.size()) / cells.size();
    const double pre_ns = 1e9 * (t1 - t0) / n, search_ns = 1e9 * (t3 - t2) / n;
    char line[600];
    std::snprintf(line, sizeof line,
                  "  %-8s %6.2f%% of cells (%zu distinct inverse-table cells): pre-solved path %5.0f ns each (GN iterations %.2f, unconverged %.2f%%); "
                  "searched %5.2f%% of them, %6.0f ns each (chi2 %.2f -> %.2f, lowered by > 0.1 on %.1f%%, by > 1 "
                  "on %.1f%%); per cell of the frame: pre-solved %4.0f + search %4.0f ns; final mean chi2 %.3f\n",
                  names[k], 100 * share, boxes[k].size(), 1e9 * (t1 - t0) / cells.size(), iterations / cells.size(),
                  100.0 * unconverged / cells.size(), 100 * searched_share,
                  searched.empty() ? 0.0 : 1e9 * (t3 - t2) / searched.size(), searched.empty() ? 0.0 : before / searched.size(),
                  searched.empty() ? 0.0 : after / searched.size(), searched.empty() ? 0.0 : 100.0 * better_01 / searched.size(),
                  searched.empty() ? 0.0 : 100.0 * better_1 / searched.size(), pre_ns, search_ns, chi2 / cells.size());
    lines += line;
    out[names[k]] = {{"share", share}, {"distinct_cells", boxes[k].size()}, {"searched_share", searched_share}, {"presolved_ns_per_frame_cell", pre_ns},
                     {"search_ns_per_frame_cell", search_ns}, {"mean_chi2", chi2 / cells.size()}};
  }
  std::printf("diagnose %s: %zu cells, fast 4d fit %.0f ns/cell CPU (one thread)\n%s", label, n, 1e9 * total_s / n,
              lines.c_str());
  out["cpu_ns_per_cell"] = 1e9 * total_s / n;
  return out;
}

nlohmann::ordered_json to_json(const RunResult& r) {
  return {{"method", r.method},       {"model", r.model},
          {"noise", r.noise},         {"pixels", r.pixels},
          {"pixels_per_second", r.pixels_per_second},
          {"flagged", r.flagged},     {"order2", r.order2},
          {"order4", r.order4},       {"de94_relit_mean", r.acc.de_all},
          {"de94_d65", r.acc.de_d65}, {"de94_per_illuminant", std::vector<double>(r.acc.de_led, r.acc.de_led + 7)},
          {"abs_log10_cm", r.acc.log_cm}, {"abs_log10_ch", r.acc.log_ch},
          {"abs_bm", r.acc.bm},       {"abs_che", r.acc.che},
          {"cpu_us_per_pixel", r.cpu_us_per_pixel}};
}

// One line of a previous run's estimation_speed_accuracy.csv.
struct BaselineRun {
  std::string label, model, noise;
  double pixels_per_second = 0, de_all = 0, de_d65 = 0;
};

std::vector<BaselineRun> read_baseline(const fs::path& file) {
  std::vector<BaselineRun> runs;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    BaselineRun r;
    if (fields >> r.label >> r.model >> r.noise >> r.pixels_per_second >> r.de_all >> r.de_d65) runs.push_back(r);
  }
  return runs;
}

// Draws a chart (files/gnuplot_chart.hpp), its script kept beside it; a
// missing gnuplot is reported, not fatal: the figures are printed and in CSV.
void draw(const fs::path& png, const std::string& terminal, const std::string& commands) {
  const std::string failed = files::draw_chart({png, terminal, commands}, fs::path(png).replace_extension(".gp"));
  if (!failed.empty()) std::fprintf(stderr, "%s: no chart\n", failed.c_str());
}


// The command line (main() parses it with CLI11; the file's header says what each option does).
struct Options {
  int width = 256, height = 192;  // the synthetic frame (--pixels N: N×1; --full: 2592×1944)
  int exhaustive_pixels = 20000;
  fs::path out = fs::path(CHROMO_SOURCE_DIR) / "bench" / "results";
  fs::path baseline;
  std::string methods = "fast,2d,exhaustive,scene";
  int scene_width = 2592, scene_height = 1944;
  bool speed_only = false, diagnose = false, diagnose_only = false;
  fs::path frame_cache = ForwardTable::default_cache_dir();
  // The grid whose forward and inverse tables measure_tables times (the full
  // grid by default; the ctest smoke times a coarse one: the two inverse-table
  // builds on the full grid were ~45 s of its ~48).
  TableGrid timing_grid;
  bool selects(const std::string& name) const { return methods.find(name) != std::string::npos; }
};

// What the sections of one run share: the options, the report
// (estimation_bench.json), the speed/accuracy CSV and the runs in it, and
// the method set's table.
struct BenchRun {
  explicit BenchRun(const Options& run_options) : options(run_options) {}
  const Options& options;
  int pixels = 0, exhaustive_pixels = 0;  // the synthetic frame's, and the exhaustive subsample (≤ pixels)
  nlohmann::ordered_json report;
  std::ofstream speed_csv;
  std::vector<RunResult> runs, scene_runs;
  std::shared_ptr<const ForwardTable> table;
};

// The virtual-lab session and what every lab section uses of it.
struct LabFrames {
  simulators::RenderedSessionOptions ro;
  simulators::RenderedSession lab;
  std::shared_ptr<const ForwardTable> lab_table;  // on the measurement's own illuminants
  std::vector<std::size_t> skin;                  // the skin cells
  std::vector<SkinParameters> skin_truth;         // their truth
  Relit skin_relit;                               // relit from their truth
};

// Table: build time (2 threads, full grid) and cache load time; the fast
// inverter's inverse table: build and load time, file size. Returns the
// method set's table.
std::shared_ptr<const ForwardTable> measure_tables(BenchRun& run) {
  auto& report = run.report;
  MeasurementSet set = method_set();
  const TableGrid& grid = run.options.timing_grid;
  auto t = std::chrono::steady_clock::now();
  auto table = std::make_shared<const ForwardTable>(ForwardTable::build(set, grid, 2));
  const double build_s = seconds_since(t);
  const fs::path cache = fs::temp_directory_path() / "chromo_bench_cache";
  fs::remove_all(cache);
  ForwardTable::load_or_build(set, grid, cache, nullptr, 2);
  t = std::chrono::steady_clock::now();
  bool rebuilt = true;
  ForwardTable::load_or_build(set, grid, cache, &rebuilt, 2);
  const double load_s = seconds_since(t);
  fs::remove_all(cache);
  std::printf("table: %zu nodes (%dx%dx%dx%d), build %.3f s on 2 threads (target <= 2 s on the full grid), cache load "
              "%.3f s (rebuilt=%d)\n",
              grid.node_count(), grid.cm_nodes, grid.ch_nodes, grid.bm_nodes, grid.che_nodes, build_s, load_s, rebuilt);
  report["table"] = {{"nodes", grid.node_count()}, {"build_s", build_s}, {"cache_load_s", load_s}};
  {
    // The fast inverter's inverse table: build (2 threads) and write, then a
    // load from the file (another directory: the process-wide registry only
    // shares tables of the same file).
    fs::remove_all(cache);
    t = std::chrono::steady_clock::now();
    bool inverse_rebuilt = false;
    const InverseTableSettings inverse_settings = fast_options_for(set).inverse_table;  // as the Estimator builds it
    const auto inverse = InverseTable::load_or_build(table, cache, &inverse_rebuilt, nullptr, 2, inverse_settings);
    const double inverse_build_s = seconds_since(t);
    const fs::path copy = cache.string() + "_copy";
    fs::remove_all(copy);
    fs::copy(cache, copy);
    t = std::chrono::steady_clock::now();
    InverseTable::load_or_build(table, copy, &inverse_rebuilt, nullptr, 0, inverse_settings);
    const double inverse_load_s = seconds_since(t);
    // The same build without the empty cells' pre-solved branches (the previous table), for the cost.
    fs::remove_all(cache);
    InverseTableSettings without = inverse_settings;
    without.presolve_empty_cells = false;
    t = std::chrono::steady_clock::now();
    InverseTable::load_or_build(table, cache, nullptr, nullptr, 2, without);
    const double plain_build_s = seconds_since(t);
    const double file_mb = fs::file_size(copy / InverseTable::file_name(InverseTable::cache_key(*table, inverse_settings))) / 1e6;
    const double plain_mb = fs::file_size(cache / InverseTable::file_name(InverseTable::cache_key(*table, without))) / 1e6;
    std::printf("inverse table: %zu occupied cells, %zu pre-solved empty cells, %zu branches, %.1f%% of the key box "
                "reached; build %.2f s on 2 threads (%.2f s without the empty cells' pre-solve), cache load %.3f s "
                "(rebuilt=%d), file %.1f MB (%.1f MB without)\n",
                inverse->occupied_cells(), inverse->presolved_empty_cells(), inverse->branch_count(),
                100 * inverse->filled_share(), inverse_build_s, plain_build_s, inverse_load_s, inverse_rebuilt, file_mb,
                plain_mb);
    report["inverse_table"] = {{"occupied_cells", inverse->occupied_cells()},
                               {"presolved_empty_cells", inverse->presolved_empty_cells()},
                               {"branches", inverse->branch_count()},
                               {"build_s", inverse_build_s},
                               {"build_s_without_presolve", plain_build_s},
                               {"cache_load_s", inverse_load_s},
                               {"file_mb", file_mb}};
    fs::remove_all(copy);
    fs::remove_all(cache);
  }
  // The methods run on the full grid's table whatever grid was timed.
  if (grid.node_count() == TableGrid{}.node_count()) return table;
  return std::make_shared<const ForwardTable>(ForwardTable::build(set, TableGrid{}, 2));
}

// Interpolation error of the grid in colour (XYZ table under D65 vs direct model).
void measure_interpolation_error(BenchRun& run) {
  auto& report = run.report;
  const spectral::Observer& o = spectral::cie1931_observer();
  const MeasurementSet xyz = rgb_measurement_set({"cie1931", {o.x_bar, o.y_bar, o.z_bar}}, spectral::illuminant_d65());
  const ForwardTable xt = ForwardTable::build(xyz, TableGrid{}, 2);
  const auto p = simulators::random_skin_parameters(20000, {0.001, 0.001, 0, 0}, {0.5, 0.32, 1, 0.1}, 3);
  std::vector<spectral::Spectrum> albedo(p.size());
  SkinModel().albedo_batch(p, albedo, 2);
  const spectral::Xyz white = spectral::white_point(spectral::illuminant_d65());
  std::vector<double> de;
  for (std::size_t i = 0; i < p.size(); ++i) {
    double v[3];
    xt.predict(xt.to_grid(p[i]), v);
    de.push_back(spectral::delta_e94(
        spectral::lab_from_xyz(spectral::xyz_of_reflectance(albedo[i], spectral::illuminant_d65()), white),
        spectral::lab_from_xyz({v[0] * white.X, v[1] * white.Y, v[2] * white.Z}, white)));
  }
  const maps::DeltaEStats s = maps::delta_e_stats(de);
  std::printf("table interpolation error under D65 (20,000 random parameter sets, full range): mean ΔE94 %.4f "
              "(target <= 0.02), median %.4f, p95 %.4f, max %.3f\n", s.mean, s.median, s.p95, s.max);
  report["interpolation_de94_d65"] = {{"mean", s.mean}, {"median", s.median}, {"p95", s.p95}, {"max", s.max}};
}

// --diagnose on a synthetic frame (one thread, CPU time): how the fast
// inverter's fits end and their cost. False when the AVX2 gather
// interpolation differs from predict4 (the run then fails).
bool diagnose_synthetic(BenchRun& run, const MeasurementSet& s, const simulators::SyntheticFrame& f, double noise) {
  auto& report = run.report;
  const auto& table = run.table;
  // One thread, CPU time: how the fast inverter's fits end, and their cost.
  const FastInverter fast(table, fs::path{}, fast_options_for(s));
  const std::size_t n = std::min<std::size_t>(f.pixels(), 50000);
  std::size_t counts[2] = {}, no_cell = 0, iteration_sum = 0;
  double chi2_sum = 0;
  const ThreadCpuClock fit_clock;
  for (std::size_t i = 0; i < n; ++i) {
    double m[4], w[4];
    const std::vector<float>& v = noise > 0 ? f.noisy : f.clean;
    for (int c = 0; c < 4; ++c) {
      m[c] = v[i * 4 + c];
      w[c] = s.channels[c].noise.fit_weight(m[c], kModelSigmaRelative);
    }
    FastPath path;
    const float mf[4] = {float(m[0]), float(m[1]), float(m[2]), float(m[3])};
    no_cell += fast.inverse_table().cell_of(mf) == InverseTable::kNoCell;
    const Fit fit = fast.fit(m, w, 4, &path);
    chi2_sum += fit.chi2;
    iteration_sum += fit.iterations;
    ++counts[static_cast<int>(path)];
  }
  const double cpu = fit_clock.seconds();
  {
    // The same 256 pixels again and again: the tables' lines stay in cache.
    const ThreadCpuClock hot_clock;
    double sink = 0;
    const int hot_repeats = std::getenv("HOT_REPEATS") ? std::atoi(std::getenv("HOT_REPEATS")) : 100;
    for (int repeat = 0; repeat < hot_repeats; ++repeat)
      for (std::size_t i = 0; i < 256; ++i) {
        double m[4], w[4];
        const std::vector<float>& v = noise > 0 ? f.noisy : f.clean;
        for (int c = 0; c < 4; ++c) {
          m[c] = v[i * 4 + c];
          w[c] = s.channels[c].noise.fit_weight(m[c], kModelSigmaRelative);
        }
        sink += fast.fit(m, w, 4).chi2;
      }
    const double hot_s = hot_clock.seconds();
    {
      float acc = 0;
      const ThreadCpuClock predict_clock;
      for (int i = 0; i < 1000000; ++i) {
        const float x[4] = {float(i % 37) + 0.3f, float(i % 29) + 0.6f, float(i % 13) + 0.2f, float(i % 7) + 0.5f};
        float v[4], j[16];
        fast.predict4(x, v, (i & 1) ? j : nullptr);
        acc += v[0] + ((i & 1) ? j[5] : 0);
      }
      std::printf("predict4: %.1f ns per call (%g)\n", 1e9 * predict_clock.seconds() / 1e6, acc);
    }
    if (!bench::print_interpolation_costs(fast)) {
      std::fprintf(stderr, "estimation_bench: the AVX2 gather interpolation differs from predict4 by more than 1e-5\n");
      return false;
    }
    std::printf("diagnose: hot cache %.0f ns/px (%g)\n", 1e9 * hot_s / (256.0 * hot_repeats), sink);
  }
  {
    EstimatorOptions eo;
    eo.method = InverterMethod::kFast;
    eo.model = ModelChoice::k4d;
    eo.threads = 1;
    const Estimator estimator(table, s, eo);
    std::vector<PixelEstimate> e(n);
    const ThreadCpuClock estimate_clock;
    estimator.estimate_tile(std::span(noise > 0 ? f.noisy : f.clean).first(n * 4), e);
    const double estimate_s = estimate_clock.seconds();
    std::printf("diagnose: Estimator::estimate_tile (4d, one thread) %.0f ns/px CPU\n", 1e9 * estimate_s / n);
    // The same, back to back, with the fast inverter's previous stopping
    // rules (no chord steps, no face stall) and today's defaults: best of
    // three rounds each, so that the ratio survives a shared machine.
    EstimatorOptions previous = eo;
    previous.fast.chord_steps = 0;
    previous.fast.face_stall_relative = 0;
    const auto frame = std::span<const float>(noise > 0 ? f.noisy : f.clean).first(n * 4);
    const double before_ns = estimator_cpu_ns(Estimator(table, s, previous), frame);
    const double after_ns = estimator_cpu_ns(estimator, frame);
    std::printf("diagnose: Estimator 4d CPU ns/px, previous stopping rules (chord_steps 0, face_stall_relative 0) %.0f "
                "-> defaults (chord_steps %d, face_stall_relative %.2f) %.0f: x%.2f; target %.0f: x%.1f to go\n",
                before_ns, eo.fast.chord_steps, eo.fast.face_stall_relative, after_ns, before_ns / after_ns,
                1e3 * kTargetCpuUsPerPixel, after_ns / (1e3 * kTargetCpuUsPerPixel));
    report[std::string("diagnose_") + (noise > 0 ? "noisy" : "noise_free")] = {
        {"estimator_cpu_ns_previous_rules", before_ns}, {"estimator_cpu_ns", after_ns}};
  }
  report[std::string("diagnose_paths_") + (noise > 0 ? "noisy" : "noise_free")] = diagnose_fast_paths(
      fast, s, std::span<const float>(noise > 0 ? f.noisy : f.clean).first(n * 4),
      noise > 0 ? "synthetic noisy" : "synthetic noise-free");
  std::printf("diagnose %s: %zu px, %.0f ns/px CPU (one thread), presolved %.2f%% searched %.2f%%, "
              "mean chi2 %.4f, outside the inverse table %.2f%%, mean iterations %.2f\n", noise > 0 ? "noisy" : "noise-free", n, 1e9 * cpu / n, 100.0 * counts[0] / n,
              100.0 * counts[1] / n, chi2_sum / n, 100.0 * no_cell / n, double(iteration_sum) / n);
  return true;
}

// Each selected method on a synthetic frame: a printed line, a CSV row and a report entry.
void run_synthetic_methods(BenchRun& run, const MeasurementSet& s, const simulators::SyntheticFrame& f, double noise,
                           double floor, const Relit& truth) {
  const std::string& methods = run.options.methods;
  const bool diagnose_only = run.options.diagnose_only;
  const int exhaustive_pixels = run.exhaustive_pixels;
  const auto& table = run.table;
  auto& report = run.report;
  auto& speed_csv = run.speed_csv;
  auto& runs = run.runs;
  for (const MethodConfig& c : kMethodConfigs) {
    if (diagnose_only || methods.find(method_name(c.method)) == std::string::npos) continue;
    EstimatorOptions eo;
    eo.method = c.method;
    eo.model = c.model;
    eo.threads = 2;
    const Estimator estimator(table, s, eo);
    const std::size_t n = c.method == InverterMethod::kExhaustive ? exhaustive_pixels : f.pixels();
    std::vector<PixelEstimate> e(n);
    const CpuClock cpu;
    const EstimateSummary summary =
        estimator.estimate(std::span(noise > 0 ? f.noisy : f.clean).first(n * 4), e);
    RunResult r{std::string(method_name(c.method)), std::string(model_name(c.model)), noise > 0 ? "noisy" : "noise-free", 0, 0, 0, 0, 0, {}};
    r.pixels = n;
    r.pixels_per_second = n / summary.seconds;
    r.cpu_us_per_pixel = 1e6 * cpu.seconds() / n;
    r.flagged = n - summary.flag_counts[0];
    r.order2 = summary.order2, r.order4 = summary.order4;
    Relit truth_n;
    for (const auto& l : truth.lab) truth_n.lab.emplace_back(l.begin(), l.begin() + n);
    r.acc = accuracy(truth_n, std::span(f.truth).first(n), e, std::vector<bool>(n, true));
    std::printf("%-10s %-4s %-10s %9zu px %11.0f px/s %7.2f CPU us/px  relit ΔE94 %.4f (D65 %.4f)%s  |Δlog10 Cm| %.4f "
                "|Δlog10 Ch| %.4f |ΔβM| %.3f |ΔChe| %.4f  flagged %.2f%%\n",
                r.method.c_str(), r.model.c_str(), r.noise.c_str(), n, r.pixels_per_second, r.cpu_us_per_pixel, r.acc.de_all,
                r.acc.de_d65, noise > 0 ? (" = " + std::to_string(r.acc.de_all / floor).substr(0, 5) + "× floor").c_str() : "",
                r.acc.log_cm, r.acc.log_ch, r.acc.bm, r.acc.che, 100.0 * r.flagged / n);
    speed_csv << r.method << "/" << r.model << " " << r.model << " " << r.noise << " " << r.pixels_per_second << " "
              << r.acc.de_all << " " << r.acc.de_d65 << " " << r.acc.log_cm << " " << r.acc.log_ch << " " << r.acc.bm
              << " " << r.acc.che << "\n";
    runs.push_back(r);
    report["runs"].push_back(to_json(r));
  }
}

// Speed/accuracy on synthetic in-gamut skin, noise-free and noisy (and
// --diagnose on each). False when the diagnosis failed.
bool run_synthetic(BenchRun& run) {
  auto& report = run.report;
  const int pixels = run.pixels;
  for (double noise : {0.0, 1.0}) {
    simulators::SyntheticOptions o;
    o.pixels = pixels;
    o.noise.noise_scale = noise;
    o.threads = 2;
    MeasurementSet s = method_set();
    const simulators::SyntheticFrame f = simulators::make_synthetic_frame(s, o);
    const Relit truth = relight(f.truth);
    const std::vector<bool> all(f.pixels(), true);
    // Noise floor: ΔE94 (D65, via the camera→XYZ matrix) of the noisy broadband input against the clean one.
    double floor = 0;
    if (noise > 0) {
      std::vector<Eigen::Vector3d> clean(f.pixels()), noisy(f.pixels());
      for (std::size_t i = 0; i < f.pixels(); ++i)
        for (int c = 0; c < 3; ++c) clean[i][c] = f.clean[i * 4 + c], noisy[i][c] = f.noisy[i * 4 + c];
      floor = maps::photo_delta_e94(clean, noisy, s.camera, s.channels[0].illuminant).mean;
      std::printf("noise floor (ΔE94 of noisy broadband input vs noise-free, D65'): %.3f\n", floor);
      report["noise_floor_de94"] = floor;
    }
    if (run.options.diagnose && !diagnose_synthetic(run, s, f, noise)) return false;
    run_synthetic_methods(run, s, f, noise, floor, truth);
  }
  return true;
}

// The virtual-lab frames (simulators/scene/rendered_session.hpp): the
// standard session rendered from the lab's physics at the sensor's full size
// (5 MP by default), binned and measured by the daemon's own path, from the
// frame cache when it holds it; the table on the measurement's own
// illuminants; the skin cells and their truth.
LabFrames render_lab(BenchRun& run) {
  const int scene_width = run.options.scene_width, scene_height = run.options.scene_height;
  const fs::path& frame_cache = run.options.frame_cache;
  auto& report = run.report;
  simulators::RenderedSessionOptions ro = bench::lab_session_options(scene_width, scene_height, frame_cache);
  const CpuClock render_cpu;
  auto t = std::chrono::steady_clock::now();
  simulators::RenderedSession lab = simulators::render_session(ro);
  const double render_s = seconds_since(t), render_cpu_s = render_cpu.seconds();
  std::printf("virtual lab: %dx%d BayerRG12 sensor -> %dx%d measurement (2x2 binning); %s %.1f s wall, %.1f s CPU; "
              "its render: scene %.1f s, camera + capture builder %.1f s, session::build_measurement %.1f s (wall); "
              "exposure %.0f us\n",
              scene_width, scene_height, lab.width, lab.height, lab.loaded_from_cache ? "loaded from the cache in" : "rendered in",
              render_s, render_cpu_s, lab.scene_seconds, lab.camera_seconds, lab.measurement_seconds, lab.exposure_us);
  nlohmann::ordered_json mixes;
  for (const auto& [name, drive] : lab.mixes) {
    std::printf("  mix %-9s drive W57 %.3f W40 %.3f W27 %.3f R %.3f G %.3f B %.3f\n", name.c_str(), drive[0], drive[1],
                drive[2], drive[3], drive[4], drive[5]);
    mixes[name] = std::vector<double>(drive.begin(), drive.end());
  }
  for (const auto* m : {&lab.noisy, &lab.noise_free})
    for (const session::RegistrationReport& r : m->registration)
      std::printf("  registration (%s): %s moved %.3f px%s\n", m == &lab.noisy ? "noisy" : "noise-free",
                  r.image.c_str(), r.motion_px, r.warped ? ", warped" : "");
  report["lab_frame"] = {{"sensor_width", scene_width}, {"sensor_height", scene_height}, {"width", lab.width},
                         {"height", lab.height}, {"loaded_from_cache", lab.loaded_from_cache}, {"seconds", render_s},
                         {"cpu_s", render_cpu_s}, {"render_scene_s", lab.scene_seconds},
                         {"render_camera_s", lab.camera_seconds}, {"render_measurement_s", lab.measurement_seconds},
                         {"exposure_us", lab.exposure_us}, {"mixes", mixes}};
  t = std::chrono::steady_clock::now();
  auto lab_table = std::make_shared<const ForwardTable>(ForwardTable::build(lab.noisy.set, TableGrid{}, 2));
  std::printf("  lab table (the measurement's own illuminants): build %.2f s\n", seconds_since(t));

  std::vector<std::size_t> skin;
  for (std::size_t i = 0; i < lab.pixels(); ++i)
    if (lab.region[i] == static_cast<std::uint8_t>(simulators::SceneRegion::kSkin)) skin.push_back(i);
  std::vector<SkinParameters> skin_truth;
  for (std::size_t i : skin) skin_truth.push_back(lab.truth[i]);
  Relit skin_relit = relight(skin_truth);
  return {std::move(ro), std::move(lab), std::move(lab_table), std::move(skin), std::move(skin_truth), std::move(skin_relit)};
}

// Fidelity of the lab frames (noise-free broadband against the model at the
// truth) and the noise floor (noisy broadband against noise-free), ΔE94
// under D65' through the camera→XYZ matrix, over the skin cells.
void measure_lab_fidelity(BenchRun& run, const LabFrames& frames) {
  auto& report = run.report;
  const auto& skin = frames.skin;
  const auto& lab = frames.lab;
  const auto& skin_truth = frames.skin_truth;
  std::vector<Eigen::Vector3d> clean, noisy;
  for (std::size_t i : skin) {
    clean.emplace_back(lab.noise_free.measured[i * 4], lab.noise_free.measured[i * 4 + 1], lab.noise_free.measured[i * 4 + 2]);
    noisy.emplace_back(lab.noisy.measured[i * 4], lab.noisy.measured[i * 4 + 1], lab.noisy.measured[i * 4 + 2]);
  }
  const MeasurementSet& set = lab.noisy.set;
  const auto model = maps::relit_camera_rgb(skin_truth, set.camera, set.channels[0].illuminant, 2);
  const maps::DeltaEStats fidelity = maps::photo_delta_e94(clean, model, set.camera, set.channels[0].illuminant);
  const maps::DeltaEStats floor = maps::photo_delta_e94(clean, noisy, set.camera, set.channels[0].illuminant);
  std::printf("  %zu skin cells (%.1f%% of the frame); noise-free frame vs the model at the truth (D65' ΔE94): mean "
              "%.4f p95 %.4f; noise floor (noisy vs noise-free broadband): mean %.3f p95 %.3f\n",
              skin.size(), 100.0 * skin.size() / lab.pixels(), fidelity.mean, fidelity.p95, floor.mean, floor.p95);
  report["lab_frame"]["skin_pixels"] = skin.size();
  report["lab_frame"]["noise_free_vs_truth_de94_d65prime"] = {{"mean", fidelity.mean}, {"p95", fidelity.p95}};
  report["lab_frame"]["noise_floor_de94"] = {{"mean", floor.mean}, {"p95", floor.p95}};
  report["lab_noise_floor_de94"] = floor.mean;
}

// --diagnose on the lab's skin cells: the fast inverter's paths, the auto
// model's 2D fit, and the noisy cells with other inverse-table settings.
void diagnose_lab(BenchRun& run, const LabFrames& frames) {
  auto& report = run.report;
  const auto& lab_table = frames.lab_table;
  const auto& lab = frames.lab;
  const auto& skin = frames.skin;
  const FastInverter fast(lab_table, fs::path{}, fast_options_for(lab.noisy.set));
  for (const bool noisy : {false, true}) {
    const session::Measurement& m = noisy ? lab.noisy : lab.noise_free;
    std::vector<float> measured;
    for (std::size_t i : skin) measured.insert(measured.end(), m.measured.begin() + i * 4, m.measured.begin() + i * 4 + 4);
    report[std::string("diagnose_paths_lab_") + (noisy ? "noisy" : "noise_free")] =
        diagnose_fast_paths(fast, m.set, measured, noisy ? "lab skin noisy" : "lab skin noise-free");
    report[std::string("diagnose_auto_slice_lab_") + (noisy ? "noisy" : "noise_free")] = diagnose_auto_slice(
        lab_table, m.set, std::span<const float>(measured).first(std::min<std::size_t>(measured.size(), 4 * 200000)),
        noisy ? "lab skin noisy" : "lab skin noise-free");
    if (!noisy) continue;
    // The same noisy cells with an empty cell's own branch tried only after
    // its neighbour's, and with the previous table (no empty cells' branches).
    FastInverterOptions later = fast_options_for(lab.noisy.set), plain = later;
    later.empty_cell_branch_first = false;
    plain.inverse_table.presolve_empty_cells = false;
    report["diagnose_paths_lab_noisy_branch_later"] = diagnose_fast_paths(
        FastInverter(lab_table, fs::path{}, later), m.set, measured, "lab skin noisy, empty cell's branch after its neighbour's");
    report["diagnose_paths_lab_noisy_no_presolve"] = diagnose_fast_paths(
        FastInverter(lab_table, fs::path{}, plain), m.set, measured, "lab skin noisy, no pre-solved empty cells");
  }
}

// Every method on the lab's skin cells (exhaustive on a fixed subsample of
// --exhaustive-pixels of them), fast 4D also on the whole frame.
void run_lab_methods(BenchRun& run, const LabFrames& frames) {
  auto& report = run.report;
  auto& speed_csv = run.speed_csv;
  auto& scene_runs = run.scene_runs;
  const int exhaustive_pixels = run.exhaustive_pixels;
  const auto& skin = frames.skin;
  const auto& lab_table = frames.lab_table;
  const auto& lab = frames.lab;
  const auto& skin_truth = frames.skin_truth;
  const auto& skin_relit = frames.skin_relit;
  const double lab_floor = report["lab_noise_floor_de94"].get<double>();
  const std::size_t stride = std::max<std::size_t>(1, skin.size() / std::max(exhaustive_pixels, 1));
  for (const bool noisy : {false, true}) {
    const session::Measurement& m = noisy ? lab.noisy : lab.noise_free;
    for (const MethodConfig& c : kMethodConfigs) {
      EstimatorOptions eo;
      eo.method = c.method;
      eo.model = c.model;
      eo.threads = 2;
      const Estimator estimator(lab_table, m.set, eo);
      // The cells this method is scored on: every skin cell, or the fixed subsample for exhaustive.
      const std::size_t step = c.method == InverterMethod::kExhaustive ? stride : 1;
      std::vector<float> measured;
      std::vector<SkinParameters> truth;
      Relit truth_relit;
      truth_relit.lab.resize(skin_relit.lab.size());
      for (std::size_t k = 0; k < skin.size(); k += step) {
        measured.insert(measured.end(), m.measured.begin() + skin[k] * 4, m.measured.begin() + skin[k] * 4 + 4);
        truth.push_back(skin_truth[k]);
        for (std::size_t l = 0; l < skin_relit.lab.size(); ++l) truth_relit.lab[l].push_back(skin_relit.lab[l][k]);
      }
      std::vector<PixelEstimate> e(truth.size());
      const CpuClock cpu;
      const EstimateSummary summary = estimator.estimate(measured, e);
      RunResult r{"lab:" + std::string(method_name(c.method)), std::string(model_name(c.model)),
                  noisy ? "noisy" : "noise-free", 0, 0, 0, 0, 0, {}};
      r.pixels = truth.size();
      r.pixels_per_second = truth.size() / summary.seconds;
      r.cpu_us_per_pixel = 1e6 * cpu.seconds() / truth.size();
      r.flagged = truth.size() - summary.flag_counts[0];
      r.order2 = summary.order2, r.order4 = summary.order4;
      r.acc = accuracy(truth_relit, truth, e, std::vector<bool>(truth.size(), true));
      std::printf("%-16s %-4s %-10s %8zu skin px %10.0f px/s %6.2f CPU us/px  relit ΔE94 %.4f (D65 %.4f)%s  "
                  "|Δlog10 Cm| %.4f |Δlog10 Ch| %.4f |ΔβM| %.3f |ΔChe| %.4f  flagged %.2f%%\n",
                  r.method.c_str(), r.model.c_str(), r.noise.c_str(), r.pixels, r.pixels_per_second, r.cpu_us_per_pixel,
                  r.acc.de_all, r.acc.de_d65,
                  noisy ? (" = " + std::to_string(r.acc.de_all / lab_floor).substr(0, 5) + "× floor").c_str() : "",
                  r.acc.log_cm, r.acc.log_ch, r.acc.bm, r.acc.che, 100.0 * r.flagged / r.pixels);
      if (c.method == InverterMethod::kFast && c.model == ModelChoice::k4d) {
        // The whole frame: its tattoo, marker, hair, specular cells take the flagging path.
        std::vector<PixelEstimate> all(lab.pixels());
        const CpuClock whole_cpu;
        const EstimateSummary whole = estimator.estimate(m.measured, all);
        std::printf("  lab fast 4d %s, whole %dx%d frame (%.1f%% not skin): %.3f s, %.0f px/s, %.2f CPU us/px, "
                    "flagged %.2f%%\n", r.noise.c_str(), lab.width, lab.height, 100.0 - 100.0 * skin.size() / lab.pixels(),
                    whole.seconds, lab.pixels() / whole.seconds, 1e6 * whole_cpu.seconds() / lab.pixels(),
                    100.0 * (lab.pixels() - whole.flag_counts[0]) / lab.pixels());
        report["lab_fast4d_whole_frame_" + r.noise] = {{"pixels", lab.pixels()}, {"seconds", whole.seconds},
                                                       {"pixels_per_second", lab.pixels() / whole.seconds}};
      }
      speed_csv << r.method << "/" << r.model << " " << r.model << " " << r.noise << " " << r.pixels_per_second << " "
                << r.acc.de_all << " " << r.acc.de_d65 << " " << r.acc.log_cm << " " << r.acc.log_ch << " " << r.acc.bm
                << " " << r.acc.che << "\n";
      scene_runs.push_back(r);
      report["lab_runs"].push_back(to_json(r));
    }
  }
}

// The lab's fast 4D against the targets and against exhaustive.
// The auto model's order rule against the fixed orders (issue 20's target:
// noise-free within 1.15× of the 4D fit, noisy no worse than it): relit
// ΔE94 (six LEDs + D65) of fast auto, fast 4D and 2D, and auto / 4D.
void print_order_ratios(const std::vector<RunResult>& runs, const std::string& prefix, const char* label) {
  for (const char* noise : {"noise-free", "noisy"}) {
    const RunResult *automatic = nullptr, *four = nullptr, *two = nullptr;
    for (const RunResult& r : runs) {
      if (r.noise != noise) continue;
      if (r.method == prefix + "fast" && r.model == "auto") automatic = &r;
      if (r.method == prefix + "fast" && r.model == "4d") four = &r;
      if (r.method == prefix + "2d") two = &r;
    }
    if (!automatic || !four) continue;
    std::printf("%s %s: relit ΔE94 auto %.4f, 4d %.4f, 2d %s; auto/4d x%.3f (target: noise-free <= 1.15, noisy "
                "<= 1); speed auto/4d x%.2f; auto at order 4 on %.1f%%\n",
                label, noise, automatic->acc.de_all, four->acc.de_all,
                two ? std::to_string(two->acc.de_all).substr(0, 6).c_str() : "-", automatic->acc.de_all / four->acc.de_all,
                automatic->pixels_per_second / four->pixels_per_second,
                100.0 * automatic->order4 / std::max<std::size_t>(1, automatic->order2 + automatic->order4));
  }
}

void print_lab_targets(const BenchRun& run) {
  const auto& scene_runs = run.scene_runs;
  print_order_ratios(scene_runs, "lab:", "lab");
  for (const char* noise : {"noise-free", "noisy"}) {
    const RunResult *fast = nullptr, *ex = nullptr;
    for (const RunResult& r : scene_runs) {
      if (r.noise != noise || r.model != "4d") continue;
      (r.method == "lab:fast" ? fast : ex) = &r;
    }
    if (fast && ex)
      std::printf("lab %s: fast 4d %.2f MP/s (target >= 10), %.3f CPU µs per cell and core (target %.1f: x%.1f to "
                  "go) = x%.0f exhaustive; D65 ΔE94 fast − exhaustive %+.4f (target <= 0.1)\n",
                  noise, fast->pixels_per_second / 1e6, fast->cpu_us_per_pixel, kTargetCpuUsPerPixel,
                  fast->cpu_us_per_pixel / kTargetCpuUsPerPixel, fast->pixels_per_second / ex->pixels_per_second,
                  fast->acc.de_d65 - ex->acc.de_d65);
  }
}

// Flag shares per scene region: fast auto on the noisy whole frame, per
// pixel and with the spatial second pass (spatial_flags.hpp).
void measure_lab_flag_shares(BenchRun& run, const LabFrames& frames) {
  auto& report = run.report;
  const auto& lab_table = frames.lab_table;
  const auto& lab = frames.lab;
  const auto& ro = frames.ro;
  EstimatorOptions eo;
  eo.threads = 2;
  const Estimator estimator(lab_table, lab.noisy.set, eo);
  std::vector<PixelEstimate> e(lab.pixels());
  EstimateSummary summary = estimator.estimate(lab.noisy.measured, e);
  // Each cell's added surface reflection, for the specular shares per band: ≥ 0.03, 0.01-0.03,
  // 0.006-0.01 (the label's edge).
  const std::vector<float> reflection = simulators::cell_added_reflection(ro);
  auto shares = [&](const char* label, nlohmann::ordered_json& out) {
    std::size_t total[8] = {}, flagged[8] = {}, band_total[3] = {}, band_flagged[3] = {};
    constexpr double kBandEdges[4] = {1.0, 0.03, 0.01, 0.0};
    for (std::size_t i = 0; i < lab.pixels(); ++i) {
      const int region = lab.region[i] == simulators::kMixedCell ? 7 : lab.region[i];
      ++total[region];
      flagged[region] += e[i].flag != PixelFlag::kExplained;
      if (region == static_cast<int>(simulators::SceneRegion::kSpecular))
        for (int b = 0; b < 3; ++b)
          if (reflection[i] >= kBandEdges[b + 1] && reflection[i] < kBandEdges[b])
            ++band_total[b], band_flagged[b] += e[i].flag != PixelFlag::kExplained;
    }
    std::printf("lab flagged share per region (fast auto, noisy, %s):", label);
    for (int k = 0; k < 8; ++k) {
      if (total[k] == 0) continue;
      const char* name = k == 7 ? "mixed_cell" : simulators::region_name(static_cast<simulators::SceneRegion>(k));
      std::printf(" %s %.1f%% (%zu)", name, 100.0 * flagged[k] / total[k], total[k]);
      out[name] = double(flagged[k]) / total[k];
    }
    std::printf("; specular by added reflection >= 0.03 / 0.01-0.03 / 0.006-0.01:");
    for (int b = 0; b < 3; ++b) {
      const double share = band_total[b] ? double(band_flagged[b]) / band_total[b] : 0.0;
      std::printf(" %.1f%%", 100 * share);
      out["specular_band"].push_back(share);
    }
    std::printf("\n");
  };
  shares("per pixel", report["lab_flagged_share_per_pixel"]);
  const auto t = std::chrono::steady_clock::now();
  const CpuClock spatial_cpu;
  const NeighbourhoodSummary pass = refine_with_neighbourhood(estimator, lab.noisy.measured, lab.width, lab.height, e, summary);
  const double spatial_s = seconds_since(t), spatial_cpu_s = spatial_cpu.seconds();
  shares("with the spatial pass", report["lab_flagged_share_spatial"]);
  std::printf("  spatial pass on %zu px (flags on %d×%d-cell blocks): %.2f s wall, %.2f s CPU (%.2f µs per cell; "
              "target <= 2 s per session)\n",
              lab.pixels(), pass.block_px, pass.block_px, spatial_s, spatial_cpu_s, 1e6 * spatial_cpu_s / lab.pixels());
  report["lab_spatial_pass"] = {{"block_px", pass.block_px}, {"seconds", spatial_s}, {"cpu_s", spatial_cpu_s}};
}

// The virtual lab's sections. False when --diagnose-only ends the run here.
bool run_virtual_lab(BenchRun& run) {
  const LabFrames frames = render_lab(run);
  measure_lab_fidelity(run, frames);
  if (run.options.diagnose) {
    diagnose_lab(run, frames);
    if (run.options.diagnose_only) return false;
  }
  run_lab_methods(run, frames);
  print_lab_targets(run);
  measure_lab_flag_shares(run, frames);
  return true;
}

// The synthetic runs' ratios: fast against exhaustive and 2D, and the targets.
void print_ratios(const BenchRun& run) {
  const auto& runs = run.runs;
  print_order_ratios(runs, "", "synthetic");
  auto find = [&](const std::string& m, const std::string& model, const std::string& noise) -> const RunResult* {
    for (const RunResult& r : runs)
      if (r.method == m && r.model == model && r.noise == noise) return &r;
    return nullptr;
  };
  for (const char* noise : {"noise-free", "noisy"}) {
    const RunResult *fast = find("fast", "4d", noise), *ex = find("exhaustive", "4d", noise), *two = find("2d", "2d", noise);
    if (!fast || !ex || !two) continue;
    std::printf("%s: fast/exhaustive speed ×%.0f, D65 ΔE94 fast − exhaustive %+.4f (target ≤ 0.1); fast vs 2D speed "
                "×%.2f, relit ΔE94 2D/fast ×%.1f; fast 4D %.2f MP/s (target ≥ 10), %.3f CPU µs per pixel and core "
                "(target %.1f: ×%.1f to go)\n",
                noise, fast->pixels_per_second / ex->pixels_per_second, fast->acc.de_d65 - ex->acc.de_d65,
                fast->pixels_per_second / two->pixels_per_second, two->acc.de_all / fast->acc.de_all,
                fast->pixels_per_second / 1e6, fast->cpu_us_per_pixel, kTargetCpuUsPerPixel,
                fast->cpu_us_per_pixel / kTargetCpuUsPerPixel);
  }
}

// --baseline: the previous version's runs beside this one's (printed ratios,
// the report, a CSV for the chart). Returns them; none without --baseline.
// Throws std::runtime_error when the file holds no runs.
std::vector<BaselineRun> compare_with_baseline(BenchRun& run) {
  const fs::path& baseline = run.options.baseline;
  const fs::path& out = run.options.out;
  const auto& runs = run.runs;
  auto& report = run.report;
  std::vector<BaselineRun> old_runs;
  if (!baseline.empty()) {
    old_runs = read_baseline(baseline);
    if (old_runs.empty()) {
      throw std::runtime_error("baseline " + baseline.string() + ": no runs read");
    }
    std::ofstream old_csv(out / "estimation_speed_accuracy_baseline.csv");
    old_csv << "# runs of the baseline (" << baseline.filename().string() << "), same columns as estimation_speed_accuracy.csv\n";
    for (const BaselineRun& b : old_runs) {
      old_csv << "old:" << b.label << " " << b.model << " " << b.noise << " " << b.pixels_per_second << " " << b.de_all
              << " " << b.de_d65 << "\n";
      for (const RunResult& r : runs) {
        if (r.method + "/" + r.model != b.label || r.noise != b.noise) continue;
        std::printf("%-14s %-10s old %9.0f px/s -> new %9.0f px/s (x%.2f); relit ΔE94 %.4f -> %.4f, D65 %.4f -> %.4f\n",
                    b.label.c_str(), b.noise.c_str(), b.pixels_per_second, r.pixels_per_second,
                    r.pixels_per_second / b.pixels_per_second, b.de_all, r.acc.de_all, b.de_d65, r.acc.de_d65);
        report["versus_baseline"].push_back({{"run", b.label},
                                             {"noise", b.noise},
                                             {"old_pixels_per_second", b.pixels_per_second},
                                             {"new_pixels_per_second", r.pixels_per_second},
                                             {"speedup", r.pixels_per_second / b.pixels_per_second},
                                             {"old_de94_relit_mean", b.de_all},
                                             {"new_de94_relit_mean", r.acc.de_all},
                                             {"old_de94_d65", b.de_d65},
                                             {"new_de94_d65", r.acc.de_d65}});
      }
    }
  }
  return old_runs;
}

// Failure behaviour 1: error against noise level (fast 4D, 2D; exhaustive on 1,000 pixels, or on
// --exhaustive-pixels if fewer: the smoke's 40).
void measure_error_vs_noise(const BenchRun& run) {
  const fs::path& out = run.options.out;
  const auto& table = run.table;
  std::ofstream noise_csv(out / "estimation_error_vs_noise.csv");
  noise_csv << "# noise_scale fast_de94 2d_de94 exhaustive_de94 noise_floor\n";
  for (double noise : {0.0, 0.25, 0.5, 1.0, 2.0, 4.0}) {
    simulators::SyntheticOptions o;
    o.pixels = 8000;
    o.noise.noise_scale = noise;
    o.seed = 7;
    MeasurementSet s = method_set();
    const simulators::SyntheticFrame f = simulators::make_synthetic_frame(s, o);
    double floor = 0;
    if (noise > 0) {
      std::vector<Eigen::Vector3d> clean(f.pixels()), noisy(f.pixels());
      for (std::size_t i = 0; i < f.pixels(); ++i)
        for (int c = 0; c < 3; ++c) clean[i][c] = f.clean[i * 4 + c], noisy[i][c] = f.noisy[i * 4 + c];
      floor = maps::photo_delta_e94(clean, noisy, s.camera, s.channels[0].illuminant).mean;
    }
    noise_csv << noise;
    for (InverterMethod m : {InverterMethod::kFast, InverterMethod::k2d, InverterMethod::kExhaustive}) {
      EstimatorOptions eo;
      eo.method = m;
      eo.model = m == InverterMethod::k2d ? ModelChoice::k2d : ModelChoice::k4d;
      eo.threads = 2;
      const std::size_t n =
          m == InverterMethod::kExhaustive ? std::min<std::size_t>(1000, run.exhaustive_pixels) : f.pixels();
      std::vector<PixelEstimate> e(n);
      Estimator(table, s, eo).estimate(std::span(f.noisy).first(n * 4), e);
      const Relit truth = relight(std::span(f.truth).first(n));
      noise_csv << " " << accuracy(truth, std::span(f.truth).first(n), e, std::vector<bool>(n, true)).de_all;
    }
    noise_csv << " " << floor << "\n";
  }
}

// Failure behaviour 2: distance outside the gamut. In-gamut pixels pushed
// out by scaling the blue-only channel by (1 + d): share flagged, and the
// relit error of those left unflagged (exhaustive on 500 pixels, or on
// --exhaustive-pixels if fewer).
void measure_error_vs_gamut(const BenchRun& run) {
  const fs::path& out = run.options.out;
  const auto& table = run.table;
  std::ofstream gamut_csv(out / "estimation_error_vs_gamut.csv");
  gamut_csv << "# blue_channel_excess flagged_share_fast de94_unflagged_fast flagged_share_exhaustive\n";
  {
    simulators::SyntheticOptions o;
    o.pixels = 4000;
    o.noise.noise_scale = 1.0;
    o.seed = 9;
    MeasurementSet s = method_set();
    const simulators::SyntheticFrame f = simulators::make_synthetic_frame(s, o);
    for (double d : {0.0, 0.02, 0.05, 0.1, 0.2, 0.4}) {
      std::vector<float> pushed = f.noisy;
      for (std::size_t i = 0; i < f.pixels(); ++i) pushed[i * 4 + 3] *= static_cast<float>(1 + d);
      gamut_csv << d;
      for (InverterMethod m : {InverterMethod::kFast, InverterMethod::kExhaustive}) {
        EstimatorOptions eo;
        eo.method = m;
        eo.model = ModelChoice::k4d;
        eo.threads = 2;
        const std::size_t n =
            m == InverterMethod::kExhaustive ? std::min<std::size_t>(500, run.exhaustive_pixels) : f.pixels();
        std::vector<PixelEstimate> e(n);
        const EstimateSummary sum = Estimator(table, s, eo).estimate(std::span(pushed).first(n * 4), e);
        gamut_csv << " " << 1.0 - double(sum.flag_counts[0]) / n;
        if (m == InverterMethod::kFast) {
          const Relit truth = relight(f.truth);
          gamut_csv << " " << accuracy(truth, f.truth, e, std::vector<bool>(n, true)).de_all;
        }
      }
      gamut_csv << "\n";
    }
  }
}

// Failure behaviour 3: Ch against Che, binned by the true Che.
void measure_ch_vs_che(const BenchRun& run) {
  const fs::path& out = run.options.out;
  const auto& table = run.table;
  std::ofstream chche_csv(out / "estimation_ch_vs_che.csv");
  chche_csv << "# true_che fast_abs_log10_ch fast_abs_che fast_noisy_abs_log10_ch fast_noisy_abs_che\n";
  {
    simulators::SyntheticOptions o;
    o.pixels = 20000;
    o.noise.noise_scale = 1.0;
    o.seed = 11;
    MeasurementSet s = method_set();
    const simulators::SyntheticFrame f = simulators::make_synthetic_frame(s, o);
    EstimatorOptions eo;
    eo.model = ModelChoice::k4d;
    eo.threads = 2;
    const Estimator estimator(table, s, eo);
    std::vector<PixelEstimate> clean(f.pixels()), noisy(f.pixels());
    estimator.estimate(f.clean, clean);
    estimator.estimate(f.noisy, noisy);
    for (int bin = 0; bin < 10; ++bin) {
      double sums[4] = {};
      int count = 0;
      for (std::size_t i = 0; i < f.pixels(); ++i) {
        if (static_cast<int>(f.truth[i].che / 0.01) != bin) continue;
        ++count;
        sums[0] += std::abs(std::log10(clean[i].parameters.ch / f.truth[i].ch));
        sums[1] += std::abs(clean[i].parameters.che - f.truth[i].che);
        sums[2] += std::abs(std::log10(noisy[i].parameters.ch / f.truth[i].ch));
        sums[3] += std::abs(noisy[i].parameters.che - f.truth[i].che);
      }
      chche_csv << (bin + 0.5) * 0.01;
      for (double v : sums) chche_csv << " " << v / std::max(count, 1);
      chche_csv << "\n";
    }
  }
}

// Anomalies and veins: share flagged per kind (fast, auto, noisy).
void measure_anomaly_flags(BenchRun& run) {
  const auto& table = run.table;
  auto& report = run.report;
  simulators::SyntheticOptions o;
  o.pixels = 40000;
  o.noise.noise_scale = 1.0;
  o.seed = 13;
  for (int k = 1; k < simulators::kSyntheticKindCount; ++k) o.share[k] = 0.08;
  MeasurementSet s = method_set();
  const simulators::SyntheticFrame f = simulators::make_synthetic_frame(s, o);
  EstimatorOptions eo;
  eo.threads = 2;
  std::vector<PixelEstimate> e(f.pixels());
  Estimator(table, s, eo).estimate(f.noisy, e);
  std::size_t total[simulators::kSyntheticKindCount] = {}, flagged[simulators::kSyntheticKindCount] = {};
  for (std::size_t i = 0; i < f.pixels(); ++i) {
    ++total[static_cast<int>(f.kind[i])];
    flagged[static_cast<int>(f.kind[i])] += e[i].flag != PixelFlag::kExplained;
  }
  std::printf("flagged share per kind (fast, auto, noisy):");
  for (int k = 0; k < simulators::kSyntheticKindCount; ++k) {
    const double share = double(flagged[k]) / std::max<std::size_t>(total[k], 1);
    std::printf(" %s %.1f%%", simulators::synthetic_kind_name(static_cast<simulators::SyntheticKind>(k)), 100 * share);
    report["flagged_share"][simulators::synthetic_kind_name(static_cast<simulators::SyntheticKind>(k))] = share;
  }
  std::printf("\nveins: %.1f%% flagged, %.1f%% fitted by the model\n",
              100.0 * flagged[1] / std::max<std::size_t>(total[1], 1),
              100.0 - 100.0 * flagged[1] / std::max<std::size_t>(total[1], 1));
}

// The two charts: speed against accuracy (with the baseline's points), and
// the failure sections. Their CSVs are written and closed before.
void draw_charts(const BenchRun& run, const std::vector<BaselineRun>& old_runs) {
  const fs::path& out = run.options.out;
  const int pixels = run.pixels;
  std::ostringstream speed_chart;
  speed_chart << "set multiplot layout 2,3 title 'Inverters on " << pixels << "-pixel synthetic frames and rendered virtual-lab sessions (lab:), 2 threads (circles noise-free, squares noisy"
                         << (old_runs.empty() ? "" : "; grey open: baseline run") << ")'\n"
                         << "set xlabel 'pixels per second'\nset logscale xy\nset grid\n"
                         << "set ylabel 'mean relit ΔE94 (six LEDs + D65)'\n"
                         << "plot '" << (out / "estimation_speed_accuracy.csv").string()
                         << "' using 4:(stringcolumn(3) eq 'noise-free' ? $5 : 1/0):1 with labels point pt 7 offset 1,0.5 "
                            "notitle, '' using 4:(stringcolumn(3) eq 'noisy' ? $5 : 1/0):1 with labels point pt 5 "
                            "offset 1,-0.5 tc rgb 'red' notitle"
                         << (old_runs.empty()
                                 ? std::string()
                                 : ", '" + (out / "estimation_speed_accuracy_baseline.csv").string() +
                                       "' using 4:(stringcolumn(3) eq 'noise-free' ? $5 : 1/0):1 with labels right point pt 6 "
                                       "offset -1,-0.8 tc rgb 'gray40' notitle, '' using 4:(stringcolumn(3) eq 'noisy' ? $5 "
                                       ": 1/0):1 with labels right point pt 4 offset -1,0.8 tc rgb 'gray40' notitle")
                         << "\n";
  {
    // Relit under D65 alone and the parameter errors, against speed (no labels: the legend says which point is which).
    std::ostringstream& panels = speed_chart;
    const std::string csv = "'" + (out / "estimation_speed_accuracy.csv").string() + "'";
    const std::pair<int, const char*> columns[] = {{6, "relit ΔE94 under D65"}, {7, "|Δlog10 Cm|"}, {8, "|Δlog10 Ch|"},
                                                   {9, "|ΔβM|"}, {10, "|ΔChe|"}};
    for (const auto& [column, label] : columns)
      panels << "set ylabel '" << label << "'\nplot " << csv << " using 4:(stringcolumn(3) eq 'noise-free' ? $" << column
             << " : 1/0):1 with labels point pt 7 offset 1,0.5 font ',7' notitle, '' using 4:(stringcolumn(3) eq 'noisy' ? $"
             << column << " : 1/0):1 with labels point pt 5 offset 1,-0.5 font ',7' tc rgb 'red' notitle\n";
    panels << "unset multiplot\n";
  }
  draw(out / "estimation_speed_accuracy.png", "pngcairo noenhanced size 1500,900", speed_chart.str());
  std::ostringstream failures_chart;
  failures_chart << "set multiplot layout 1,3\nset grid\n"
                         << "set title 'error vs noise'\nset xlabel 'noise scale (1 = camera model)'\nset ylabel 'relit ΔE94'\n"
                         << "plot '" << (out / "estimation_error_vs_noise.csv").string()
                         << "' u 1:2 w lp t 'fast 4D', '' u 1:3 w lp t '2D', '' u 1:4 w lp t 'exhaustive 4D', '' u 1:5 w l "
                            "dt 2 t 'noise floor'\n"
                         << "set title 'outside the gamut'\nset xlabel 'blue channel excess'\nset ylabel 'share flagged'\n"
                         << "set y2tics\nset y2label 'relit ΔE94 of unflagged pixels'\n"
                         << "plot '" << (out / "estimation_error_vs_gamut.csv").string()
                         << "' u 1:2 w lp t 'fast: flagged', '' u 1:4 w lp t 'exhaustive: flagged', '' u 1:3 w lp axes x1y2 "
                            "t 'fast: ΔE94 unflagged (right)'\n"
                         << "set title 'Ch against Che'\nset xlabel 'true Che'\nset xtics 0.02\nset ylabel '|Δlog10 Ch|'\n"
                            "set y2label '|ΔChe|'\n"
                         << "plot '" << (out / "estimation_ch_vs_che.csv").string()
                         << "' u 1:2 w lp t 'Ch, noise-free', '' u 1:4 w lp t 'Ch, noisy', '' u 1:3 w lp axes x1y2 t 'Che, "
                            "noise-free', '' u 1:5 w lp axes x1y2 t 'Che, noisy'\nunset multiplot\n";
  draw(out / "estimation_failures.png", "pngcairo size 1400,450", failures_chart.str());
}

}  // namespace

static int bench_main(int argc, char** argv) {
  Options options;
  CLI::App app{"Estimation: speed against accuracy for every inverter on the same frames (see the source's header)"};
  std::optional<int> pixels_option;
  bool full = false, no_frame_cache = false;
  std::vector<int> scene_size;
  auto* pixels = app.add_option("--pixels", pixels_option, "synthetic frame of N×1 pixels");
  app.add_flag("--full", full, "a 5-megapixel synthetic frame (2592×1944)")->excludes(pixels);
  app.add_option("--exhaustive-pixels", options.exhaustive_pixels, "the exhaustive search's subsample");
  app.add_option("--out", options.out, "where the figures and charts go");
  app.add_option("--baseline", options.baseline, "another build's estimation_speed_accuracy.csv");
  app.add_option("--methods", options.methods, "fast,2d,exhaustive,scene (which runs)");
  app.add_option("--scene-size", scene_size, "the virtual lab's sensor, W H")->expected(2);
  std::vector<int> timing_grid;
  app.add_option("--timing-grid", timing_grid, "the table grid the table builds are timed on, Cm Ch Bm Che nodes")
      ->expected(4);
  auto* cache = app.add_option("--frame-cache", options.frame_cache, "the rendered session's cache directory");
  app.add_flag("--no-frame-cache", no_frame_cache, "render the session, cache nothing")->excludes(cache);
  app.add_flag("--speed-only", options.speed_only, "no interpolation check, no failure sections");
  auto* diagnose = app.add_flag("--diagnose", options.diagnose, "one thread, CPU time, where the fast inverter's time goes");
  app.add_flag("--diagnose-only", options.diagnose_only, "the diagnosis and no method runs (nothing written)")
      ->excludes(diagnose);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    const int status = app.exit(error);
    return status == 0 ? 0 : 2;
  }
  if (pixels_option) options.width = *pixels_option, options.height = 1;
  if (full) options.width = 2592, options.height = 1944;
  if (!scene_size.empty()) options.scene_width = scene_size[0], options.scene_height = scene_size[1];
  if (!timing_grid.empty()) {
    options.timing_grid = {timing_grid[0], timing_grid[1], timing_grid[2], timing_grid[3]};
    if (std::string error; !options.timing_grid.IsValid(&error)) {
      std::fprintf(stderr, "estimation_bench: --timing-grid: %s\n", error.c_str());
      return 2;
    }
  }
  if (no_frame_cache) options.frame_cache.clear();
  if (options.diagnose_only) options.diagnose = true;

  fs::create_directories(options.out);
  BenchRun run(options);
  run.pixels = options.width * options.height;
  run.exhaustive_pixels = std::min(options.exhaustive_pixels, run.pixels);
  run.report["frame"] = {{"width", options.width}, {"height", options.height}, {"pixels", run.pixels},
                         {"exhaustive_pixels", run.exhaustive_pixels}};
  run.report["threads"] = 2;
  run.table = measure_tables(run);
  if (!options.speed_only) measure_interpolation_error(run);
  run.speed_csv.open(options.out / "estimation_speed_accuracy.csv");
  run.speed_csv << "# method model noise pixels_per_second de94_relit_mean de94_d65 abs_log10_cm abs_log10_ch abs_bm abs_che\n";
  if (!run_synthetic(run)) return 1;
  if (options.selects("scene")) {
    if (!run_virtual_lab(run)) return 0;
  } else if (options.diagnose_only) {
    return 0;
  }
  print_ratios(run);
  std::vector<BaselineRun> old_runs;
  try {
    old_runs = compare_with_baseline(run);
  } catch (const std::runtime_error& error) {
    std::fprintf(stderr, "%s\n", error.what());
    return 2;
  }
  if (options.speed_only) return 0;
  measure_error_vs_noise(run);
  measure_error_vs_gamut(run);
  measure_ch_vs_che(run);
  measure_anomaly_flags(run);
  std::ofstream(options.out / "estimation_bench.json") << run.report.dump(2) << "\n";
  run.speed_csv.close();  // gnuplot reads it next
  draw_charts(run, old_runs);
  std::printf("wrote %s\n", options.out.string().c_str());
  return 0;
}

int main(int argc, char** argv) { return chromo::bench::guarded_main("estimation_bench", bench_main, argc, argv); }
