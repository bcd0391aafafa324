// estimate_stages_bench: where the time of one camera's estimate at 5 MP
// goes (issue 21 part 5), before and after the speed work, side by side in
// one run, and what the new paths change in the results.
//
//   estimate_stages_bench [--sensor W H] [--seeds 5,11,12] [--threads N]
//                         [--no-derived] [--out DIR] [--no-chart]
//
// Per scene seed: the virtual lab's standard session rendered in process at
// the sensor's size (default 2448x2048 BayerRG12, binned 2x2 to 1224x1024
// cells; simulators/scene/rendered_session.hpp, not cached: the cache keeps
// no photographs), its tables prepared as chromod's on-line estimator does
// during capture (maps::prepare_tables), then maps::estimate_measurement
// twice on the same measurement and tables:
//   before  the relit comparison by the exact model per pixel, the report's
//           files one after another with OpenEXR unthreaded (the code before
//           this change);
//   after   the defaults: the relit comparison from a RelitTable, previews
//           encoded while maps.exr is compressed on OpenEXR's pool.
// The spatial pass (neighbourhood) is the same code in both: its per-pixel
// loops on OpenMP threads were tried and doubled its wall time on this
// loaded 2-core machine (many short parallel regions per pass), so it stays
// on one thread; it is timed here for the split.
// Printed per stage (estimate, neighbourhood, relit comparison, writing,
// total) with after/before ratios, per seed and as the spread (mean [min,
// max]); then what changed: the maps (every channel of maps.exr compared),
// the relit ΔE94 statistics against the photographs (mean, median, p95 per
// illuminant: after − before), and per pixel the ΔE94 between the table's
// reconstruction and the exact model's under each photograph's illuminant.
//
// Derived data (unless --no-derived): the ten files chromod writes after a
// standard session (derived_data.hpp: seven means, three albedos, 5-MP FLOAT
// ZIP) from frame sums of the same geometry (BayerRG12 frames of a smooth
// field with noise, one per step), written one after another unthreaded
// (before) and on every core (after), and at ZIP level 1 for reference; the
// pixels read back are compared with the first writing's.
//
// Writes DIR/estimate_stages.{csv,png,dat,gp} (DIR: bench/results).
//
// --chain (issue 39 part 2): instead of the above, the whole chain per stage
// for each plan (`--plans`, default standard and multispectral: the six LED
// types one at a time, 18 channels) at each sensor size (`--megapixels`,
// default 1, 2.5, 5: the 2448x2048 sensor's aspect), per seed: measurement
// and registration (the noisy measurement built again from the render's
// captures, as chromod's capture builder does: the captures registered one
// by one and at once on every core, side by side, the measured values
// compared; the whole estimate counts the latter), table set-up (prepare_tables:
// forward, inverse and subspace tables; chromod does it during capture), the
// estimate (inversion, per-pixel flags, σ maps), the estimate again without
// σ maps (σ's share), the spatial pass, the relit comparison and writing;
// the whole estimate's M cells/s (measurement and registration + estimate +
// spatial pass, without and with the table set-up) against issue 39's
// targets (the method ≥ 3, six LEDs ≥ 1). Writes DIR/estimate_chain.{csv,png}
// and DIR/estimate_chain_growth.png (wall seconds against sensor MP).
//
// --exr-levels MAPS.exr [--levels 1,...] [--pairs N] (issue 39, speed39b):
// that file written at ZIP level 4 and each level in turn (exr_level_pairs.hpp).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "bench_cli.hpp"
#include <unistd.h>

#include "chart.hpp"
#include "exr_level_pairs.hpp"
#include "guarded_main.hpp"
#include "clocks.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/maps/estimate_report.hpp"
#include "chromo/maps/reconstruction.hpp"
#include "chromo/maps/relit_table.hpp"
#include "chromo/session/derived_data.hpp"
#include "chromo/session/journal.hpp"
#include "chromo/session/session_captures.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"

namespace chromo::bench {
namespace {

namespace fs = std::filesystem;

const char* const kStages[] = {"estimate", "neighbourhood", "relit_comparison", "writing"};
constexpr int kStageCount = 4;

struct Spread {
  std::vector<double> v;
  void add(double x) { v.push_back(x); }
  double mean() const {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? 0 : s / v.size();
  }
  double min() const { return v.empty() ? 0 : *std::min_element(v.begin(), v.end()); }
  double max() const { return v.empty() ? 0 : *std::max_element(v.begin(), v.end()); }
  std::string text(const char* format = "%.3f") const {
    char a[32], b[32], c[32];
    std::snprintf(a, sizeof a, format, mean());
    std::snprintf(b, sizeof b, format, min());
    std::snprintf(c, sizeof c, format, max());
    return std::string(a) + " [" + b + ", " + c + "]";
  }
};

struct Run {
  maps::MethodEstimationResult result;
  double total = 0;  // wall seconds of the whole call
  double cpu = 0;    // CPU seconds of the process over the call (all threads; steadier on a shared machine)
};

maps::FileCommit direct_commit() {
  return [](const fs::path& path, const std::function<void(const fs::path&)>& produce) { produce(path); };
}

Run run_estimate(const simulators::RenderedSession& lab, const maps::PreparedTables& tables,
                 maps::MethodEstimationOptions options, const fs::path& dir) {
  fs::create_directories(dir);
  const auto t = std::chrono::steady_clock::now();
  const CpuClock cpu;
  Run run;
  run.result = maps::estimate_measurement(lab.noisy, lab.noisy.set.camera, 0.99, 0, options, dir, direct_commit(),
                                                 {}, {}, &tables);
  run.total = seconds_since(t);
  run.cpu = cpu.seconds();
  return run;
}

// Largest |a − b| per maps.exr channel (NaN-aware: NaN = NaN), and how many
// pixels differ anywhere.
struct MapsDifference {
  std::vector<std::string> channels;
  std::vector<double> max_abs;
  std::size_t pixels_differing = 0;
};
MapsDifference compare_maps(const fs::path& a_path, const fs::path& b_path) {
  const files::FloatImage a = files::read_exr(a_path), b = files::read_exr(b_path);
  MapsDifference d;
  d.channels = a.channel_names;
  std::vector<char> differs(static_cast<std::size_t>(a.width) * a.height, 0);
  for (std::size_t c = 0; c < a.channels.size(); ++c) {
    double m = 0;
    const auto& x = a.channels[c];
    const auto& y = b.channel(a.channel_names[c]);
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (std::isnan(x[i]) && std::isnan(y[i])) continue;
      const double e = std::abs(static_cast<double>(x[i]) - y[i]);
      if (!(e == 0)) differs[i] = 1, m = std::max(m, std::isfinite(e) ? e : INFINITY);
    }
    d.max_abs.push_back(m);
  }
  for (char c : differs) d.pixels_differing += c;
  return d;
}

// Per pixel ΔE94 between the relit table's reconstruction and the exact
// model's, under each photograph's illuminant, over the explained pixels of
// maps.exr (the comparison's pixels): mean, p95, max per illuminant.
std::vector<maps::DeltaEStats> table_error(const fs::path& maps_exr, const simulators::RenderedSession& lab,
                                           const estimation::TableGrid& grid) {
  const files::FloatImage m = files::read_exr(maps_exr);
  std::vector<estimation::SkinParameters> p;
  const auto& flags = m.channel("flags");
  for (std::size_t i = 0; i < flags.size(); ++i)
    if (flags[i] == 0)
      p.push_back({m.channel("Cm")[i], m.channel("Ch")[i], m.channel("Bm")[i], m.channel("Che")[i]});
  std::vector<spectral::Spectrum> illuminants;
  for (const auto& photo : lab.noisy.photographs) illuminants.push_back(photo.illuminant);
  const maps::RelitTable table(lab.noisy.set.camera, illuminants, grid, {}, 0);
  std::vector<maps::DeltaEStats> out;
  const auto from_table = table.rgb(p);
  for (std::size_t i = 0; i < illuminants.size(); ++i) {
    const auto exact = maps::relit_camera_rgb(p, lab.noisy.set.camera, illuminants[i]);
    out.push_back(maps::photo_delta_e94(exact, from_table[i], lab.noisy.set.camera, illuminants[i]));
  }
  return out;
}

// Derived data: frame sums of the standard plan's steps at the sensor's size.
struct DerivedRun {
  double seconds = 0, cpu = 0;
  std::uintmax_t bytes = 0;
};
session::SessionFrameSums derived_sums(const session::SessionPlan& plan, int width, int height, std::uint64_t seed) {
  session::SessionFrameSums sums;
  std::mt19937 rng(static_cast<std::uint32_t>(seed));
  std::normal_distribution<double> noise(0, 1);
  std::vector<std::uint8_t> samples(static_cast<std::size_t>(width) * height * 2);
  for (std::size_t s = 0; s < plan.steps.size(); ++s) {
    const session::Step& step = plan.steps[s];
    session::FrameRecord record;
    record.index = s;
    record.step = step.name;
    record.step_index = static_cast<int>(s);
    record.role = step.role;
    record.camera = "cam0";
    record.width = width, record.height = height;
    record.pixel_format = drivers::PixelFormat::kBayerRG12;
    const double level = step.role == session::StepRole::kDark ? 64 : step.role == session::StepRole::kWhite ? 3400 : 1400;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        // A smooth field (vignetting, the skin's variation) plus shot and read noise.
        const double u = (x - width / 2.0) / width, v = (y - height / 2.0) / height;
        const double mean = level * (1 - 0.3 * (u * u + v * v)) * (1 + 0.05 * std::sin(0.01 * x) * std::cos(0.013 * y));
        const double dn = std::clamp(mean + noise(rng) * std::sqrt(4 + 0.25 * mean), 0.0, 4095.0);
        const auto value = static_cast<std::uint16_t>(std::lround(dn));
        std::memcpy(&samples[2 * (static_cast<std::size_t>(y) * width + x)], &value, 2);
      }
    sums.add(record, samples);
  }
  return sums;
}

DerivedRun write_derived(const fs::path& folder, const session::SessionPlan& plan, const session::SessionFrameSums& sums,
                         const session::DerivedDataOptions& options) {
  fs::remove_all(folder);
  fs::create_directories(folder);
  session::Journal journal(folder / "journal.jsonl", nullptr);
  const auto t = std::chrono::steady_clock::now();
  const CpuClock cpu;
  session::write_derived_data(folder, plan, sums, 0.99, journal, nullptr, options);
  DerivedRun run;
  run.seconds = seconds_since(t);
  run.cpu = cpu.seconds();
  for (const auto& e : fs::directory_iterator(folder / "derived")) run.bytes += fs::file_size(e.path());
  return run;
}

// Every file of `b` holds the pixels of the same file in `a`, bit for bit.
bool same_pixels(const fs::path& a, const fs::path& b, int* files_compared) {
  bool same = true;
  for (const auto& e : fs::directory_iterator(a / "derived")) {
    const files::FloatImage x = files::read_exr(e.path()), y = files::read_exr(b / "derived" / e.path().filename());
    same = same && x.channel_names == y.channel_names;
    for (std::size_t c = 0; same && c < x.channels.size(); ++c)
      same = std::memcmp(x.channels[c].data(), y.channels[c].data(), x.channels[c].size() * sizeof(float)) == 0;
    ++*files_compared;
  }
  return same;
}

// One plan at one sensor size and seed: the chain's stages (wall seconds).
struct ChainRun {
  std::string plan;
  double megapixels = 0;
  std::size_t cells = 0;
  std::map<std::string, double> stage_s;
  bool same_measurement = false;  // the registrations at once gave the same measured values as one by one
  double whole_s() const {  // measurement and registration, estimate, spatial pass
    return stage_s.at("measurement_and_registration") + stage_s.at("estimate") + stage_s.at("neighbourhood");
  }
};
const char* const kChainStages[] = {"measurement_registration_one_by_one", "measurement_and_registration", "table_setup", "estimate", "sigma_maps",
                                    "neighbourhood", "relit_comparison", "writing"};

ChainRun run_chain(const std::string& plan, double megapixels, std::uint64_t seed, int threads, const fs::path& dir) {
  // The 5-MP sensor's aspect, even sides.
  const double side = std::sqrt(megapixels * 1e6 / (2448.0 * 2048.0));
  simulators::RenderedSessionOptions ro;
  ro.sensor_width = 2 * static_cast<int>(std::lround(2448 * side / 2)), ro.sensor_height = 2 * static_cast<int>(std::lround(2048 * side / 2));
  ro.seed = seed, ro.threads = threads, ro.plan = plan, ro.noise_free = false, ro.keep_captures = true;
  const simulators::RenderedSession lab = simulators::render_session(ro);
  ChainRun run;
  run.plan = plan, run.megapixels = ro.sensor_width * double(ro.sensor_height) / 1e6, run.cells = lab.pixels();
  // The measurement built again from the kept captures: its registrations one
  // after another (RegistrationOptions' default) and at once on every core
  // (threads 0), side by side; the measured values must be the same.
  auto measure = [&](int registration_threads, double& seconds) {
    session::RegistrationOptions registration;
    registration.threads = registration_threads;
    const auto t0 = std::chrono::steady_clock::now();
    session::Measurement m = session::build_measurement(lab.noisy_captures->captures(), registration);
    seconds = seconds_since(t0);
    return m;
  };
  const session::Measurement serial = measure(1, run.stage_s["measurement_registration_one_by_one"]);
  const session::Measurement concurrent = measure(0, run.stage_s["measurement_and_registration"]);
  run.same_measurement = serial.measured.size() == concurrent.measured.size() &&
                         std::memcmp(serial.measured.data(), concurrent.measured.data(),
                                     serial.measured.size() * sizeof(float)) == 0 &&
                         serial.measured.size() == lab.noisy.measured.size() &&
                         std::memcmp(serial.measured.data(), lab.noisy.measured.data(),
                                     serial.measured.size() * sizeof(float)) == 0;
  maps::MethodEstimationOptions options;
  options.estimator.threads = threads;
  auto t = std::chrono::steady_clock::now();
  const maps::PreparedTables tables = maps::prepare_tables(lab.noisy.set, options);
  run.stage_s["table_setup"] = seconds_since(t);
  const Run with_sigma = run_estimate(lab, tables, options, dir / "sigma");
  for (const char* stage : {"estimate", "neighbourhood", "relit_comparison", "writing"})
    run.stage_s[stage] = with_sigma.result.seconds(stage);
  // σ's share: the estimator alone without the σ maps, on the same tables.
  estimation::EstimatorOptions plain = tables.estimator->options();
  plain.uncertainty = false;
  const estimation::Estimator without_sigma(tables.table, lab.noisy.set, plain);
  std::vector<estimation::PixelEstimate> estimates(lab.pixels());
  const double no_sigma_s = without_sigma.estimate(lab.noisy.measured, estimates).seconds;
  run.stage_s["sigma_maps"] = run.stage_s["estimate"] - no_sigma_s;
  fs::remove_all(dir);
  return run;
}

int chain_main(const std::vector<std::string>& plans, const std::vector<double>& megapixels,
               const std::vector<std::uint64_t>& seeds, int threads, const fs::path& out, bool no_chart) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // a long run: each line as it comes
  const fs::path scratch = fs::temp_directory_path() / ("estimate_chain_bench-" + std::to_string(::getpid()));
  std::printf("estimate_stages_bench --chain: %d estimator threads; load average %.2f\n", threads, load_average());
  std::ofstream csv(out / "estimate_chain.csv");
  csv << "plan,megapixels,cells,seed";
  for (const char* s : kChainStages) csv << "," << s << "_s";
  csv << ",whole_s,whole_mcells_per_s,whole_with_tables_mcells_per_s,load_average\n";
  std::map<std::pair<std::string, double>, std::map<std::string, Spread>> spread;  // (plan, MP) → stage → seconds
  std::map<std::pair<std::string, double>, Spread> rate, rate_with_tables, registration_ratio;
  for (const std::string& plan : plans)
    for (const double mp : megapixels)
      for (const std::uint64_t seed : seeds) {
        const ChainRun r = run_chain(plan, mp, seed, threads, scratch / "run");
        const double whole = r.whole_s(), with_tables = whole + r.stage_s.at("table_setup");
        const auto key = std::make_pair(plan, mp);
        for (const auto& [stage, sec] : r.stage_s) spread[key][stage].add(sec);
        rate[key].add(r.cells / whole / 1e6), rate_with_tables[key].add(r.cells / with_tables / 1e6);
        std::printf("\n%s, %.2f MP sensor (%zu cells), seed %llu, load %.2f:\n", plan.c_str(), r.megapixels, r.cells,
                    static_cast<unsigned long long>(seed), load_average());
        csv << plan << "," << r.megapixels << "," << r.cells << "," << seed;
        for (const char* s : kChainStages) {
          std::printf("  %-30s %8.3f s\n", s, r.stage_s.at(s));
          csv << "," << r.stage_s.at(s);
        }
        std::printf("  registrations at once / one by one: x%.3f (measured values %s)\n",
                    r.stage_s.at("measurement_and_registration") / r.stage_s.at("measurement_registration_one_by_one"),
                    r.same_measurement ? "identical" : "DIFFER");
        registration_ratio[key].add(r.stage_s.at("measurement_and_registration") /
                                    r.stage_s.at("measurement_registration_one_by_one"));
        std::printf("  whole estimate (measurement+registration, estimate, spatial pass) %.3f s: %.3f M cells/s; "
                    "with the table set-up %.3f M cells/s\n",
                    whole, r.cells / whole / 1e6, r.cells / with_tables / 1e6);
        csv << "," << whole << "," << r.cells / whole / 1e6 << "," << r.cells / with_tables / 1e6 << "," << load_average()
            << std::endl;
      }
  fs::remove_all(scratch);

  std::printf("\nspread over %zu seed(s), mean [min, max] wall s (load average now %.2f):\n", seeds.size(), load_average());
  std::vector<Bar> bars;
  std::vector<LineSeries> growth;
  for (const std::string& plan : plans) {
    for (const char* stage : kChainStages) {
      LineSeries line{plan + " " + stage, {}};
      std::replace(line.title.begin(), line.title.end(), '_', ' ');
      for (const double mp : megapixels) {
        const auto key = std::make_pair(plan, mp);
        std::printf("  %-14s %5.2f MP %-30s %s\n", plan.c_str(), mp, stage, spread[key][stage].text().c_str());
        line.points.emplace_back(mp, spread[key][stage].mean());
      }
      growth.push_back(line);
      std::string label = plan + " " + stage;
      std::replace(label.begin(), label.end(), '_', ' ');
      bars.push_back({label, spread[std::make_pair(plan, megapixels.back())][stage].mean()});
    }
    for (const double mp : megapixels) {
      const auto key = std::make_pair(plan, mp);
      std::printf("  %-14s %5.2f MP whole estimate M cells/s %s (target %s), with the table set-up %s; "
                  "registrations at once / one by one x%s\n",
                  plan.c_str(), mp, rate[key].text().c_str(), plan == "standard" ? ">= 3" : ">= 1",
                  rate_with_tables[key].text().c_str(), registration_ratio[key].text().c_str());
    }
  }
  std::printf("\nwrote %s\n", (out / "estimate_chain.csv").c_str());
  if (!no_chart) {
    char title[160];
    std::snprintf(title, sizeof title, "the chain per stage at %.1f MP (wall s, %d threads, mean over seeds)",
                  megapixels.back(), threads);
    write_bar_chart(out / "estimate_chain.png", title, "wall seconds", bars);
    write_line_chart(out / "estimate_chain_growth.png", "the chain per stage against the sensor size", "sensor MP",
                     "wall seconds", growth);
  }
  return 0;
}

int bench_main(int argc, char** argv) {
  CLI::App app{"estimate_stages_bench: the 5-MP estimate's stages before and after, side by side"};
  int sensor_width = 2448, sensor_height = 2048, threads = 2;
  std::vector<std::uint64_t> seeds = {5, 11, 12};
  bool no_derived = false, no_chart = false;
  fs::path out = CHROMO_BENCH_RESULTS;
  std::vector<int> sensor;
  app.add_option("--sensor", sensor, "sensor width and height (even)")->expected(2);
  app.add_option("--seeds", seeds, "scene seeds")->delimiter(',');
  app.add_option("--threads", threads, "estimator threads (the machine's 2 cores)")->check(CLI::Range(1, 64));
  app.add_flag("--no-derived", no_derived, "skip the derived data");
  app.add_flag("--no-chart", no_chart, "no chart");
  app.add_option("--out", out, "where the CSV and chart go");
  bool chain = false;
  std::vector<std::string> plans = {"standard", "multispectral"};
  std::vector<double> megapixels = {1, 2.5, 5};
  app.add_flag("--chain", chain, "the whole chain per stage, per plan and sensor size (issue 39)");
  app.add_option("--plans", plans, "--chain: built-in plans")->delimiter(',');
  app.add_option("--megapixels", megapixels, "--chain: sensor sizes in MP")->delimiter(',');
  fs::path exr_levels_file;
  std::vector<int> exr_levels = {1};
  int pairs = 3;
  app.add_option("--exr-levels", exr_levels_file, "a stored maps.exr: written at ZIP level 4 and --levels in turn");
  app.add_option("--levels", exr_levels, "--exr-levels: the ZIP levels against 4")->delimiter(',');
  app.add_option("--pairs", pairs, "--exr-levels: A B pairs")->check(CLI::Range(1, 50));
  CLI11_PARSE(app, argc, argv);
  if (!exr_levels_file.empty()) return exr_level_pairs_main(exr_levels_file, exr_levels, pairs, threads);
  if (chain) return chain_main(plans, megapixels, seeds, threads, out, no_chart);
  if (sensor.size() == 2) sensor_width = sensor[0], sensor_height = sensor[1];

  const fs::path scratch = fs::temp_directory_path() / ("estimate_stages_bench-" + std::to_string(::getpid()));
  fs::create_directories(scratch);
  std::printf("estimate_stages_bench: %dx%d BayerRG12 sensor -> %dx%d cells, seeds", sensor_width, sensor_height,
              sensor_width / 2, sensor_height / 2);
  for (auto s : seeds) std::printf(" %llu", static_cast<unsigned long long>(s));
  std::printf(", %d estimator threads; load average %.2f\n", threads, load_average());

  Spread before_stage[kStageCount], after_stage[kStageCount], ratio_stage[kStageCount], before_total, after_total,
      ratio_total, before_cpu, after_cpu, ratio_cpu, render_s, prepare_s, maps_pixels_differing;
  std::map<std::string, Spread> relit_shift_mean, relit_shift_median, relit_shift_p95, table_mean, table_p95, table_max;
  std::vector<std::string> illuminant_names;
  std::ofstream csv(out / "estimate_stages.csv");
  csv << "seed,config,estimate_s,neighbourhood_s,relit_comparison_s,writing_s,total_s,total_cpu_s\n";

  for (const std::uint64_t seed : seeds) {
    simulators::RenderedSessionOptions ro;
    ro.sensor_width = sensor_width, ro.sensor_height = sensor_height, ro.seed = seed, ro.threads = threads;
    ro.noise_free = false;
    auto t = std::chrono::steady_clock::now();
    const simulators::RenderedSession lab = simulators::render_session(ro);
    render_s.add(seconds_since(t));

    maps::MethodEstimationOptions after;
    after.estimator.threads = threads;
    maps::MethodEstimationOptions before = after;
    before.relit_model = maps::RelitModel::kExact;
    before.writer_threads = 1;
    t = std::chrono::steady_clock::now();
    const maps::PreparedTables tables = maps::prepare_tables(lab.noisy.set, after);
    prepare_s.add(seconds_since(t));

    const fs::path dir = scratch / std::to_string(seed);
    const Run b = run_estimate(lab, tables, before, dir / "before");
    const Run a = run_estimate(lab, tables, after, dir / "after");

    std::printf("\nseed %llu: rendered in %.1f s, tables prepared in %.2f s (during capture in chromod)\n",
                static_cast<unsigned long long>(seed), render_s.v.back(), prepare_s.v.back());
    std::printf("  %-18s %9s %9s %9s\n", "stage (wall s)", "before", "after", "after/before");
    for (int s = 0; s < kStageCount; ++s) {
      const double x = b.result.seconds(kStages[s]), y = a.result.seconds(kStages[s]);
      before_stage[s].add(x), after_stage[s].add(y), ratio_stage[s].add(y / x);
      std::printf("  %-18s %9.3f %9.3f %9.3f\n", kStages[s], x, y, y / x);
    }
    before_total.add(b.total), after_total.add(a.total), ratio_total.add(a.total / b.total);
    std::printf("  %-18s %9.3f %9.3f %9.3f\n", "total", b.total, a.total, a.total / b.total);
    before_cpu.add(b.cpu), after_cpu.add(a.cpu), ratio_cpu.add(a.cpu / b.cpu);
    std::printf("  %-18s %9.3f %9.3f %9.3f\n", "total CPU s", b.cpu, a.cpu, a.cpu / b.cpu);
    for (const auto& [name, r] : {std::pair<const char*, const Run*>{"before", &b}, std::pair<const char*, const Run*>{"after", &a}})
      csv << seed << "," << name << "," << r->result.seconds("estimate") << "," << r->result.seconds("neighbourhood") << ","
          << r->result.seconds("relit_comparison") << "," << r->result.seconds("writing") << "," << r->total << ","
          << r->cpu << "\n";

    const MapsDifference d = compare_maps(dir / "before" / "maps.exr", dir / "after" / "maps.exr");
    maps_pixels_differing.add(static_cast<double>(d.pixels_differing));
    std::printf("  maps.exr after vs before: %zu pixels differ; max |difference|", d.pixels_differing);
    for (std::size_t c = 0; c < d.channels.size(); ++c) std::printf(" %s %.3g", d.channels[c].c_str(), d.max_abs[c]);
    std::printf("\n");
    const auto errors = table_error(dir / "after" / "maps.exr", lab, tables.table->grid());
    for (std::size_t i = 0; i < a.result.relit.size(); ++i) {
      const auto& x = b.result.relit[i].delta_e94;
      const auto& y = a.result.relit[i].delta_e94;
      const std::string& name = a.result.relit[i].illuminant;
      if (illuminant_names.size() < a.result.relit.size()) illuminant_names.push_back(name);
      relit_shift_mean[name].add(y.mean - x.mean);
      relit_shift_median[name].add(y.median - x.median);
      relit_shift_p95[name].add(y.p95 - x.p95);
      table_mean[name].add(errors[i].mean), table_p95[name].add(errors[i].p95), table_max[name].add(errors[i].max);
      std::printf("  relit ΔE94 vs photograph %-9s exact: mean %.4f median %.4f p95 %.4f | table: %.4f %.4f %.4f"
                  " | table vs exact per pixel: mean %.4f p95 %.4f max %.4f (%zu px)\n",
                  name.c_str(), x.mean, x.median, x.p95, y.mean, y.median, y.p95, errors[i].mean, errors[i].p95,
                  errors[i].max, errors[i].pixels);
    }
    fs::remove_all(dir);
  }

  std::printf("\nspread over %zu seeds, mean [min, max] (load average now %.2f):\n", seeds.size(), load_average());
  std::printf("  render (not in the estimate) %s s; tables prepared %s s\n", render_s.text("%.1f").c_str(),
              prepare_s.text("%.2f").c_str());
  std::printf("  %-18s %-26s %-26s %s\n", "stage (wall s)", "before", "after", "after/before");
  for (int s = 0; s < kStageCount; ++s)
    std::printf("  %-18s %-26s %-26s %s\n", kStages[s], before_stage[s].text().c_str(), after_stage[s].text().c_str(),
                ratio_stage[s].text().c_str());
  std::printf("  %-18s %-26s %-26s %s\n", "total", before_total.text().c_str(), after_total.text().c_str(),
              ratio_total.text().c_str());
  std::printf("  %-18s %-26s %-26s %s\n", "total CPU s", before_cpu.text().c_str(), after_cpu.text().c_str(),
              ratio_cpu.text().c_str());
  std::printf("  maps.exr pixels differing after vs before: %s\n", maps_pixels_differing.text("%.0f").c_str());
  for (const std::string& name : illuminant_names)
    std::printf("  %-9s relit ΔE94 statistic, table − exact: mean %s, median %s, p95 %s; per pixel table vs exact ΔE94: "
                "mean %s, p95 %s, max %s\n",
                name.c_str(), relit_shift_mean[name].text("%+.4f").c_str(), relit_shift_median[name].text("%+.4f").c_str(),
                relit_shift_p95[name].text("%+.4f").c_str(), table_mean[name].text("%.4f").c_str(),
                table_p95[name].text("%.4f").c_str(), table_max[name].text("%.3f").c_str());

  std::vector<Bar> bars;
  for (int s = 0; s < kStageCount; ++s) {
    std::string label = kStages[s];
    std::replace(label.begin(), label.end(), '_', ' ');  // gnuplot reads '_' as a subscript
    bars.push_back({label + " before", before_stage[s].mean()});
    bars.push_back({label + " after", after_stage[s].mean()});
  }
  bars.push_back({"total before", before_total.mean()});
  bars.push_back({"total after", after_total.mean()});

  if (!no_derived) {
    const session::SessionPlan plan = session::standard_plan();
    const auto sums = derived_sums(plan, sensor_width, sensor_height, 7);
    struct Variant {
      const char* name;
      session::DerivedDataOptions options;
    };
    const Variant variants[] = {{"before: one after another, unthreaded, ZIP default", {1, -1}},
                                {"after: files on every core, ZIP default", {0, -1}},
                                {"reference: files on every core, ZIP level 1", {0, 1}}};
    std::printf("\nderived data: %zu steps of %dx%d BayerRG12 -> the standard session's derived files\n",
                plan.steps.size(), sensor_width, sensor_height);
    double first = 0;
    for (std::size_t v = 0; v < std::size(variants); ++v) {
      const fs::path folder = scratch / ("derived-" + std::to_string(v));
      const DerivedRun r = write_derived(folder, plan, sums, variants[v].options);
      if (v == 0) first = r.seconds;
      int compared = 0;
      const bool same = v == 0 || same_pixels(scratch / "derived-0", folder, &compared);
      std::printf("  %-52s %7.2f s (CPU %6.2f s)  %6.1f MB  x%.2f of before%s\n", variants[v].name, r.seconds, r.cpu,
                  r.bytes / 1e6, r.seconds / first,
                  v == 0 ? "" : (same ? (", same pixels in all " + std::to_string(compared) + " files").c_str()
                                      : ", PIXELS DIFFER"));
      bars.push_back({std::string("derived ") + (v == 0 ? "before" : v == 1 ? "after" : "zip-1"), r.seconds});
      csv << "derived," << (v == 0 ? "before" : v == 1 ? "after" : "zip-1") << ",,,," << r.seconds << "," << r.seconds
          << ",\n";
    }
    fs::remove_all(scratch / "derived-0");
    fs::remove_all(scratch / "derived-1");
    fs::remove_all(scratch / "derived-2");
  }
  fs::remove_all(scratch);
  std::printf("\nwrote %s\n", (out / "estimate_stages.csv").c_str());
  if (!no_chart)
    write_bar_chart(out / "estimate_stages.png",
                    "5-MP estimate per stage, before and after (mean over seeds; wall s, 2 threads)", "wall seconds",
                    bars);
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) { return chromo::bench::guarded_main("estimate_stages_bench", chromo::bench::bench_main, argc, argv); }
