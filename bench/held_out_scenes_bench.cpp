// The default estimator (fast inverter, auto model, spatial pass) on virtual-
// lab sessions it was never tuned on: the standard session rendered from the
// lab's physics (simulators/scene/rendered_session.hpp) for several scene
// seeds other than the tuning seed 5. Each seed draws its own skin fields
// (Cm, Ch, βm, Che) and places its own vein, tattoo ink, marker, hair and
// highlights, and its own camera noise. Per seed and for the spread over the
// held-out seeds (mean, min, max): relit ΔE94 against the truth on the skin
// cells (six LEDs + D65, and D65 alone) of the auto model (with and without
// the spatial pass's pooled order), the 4D and the 2D model, and auto / 4D,
// on the noisy frames, the noise-free frames with the camera's noise declared
// (as the daemon tells the estimator) and the noise-free frames declared
// noise-free (read σ 1e-6); the share of skin at order 4; each parameter's
// error, and the share of each scene region flagged.
//
//   held_out_scenes_bench [--seeds 11,12,13,14,15,16] [--sensor W H] [--plan NAME] [--out DIR]
//                         [--order-factor K] [--tuning-only] [--skin-denoise off|on]
//                         [--discrepancy none|learned] [--quick]
//
// --skin-denoise on (the default, as chromod's estimation.skin_denoise): the
// multi-pixel estimate in every configuration's spatial pass
// (estimation/skin_refit.hpp); off: the per-pixel chain's maps;
// --discrepancy learned: the learned discrepancy of real skin in the
// estimator (chromod's default; none: the camera noise alone, this bench's
// earlier figures). Also printed: relit ΔE94 under D65 and CIE A and their
// mean (issue 37's statistic), and the default's estimate time with the
// multi-pixel step's share. --quick: the auto and 4D models only, on the
// noisy and the noise-free (declared σ) frames (the other columns print 0).
//
// --plan: a built-in plan other than the standard one ("multispectral",
// "multispectral+method"; rendered_session.hpp), through the same default
// pipeline, for plans compared by the daemon's estimator rather than per pixel.
//
// Writes DIR/held_out_scenes[_PLAN].csv and .png (relit ΔE94 per
// seed). The tuning seed's row is printed first, for reference, and is not
// part of the spread.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "bench_cli.hpp"

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/estimation/skin_refit.hpp"
#include "chromo/estimation/spatial_flags.hpp"
#include "chromo/files/gnuplot_chart.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "noise_declaration.hpp"
#include "relit_accuracy.hpp"

namespace chromo::bench {
namespace {

constexpr std::uint64_t kTuningSeed = 5;
constexpr int kRegions = 6;  // skin, vein, tattoo, marker, hair, specular

// The estimator configurations run on every measurement: the default (auto
// model, spatial pass with its pooled order), the auto model with the spatial
// pass's flags but no pooled order, and the fixed orders (spatial flags on).
enum Config { kAuto, kAutoNoPool, k4d, k2d, kConfigs };
constexpr const char* kConfigNames[kConfigs] = {"auto", "auto-nopool", "4d", "2d"};

struct ConfigResult {
  Accuracy acc;                    // relit, on explained skin cells
  double de_a = 0;                 // relit ΔE94 under CIE A, the same cells
  double seconds = 0;              // the estimate (per-pixel and spatial pass), wall
  double denoise_seconds = 0;      // of which the multi-pixel step (--skin-denoise on)
  double flagged[kRegions] = {};   // share of each region's cells flagged
  double order4 = 0;               // share of explained skin cells at order 4
};

struct SeedResult {
  std::uint64_t seed = 0;
  // noisy; noise-free with the camera's noise declared (as the daemon does);
  // noise-free declared noise-free (read σ 1e-6, no shot noise).
  ConfigResult noisy[kConfigs], noise_free[kConfigs], declared[kConfigs];
  std::size_t region_cells[kRegions] = {};
};

// The auto model's appearance factor k (--order-factor; the default's unless given).
double order_factor = estimation::EstimatorOptions{}.order_appearance_factor;
// --skin-denoise and --discrepancy.
std::optional<estimation::SkinDenoiseOptions> skin_denoise;
std::shared_ptr<const estimation::ModelDiscrepancy> discrepancy;
bool quick = false;  // --quick

struct Estimate {
  std::vector<estimation::PixelEstimate> e;
  double seconds = 0, denoise_seconds = 0;
};

// One configuration on one measurement: per pixel, then the spatial pass.
Estimate estimate(std::shared_ptr<const estimation::ForwardTable> table,
                                                const estimation::MeasurementSet& set, std::span<const float> measured,
                                                int width, int height, Config config) {
  estimation::EstimatorOptions options;
  options.threads = 2;
  options.order_appearance_factor = order_factor;
  options.discrepancy = discrepancy;
  options.model = config == k4d ? estimation::ModelChoice::k4d
                  : config == k2d ? estimation::ModelChoice::k2d
                                  : estimation::ModelChoice::kAuto;
  // As the daemon and `chromo estimate` do: with the pooled order, the per-pixel rule is the likelihood ratio.
  if (config == kAuto) options.order_rule = estimation::EstimatorOptions::OrderRule::kLikelihoodRatio;
  const estimation::Estimator estimator(table, set, options);
  Estimate r;
  r.e.resize(measured.size() / static_cast<std::size_t>(set.size()));
  const auto start = std::chrono::steady_clock::now();
  estimation::EstimateSummary summary = estimator.estimate(measured, r.e);
  estimation::NeighbourhoodOptions no;
  no.pool_order = config == kAuto;
  // skin_denoise empty: exactly refine_with_neighbourhood() (skin_refit.hpp).
  const estimation::SpatialPass pass =
      estimation::spatial_pass(estimator, measured, width, height, r.e, summary, no, skin_denoise);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (pass.skin_refit) r.denoise_seconds = pass.skin_refit->seconds;
  return r;
}

ConfigResult score(const simulators::RenderedSession& lab, const Relit& truth, const std::vector<bool>& skin,
                   const Estimate& estimated) {
  const std::vector<estimation::PixelEstimate>& e = estimated.e;
  ConfigResult r;
  r.acc = accuracy(truth, lab.truth, e, skin);
  r.de_a = relit_under_a(lab.truth, e, skin);
  r.seconds = estimated.seconds, r.denoise_seconds = estimated.denoise_seconds;
  std::size_t flagged[kRegions] = {}, cells[kRegions] = {}, order4 = 0, explained_skin = 0;
  for (std::size_t i = 0; i < lab.pixels(); ++i) {
    if (lab.region[i] >= kRegions) continue;  // white target, mixed cells
    ++cells[lab.region[i]];
    const bool explained = e[i].flag == estimation::PixelFlag::kExplained;
    if (!explained) ++flagged[lab.region[i]];
    if (explained && skin[i]) ++explained_skin, order4 += e[i].order == 4;
  }
  for (int k = 0; k < kRegions; ++k) r.flagged[k] = cells[k] ? static_cast<double>(flagged[k]) / cells[k] : 0.0;
  r.order4 = explained_skin ? static_cast<double>(order4) / explained_skin : 0.0;
  return r;
}

// The built-in plan the sessions are rendered with (--plan).
std::string plan_name = "standard";

std::string output_stem() {
  std::string stem = plan_name == "standard" ? "held_out_scenes" : "held_out_scenes_" + plan_name;
  if (discrepancy) stem += "_learned";
  return skin_denoise ? stem + "_denoise" : stem;
}

SeedResult run_seed(std::uint64_t seed, int sensor_width, int sensor_height) {
  simulators::RenderedSessionOptions ro;
  ro.sensor_width = sensor_width, ro.sensor_height = sensor_height, ro.seed = seed, ro.threads = 2;
  ro.plan = plan_name;
  const simulators::RenderedSession lab = simulators::render_session(ro);
  SeedResult r;
  r.seed = seed;
  std::vector<bool> skin(lab.pixels());
  for (std::size_t i = 0; i < lab.pixels(); ++i) {
    skin[i] = lab.region[i] == static_cast<std::uint8_t>(simulators::SceneRegion::kSkin);
    if (lab.region[i] < kRegions) ++r.region_cells[lab.region[i]];
  }
  const Relit truth = relight(lab.truth);
  // One table per set of channel weights (the noise does not enter it).
  auto table_for = [&, cached = std::shared_ptr<const estimation::ForwardTable>()](
                       const estimation::MeasurementSet& set) mutable {
    if (!cached || cached->key() != estimation::ForwardTable::cache_key(set, estimation::TableGrid{}))
      cached = std::make_shared<const estimation::ForwardTable>(
          estimation::ForwardTable::build(set, estimation::TableGrid{}, 2));
    return cached;
  };
  const estimation::MeasurementSet declared = declared_noise_free(lab.noise_free.set);
  for (int c = 0; c < kConfigs; ++c) {
    const Config config = static_cast<Config>(c);
    if (quick && (config == kAutoNoPool || config == k2d)) continue;
    r.noisy[c] = score(lab, truth, skin,
                       estimate(table_for(lab.noisy.set), lab.noisy.set, lab.noisy.measured, lab.width, lab.height, config));
    r.noise_free[c] = score(lab, truth, skin,
                            estimate(table_for(lab.noise_free.set), lab.noise_free.set, lab.noise_free.measured,
                                     lab.width, lab.height, config));
    if (!quick) r.declared[c] = score(lab, truth, skin,
                          estimate(table_for(declared), declared, lab.noise_free.measured, lab.width, lab.height, config));
  }
  return r;
}

// Issue 37's statistic: relit ΔE94 mean of D65 and A.
double mean_d65_a(const ConfigResult& c) { return (c.acc.de_d65 + c.de_a) / 2; }

void print_header() {
  std::printf("relit dE94 on explained skin cells (six LEDs + D65); order 4 = share of them at order 4\n");
  std::printf("%6s %-22s %8s %8s %8s %8s %8s %9s %8s %8s %8s\n", "seed", "data", "auto", "no-pool", "4d", "2d",
              "auto/4d", "nopool/4d", "order4", "skin flg", "4d flg");
}

void print_rows(const char* label, const SeedResult& r) {
  const struct {
    const char* name;
    const ConfigResult* c;
  } data[3] = {{"noisy", r.noisy}, {"noise-free (declared σ)", r.noise_free}, {"noise-free (σ ≈ 0)", r.declared}};
  for (const auto& d : data)
    std::printf("%6s %-22s %8.4f %8.4f %8.4f %8.4f %8.3f %9.3f %7.1f%% %7.2f%% %7.2f%%\n", label, d.name,
                d.c[kAuto].acc.de_all, d.c[kAutoNoPool].acc.de_all, d.c[k4d].acc.de_all, d.c[k2d].acc.de_all,
                d.c[kAuto].acc.de_all / d.c[k4d].acc.de_all, d.c[kAutoNoPool].acc.de_all / d.c[k4d].acc.de_all,
                100 * d.c[kAuto].order4, 100 * d.c[kAuto].flagged[0], 100 * d.c[k4d].flagged[0]);
  for (const auto& d : data)
    std::printf("%6s %-22s auto relit D65 %.4f A %.4f mean(D65,A) %.4f; 4d mean(D65,A) %.4f\n", label, d.name,
                d.c[kAuto].acc.de_d65, d.c[kAuto].de_a, mean_d65_a(d.c[kAuto]), mean_d65_a(d.c[k4d]));
  std::printf("%6s %-22s auto estimate %.2f s wall, of which multi-pixel %.2f s\n", label, "noisy", r.noisy[kAuto].seconds,
              r.noisy[kAuto].denoise_seconds);
  std::printf("%6s %-22s", label, "noisy default flagged");
  for (int k = 0; k < kRegions; ++k)
    std::printf(" %s %.1f%%", simulators::region_name(static_cast<simulators::SceneRegion>(k)), 100 * r.noisy[kAuto].flagged[k]);
  std::printf("\n");
}

// Mean, min and max over the held-out seeds of one figure.
template <class Get>
void print_spread(const char* name, const std::vector<SeedResult>& results, Get get) {
  double sum = 0, low = get(results.front()), high = low;
  for (const auto& r : results) sum += get(r), low = std::min(low, get(r)), high = std::max(high, get(r));
  std::printf("  %-44s mean %8.4f  min %8.4f  max %8.4f\n", name, sum / results.size(), low, high);
}

void write_outputs(const std::filesystem::path& out, const std::vector<SeedResult>& results) {
  std::filesystem::create_directories(out);
  const auto csv = out / (output_stem() + ".csv");
  {
    std::ofstream f(csv);
    f << "seed";
    for (const char* data : {"noisy", "clean", "declared"})
      for (const char* config : kConfigNames) f << "," << data << "_" << config << "_de_all";
    f << ",noisy_de_d65,clean_de_d65,log_cm,log_ch,bm,che,order4_noisy,order4_clean,order4_declared";
    for (int k = 0; k < kRegions; ++k) f << ",flagged_" << simulators::region_name(static_cast<simulators::SceneRegion>(k));
    f << ",skin_flagged_noisy_4d,noisy_de_a,noisy_de_d65_a,clean_de_a,clean_de_d65_a,clean_4d_de_d65_a,"
         "noisy_seconds,noisy_denoise_seconds\n";
    for (const auto& r : results) {
      f << r.seed;
      for (const ConfigResult* d : {r.noisy, r.noise_free, r.declared})
        for (int c = 0; c < kConfigs; ++c) f << "," << d[c].acc.de_all;
      const Accuracy& a = r.noisy[kAuto].acc;
      f << "," << a.de_d65 << "," << r.noise_free[kAuto].acc.de_d65 << "," << a.log_cm << "," << a.log_ch << ","
        << a.bm << "," << a.che << "," << r.noisy[kAuto].order4 << "," << r.noise_free[kAuto].order4 << ","
        << r.declared[kAuto].order4;
      for (double v : r.noisy[kAuto].flagged) f << "," << v;
      f << "," << r.noisy[k4d].flagged[0] << "," << r.noisy[kAuto].de_a << "," << mean_d65_a(r.noisy[kAuto]) << ","
        << r.noise_free[kAuto].de_a << "," << mean_d65_a(r.noise_free[kAuto]) << "," << mean_d65_a(r.noise_free[k4d])
        << "," << r.noisy[kAuto].seconds << "," << r.noisy[kAuto].denoise_seconds << "\n";
    }
  }
  files::GnuplotChart chart;
  chart.png = out / (output_stem() + ".png");
  chart.commands = "set datafile separator ','\nset key top left\nset style data histograms\n"
                   "set style fill solid 0.8\nset title 'Held-out lab scenes (skin cells), plan " + plan_name + ": auto model against 4D and 2D'\n"
                   "set xlabel 'scene seed'\nset ylabel 'mean relit dE94 vs truth (six LEDs + D65)'\nset yrange [0:*]\n"
                   "plot '" + csv.string() + "' every ::1 using 2:xtic(1) title 'noisy auto', '' every ::1 using 4 "
                   "title 'noisy 4D', '' every ::1 using 6 title 'noise-free auto', '' every ::1 using 8 title "
                   "'noise-free 4D', '' every ::1 using 10 title 'noise-free (declared) auto', '' every ::1 using 12 "
                   "title 'noise-free (declared) 4D'\n";
  if (const std::string error = files::draw_chart(chart); !error.empty()) std::printf("chart: %s\n", error.c_str());
  std::printf("wrote %s and %s\n", csv.c_str(), chart.png.c_str());
}

int run(int argc, char** argv) {
  std::vector<std::uint64_t> seeds{11, 12, 13, 14, 15, 16};
  std::vector<int> sensor{640, 480};
  std::filesystem::path out = "bench/results";
  CLI::App app{"The default estimator on held-out virtual-lab scenes"};
  app.add_option("--seeds", seeds, "held-out scene seeds (not the tuning seed 5)")->delimiter(',');
  app.add_option("--sensor", sensor, "sensor width and height (even)")->expected(2);
  app.add_option("--out", out, "folder for the CSV and the chart");
  app.add_option("--plan", plan_name, "built-in plan: standard, multispectral, multispectral+method");
  bool tuning_only = false;
  app.add_option("--order-factor", order_factor, "the auto model's appearance factor k (tuning)");
  app.add_flag("--tuning-only", tuning_only, "the tuning seed alone (for --order-factor sweeps)");
  app.add_flag("--quick", quick, "the auto and 4D models on the noisy and noise-free (declared σ) frames only");
  bool tuning_seeds = false;
  app.add_flag("--tuning-seeds", tuning_seeds,
               "the spread over the tuning seeds 1-5 instead of --seeds (for choosing defaults; never tune on 11-13)");
  std::string denoise = "on", discrepancy_name = "none";
  app.add_option("--skin-denoise", denoise, "the multi-pixel estimate in the spatial pass (default on, as chromod)")
      ->check(CLI::IsMember({"off", "on"}));
  app.add_option("--discrepancy", discrepancy_name, "the estimator's learned discrepancy of real skin")
      ->check(CLI::IsMember({"none", "learned"}));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (denoise == "on") skin_denoise = estimation::SkinDenoiseOptions{};
  if (discrepancy_name == "learned") discrepancy = estimation::ModelDiscrepancy::standard();
  if (tuning_seeds) seeds = {1, 2, 3, 4, 5};
  if (!tuning_seeds && std::find(seeds.begin(), seeds.end(), kTuningSeed) != seeds.end()) {
    std::fprintf(stderr, "--seeds: %llu is the tuning seed, not a held-out one\n",
                 static_cast<unsigned long long>(kTuningSeed));
    return 2;
  }
  std::printf("plan %s: ", plan_name.c_str());
  std::printf("fast inverter on %dx%d-sensor lab sessions (%dx%d cells); auto = the default (spatial pass with "
              "the pooled likelihood-ratio order); no-pool = the appearance order rule per pixel, k = %.3g\n",
              sensor[0], sensor[1], sensor[0] / 2, sensor[1] / 2, order_factor);
  std::printf("skin denoise %s, discrepancy %s\n", denoise.c_str(), discrepancy_name.c_str());
  print_header();
  if (!tuning_seeds) print_rows("5 (t)", run_seed(kTuningSeed, sensor[0], sensor[1]));
  if (tuning_only) return 0;
  std::vector<SeedResult> results;
  for (std::uint64_t seed : seeds) {
    results.push_back(run_seed(seed, sensor[0], sensor[1]));
    print_rows(std::to_string(seed).c_str(), results.back());
    std::fflush(stdout);
  }
  std::printf("spread over %zu held-out seeds:\n", results.size());
  const struct {
    const char* name;
    ConfigResult (SeedResult::*data)[kConfigs];
  } data[3] = {{"noisy", &SeedResult::noisy}, {"noise-free (declared σ)", &SeedResult::noise_free},
               {"noise-free (σ ≈ 0)", &SeedResult::declared}};
  for (const auto& d : data) {
    for (int c = 0; c < kConfigs; ++c) {
      const std::string name = std::string(d.name) + " " + kConfigNames[c] + " relit dE94";
      print_spread(name.c_str(), results, [&](const SeedResult& r) { return (r.*d.data)[c].acc.de_all; });
    }
    for (int c : {kAuto, kAutoNoPool}) {
      const std::string name = std::string(d.name) + " " + kConfigNames[c] + " / 4d";
      print_spread(name.c_str(), results,
                   [&](const SeedResult& r) { return (r.*d.data)[c].acc.de_all / (r.*d.data)[k4d].acc.de_all; });
    }
    print_spread((std::string(d.name) + " auto skin flagged").c_str(), results,
                 [&](const SeedResult& r) { return (r.*d.data)[kAuto].flagged[0]; });
    print_spread((std::string(d.name) + " 4d skin flagged").c_str(), results,
                 [&](const SeedResult& r) { return (r.*d.data)[k4d].flagged[0]; });
  }
  print_spread("noisy relit dE94 D65 (auto)", results, [](const SeedResult& r) { return r.noisy[kAuto].acc.de_d65; });
  print_spread("noisy relit dE94 A (auto)", results, [](const SeedResult& r) { return r.noisy[kAuto].de_a; });
  print_spread("noisy relit dE94 mean(D65,A) (auto)", results, [](const SeedResult& r) { return mean_d65_a(r.noisy[kAuto]); });
  print_spread("noise-free relit dE94 mean(D65,A) (auto)", results,
               [](const SeedResult& r) { return mean_d65_a(r.noise_free[kAuto]); });
  print_spread("noise-free mean(D65,A) auto / 4d", results,
               [](const SeedResult& r) { return mean_d65_a(r.noise_free[kAuto]) / mean_d65_a(r.noise_free[k4d]); });
  print_spread("noisy estimate seconds (auto)", results, [](const SeedResult& r) { return r.noisy[kAuto].seconds; });
  print_spread("noisy multi-pixel seconds (auto)", results,
               [](const SeedResult& r) { return r.noisy[kAuto].denoise_seconds; });
  for (int k = 0; k < kRegions; ++k) {
    const std::string name = std::string("noisy auto ") +
                             simulators::region_name(static_cast<simulators::SceneRegion>(k)) + " flagged";
    print_spread(name.c_str(), results, [k](const SeedResult& r) { return r.noisy[kAuto].flagged[k]; });
  }
  write_outputs(out, results);
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) {
  try {
    return chromo::bench::run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "held_out_scenes_bench: %s\n", e.what());
    return 1;
  }
}
