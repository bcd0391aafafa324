// The default estimator (fast inverter, auto model, spatial pass) on virtual-
// lab sessions it was never tuned on: the standard session rendered from the
// lab's physics (simulators/scene/rendered_session.hpp) for several scene
// seeds other than the tuning seed 5. Each seed draws its own skin fields
// (Cm, Ch, βm, Che) and places its own vein, tattoo ink, marker, hair and
// highlights, and its own camera noise. Per seed and for the spread over the
// held-out seeds (mean, min, max): relit ΔE94 against the truth on the skin
// cells (six LEDs + D65, and D65 alone), noisy and noise-free, each
// parameter's error, and the share of each scene region flagged.
//
//   held_out_scenes_bench [--seeds 11,12,13,14,15,16] [--sensor W H] [--out DIR]
//
// Writes DIR/held_out_scenes.csv and DIR/held_out_scenes.png (relit ΔE94 per
// seed). The tuning seed's row is printed first, for reference, and is not
// part of the spread.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/spatial_flags.hpp"
#include "chromo/files/gnuplot_chart.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "relit_accuracy.hpp"

namespace chromo::bench {
namespace {

constexpr std::uint64_t kTuningSeed = 5;
constexpr int kRegions = 6;  // skin, vein, tattoo, marker, hair, specular

struct SeedResult {
  std::uint64_t seed = 0;
  Accuracy noisy, noise_free;          // on skin cells, explained ones
  double flagged[kRegions] = {};       // share of each region's cells flagged (noisy, with the spatial pass)
  std::size_t region_cells[kRegions] = {};
};

// The default estimator on one measurement: per pixel, then the spatial pass.
std::vector<estimation::PixelEstimate> estimate(const session::MethodMeasurement& m, int width, int height) {
  auto table = std::make_shared<const estimation::ForwardTable>(
      estimation::ForwardTable::build(m.set, estimation::TableGrid{}, 2));
  estimation::EstimatorOptions options;
  options.threads = 2;
  const estimation::Estimator estimator(table, m.set, options);
  std::vector<estimation::PixelEstimate> e(m.measured.size() / static_cast<std::size_t>(m.set.size()));
  estimation::EstimateSummary summary = estimator.estimate(m.measured, e);
  estimation::refine_with_neighbourhood(estimator, m.measured, width, height, e, summary);
  return e;
}

SeedResult run_seed(std::uint64_t seed, int sensor_width, int sensor_height) {
  simulators::RenderedSessionOptions ro;
  ro.sensor_width = sensor_width, ro.sensor_height = sensor_height, ro.seed = seed, ro.threads = 2;
  const simulators::RenderedSession lab = simulators::render_session(ro);
  SeedResult r;
  r.seed = seed;
  std::vector<bool> skin(lab.pixels());
  for (std::size_t i = 0; i < lab.pixels(); ++i)
    skin[i] = lab.region[i] == static_cast<std::uint8_t>(simulators::SceneRegion::kSkin);
  const Relit truth = relight(lab.truth);
  const auto noisy = estimate(lab.noisy, lab.width, lab.height);
  const auto noise_free = estimate(lab.noise_free, lab.width, lab.height);
  r.noisy = accuracy(truth, lab.truth, noisy, skin);
  r.noise_free = accuracy(truth, lab.truth, noise_free, skin);
  std::size_t flagged[kRegions] = {};
  for (std::size_t i = 0; i < lab.pixels(); ++i) {
    if (lab.region[i] >= kRegions) continue;  // white target, mixed cells
    ++r.region_cells[lab.region[i]];
    if (noisy[i].flag != estimation::PixelFlag::kExplained) ++flagged[lab.region[i]];
  }
  for (int k = 0; k < kRegions; ++k)
    r.flagged[k] = r.region_cells[k] ? static_cast<double>(flagged[k]) / r.region_cells[k] : 0.0;
  return r;
}

void print_header() {
  std::printf("%6s %9s %9s %9s %9s %8s %8s %8s %8s", "seed", "noisy", "noisy", "clean", "clean", "|dlogCm|",
              "|dlogCh|", "|dBm|", "|dChe|");
  for (int k = 0; k < kRegions; ++k) std::printf(" %9.9s", simulators::region_name(static_cast<simulators::SceneRegion>(k)));
  std::printf("\n%6s %9s %9s %9s %9s %8s %8s %8s %8s", "", "dE all", "dE D65", "dE all", "dE D65", "noisy", "noisy",
              "noisy", "noisy");
  for (int k = 0; k < kRegions; ++k) std::printf(" %9s", "flagged");
  std::printf("\n");
}

void print_row(const char* label, const SeedResult& r) {
  std::printf("%6s %9.3f %9.3f %9.3f %9.3f %8.3f %8.3f %8.3f %8.4f", label, r.noisy.de_all, r.noisy.de_d65,
              r.noise_free.de_all, r.noise_free.de_d65, r.noisy.log_cm, r.noisy.log_ch, r.noisy.bm, r.noisy.che);
  for (int k = 0; k < kRegions; ++k) std::printf(" %8.1f%%", 100 * r.flagged[k]);
  std::printf("\n");
}

// Mean, min and max over the held-out seeds of one figure.
template <class Get>
void print_spread(const char* name, const std::vector<SeedResult>& results, Get get) {
  double sum = 0, low = get(results.front()), high = low;
  for (const auto& r : results) sum += get(r), low = std::min(low, get(r)), high = std::max(high, get(r));
  std::printf("  %-34s mean %8.4f  min %8.4f  max %8.4f\n", name, sum / results.size(), low, high);
}

void write_outputs(const std::filesystem::path& out, const std::vector<SeedResult>& results) {
  std::filesystem::create_directories(out);
  const auto csv = out / "held_out_scenes.csv";
  {
    std::ofstream f(csv);
    f << "seed,noisy_de_all,noisy_de_d65,clean_de_all,clean_de_d65,log_cm,log_ch,bm,che";
    for (int k = 0; k < kRegions; ++k) f << ",flagged_" << simulators::region_name(static_cast<simulators::SceneRegion>(k));
    f << "\n";
    for (const auto& r : results) {
      f << r.seed << "," << r.noisy.de_all << "," << r.noisy.de_d65 << "," << r.noise_free.de_all << ","
        << r.noise_free.de_d65 << "," << r.noisy.log_cm << "," << r.noisy.log_ch << "," << r.noisy.bm << ","
        << r.noisy.che;
      for (double v : r.flagged) f << "," << v;
      f << "\n";
    }
  }
  files::GnuplotChart chart;
  chart.png = out / "held_out_scenes.png";
  chart.commands = "set datafile separator ','\nset key top left\nset style data histograms\n"
                   "set style fill solid 0.8\nset title 'Default estimator on held-out lab scenes (skin cells)'\n"
                   "set xlabel 'scene seed'\nset ylabel 'mean relit dE94 vs truth (six LEDs + D65)'\nset yrange [0:*]\n"
                   "plot '" + csv.string() + "' every ::1 using 2:xtic(1) title 'noisy', '' every ::1 using 4 title 'noise-free'\n";
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
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (std::find(seeds.begin(), seeds.end(), kTuningSeed) != seeds.end()) {
    std::fprintf(stderr, "--seeds: %llu is the tuning seed, not a held-out one\n",
                 static_cast<unsigned long long>(kTuningSeed));
    return 2;
  }
  std::printf("default estimator (fast, auto, spatial pass) on %dx%d-sensor lab sessions (%dx%d cells)\n", sensor[0],
              sensor[1], sensor[0] / 2, sensor[1] / 2);
  print_header();
  print_row("5 (t)", run_seed(kTuningSeed, sensor[0], sensor[1]));
  std::vector<SeedResult> results;
  for (std::uint64_t seed : seeds) {
    results.push_back(run_seed(seed, sensor[0], sensor[1]));
    print_row(std::to_string(seed).c_str(), results.back());
  }
  std::printf("spread over %zu held-out seeds:\n", results.size());
  print_spread("noisy relit dE94, six LEDs + D65", results, [](const SeedResult& r) { return r.noisy.de_all; });
  print_spread("noisy relit dE94, D65", results, [](const SeedResult& r) { return r.noisy.de_d65; });
  print_spread("noise-free relit dE94, six LEDs + D65", results, [](const SeedResult& r) { return r.noise_free.de_all; });
  for (int k = 0; k < kRegions; ++k) {
    const std::string name = std::string(simulators::region_name(static_cast<simulators::SceneRegion>(k))) + " flagged";
    print_spread(name.c_str(), results, [k](const SeedResult& r) { return r.flagged[k]; });
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
