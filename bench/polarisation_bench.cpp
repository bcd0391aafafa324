// Polarisation bench (issue 23, part 6; docs/polarisation.md "Bench"):
// the polarised standard session rendered in process
// (simulators/scene/rendered_session.hpp with polarised = true and oily
// regions of 1-20σ of the surface map's noise), over held-out scene seeds
// and the films' extinction ratio at 550 nm (1:50 ... 1:1000), measured as
// chromod measures it (SessionCaptureBuilder, build_measurement: the
// surface map from D65' parallel − cross) and estimated by the fast 4D
// inverter from the cross-polarised captures. Per seed and ratio:
//   - the optical highlight flag (estimation/highlight_flags.hpp) rate per
//     strength bin of the true added reflection in σ (the session's
//     surface_sigma, from the camera noise model), and at ≥ 4σ;
//   - skin falsely flagged (cells whose four sites are skin, no added reflection);
//   - relit ΔE94 (six LEDs + D65, bench/relit_accuracy.hpp) of the diffuse
//     maps against the truth under highlights (≥ 4σ) and on skin, and their ratio;
//   - the surface map's signed bias against the true surface layer
//     (F(0°) + added) where the added reflection is ≥ 10σ.
// Targets at 1:200 (issue 23): ≥ 95% flagged at ≥ 4σ, ≤ 1% of skin, ΔE94
// ratio ≤ 1.2, |bias| ≤ 5%. Prints its table, writes
// results/polarisation.csv and results/polarisation.png.
#include "bench_cli.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/highlight_flags.hpp"
#include "chromo/files/gnuplot_chart.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/simulators/scene/scene.hpp"

#include "guarded_main.hpp"
#include "relit_accuracy.hpp"

namespace {

using namespace chromo;

constexpr double kBinEdges[] = {0.5, 1, 2, 4, 10, 20, 1e9};
constexpr int kBins = 6;

struct Run {
  double flag_rate_bin[kBins] = {};
  std::size_t bin_cells[kBins] = {};
  double flagged_4sigma = 0, skin_flagged = 0, de_highlight = 0, de_skin = 0, ratio = 0, bias_10sigma = 0;
  std::size_t cells_4sigma = 0, cells_10sigma = 0, skin_cells = 0;
  double surface_sigma = 0, sheen_reference = 0;
  double de_bin[kBins] = {};  // relit ΔE94 under highlights per strength bin
  double skin_sigma_measured = 0, skin_sigma_model = 0;  // std of S on skin; mean σ_i there (the flag's)
  double bias_red_10sigma = 0, bias_blue_10sigma = 0;     // the R and B surface maps' bias (where unsaturated... all ≥ 10σ cells)
  std::size_t corrected_cells = 0;                        // cross captures corrected by S itself
};

Run run_one(std::uint64_t seed, double extinction_ratio, int sensor_width, int sensor_height, int oily_count,
            bool surface_correction) {
  simulators::RenderedSessionOptions o;
  o.sensor_width = sensor_width, o.sensor_height = sensor_height;
  o.seed = seed;
  o.polarised = true;
  o.extinction_ratio_550nm = extinction_ratio;
  o.oily.count = oily_count;
  o.estimator_knows_films = surface_correction;
  o.noise_free = false;
  o.threads = 2;
  const simulators::RenderedSession lab = simulators::render_session(o);
  const std::vector<float> added = simulators::cell_added_reflection(o, lab.surface_sigma);
  const auto& m = lab.noisy;
  const estimation::HighlightFlags flags = estimation::flag_highlights(m.surface, m.surface_sigma, m.width, m.height);
  Run r;
  r.surface_sigma = lab.surface_sigma;
  r.sheen_reference = flags.sheen_reference;
  const auto specular = static_cast<std::uint8_t>(simulators::SceneRegion::kSpecular);
  const auto skin = static_cast<std::uint8_t>(simulators::SceneRegion::kSkin);
  // What lies under the highlights: the same scene without them. Highlight
  // cells count only where all four sites are skin underneath (an oily
  // region over hair or a tattoo scores the anomaly, not the highlight).
  simulators::SkinSceneOptions beneath;
  beneath.width = sensor_width, beneath.height = sensor_height, beneath.seed = seed, beneath.white_patch = false;
  beneath.threads = 2, beneath.highlight = false;
  const simulators::Scene under = simulators::make_skin_scene(beneath);
  std::vector<bool> skin_beneath(lab.pixels());
  for (int y = 0; y < lab.height; ++y)
    for (int x = 0; x < lab.width; ++x) {
      bool all_skin = true;
      for (int d = 0; d < 4; ++d) all_skin = all_skin && under.regions().at<std::uint8_t>(2 * y + d / 2, 2 * x + d % 2) == skin;
      skin_beneath[static_cast<std::size_t>(y) * lab.width + x] = all_skin;
    }
  std::vector<bool> highlight_mask(lab.pixels()), skin_mask(lab.pixels());
  std::size_t flagged_bin[kBins] = {}, flagged_4 = 0, skin_flagged = 0;
  double bias_sum = 0, bias_red_sum = 0, bias_blue_sum = 0;
  for (std::size_t i = 0; i < lab.pixels(); ++i) {
    if (lab.region[i] == skin) {
      ++r.skin_cells, skin_flagged += flags.flag[i], skin_mask[i] = true;
      continue;
    }
    if (lab.region[i] != specular) continue;
    const double n_sigma = added[i] / lab.surface_sigma;
    for (int b = 0; b < kBins; ++b)
      if (n_sigma >= kBinEdges[b] && n_sigma < kBinEdges[b + 1]) ++r.bin_cells[b], flagged_bin[b] += flags.flag[i];
    if (n_sigma >= 4) ++r.cells_4sigma, flagged_4 += flags.flag[i], highlight_mask[i] = skin_beneath[i];
    if (n_sigma >= 10 && std::isfinite(m.surface[i])) {
      const double truth = lab.sheen + added[i];
      bias_sum += (m.surface[i] - truth) / truth, ++r.cells_10sigma;
      bias_red_sum += (m.surface_red[i] - truth) / truth, bias_blue_sum += (m.surface_blue[i] - truth) / truth;
    }
  }
  {
    double sum = 0, sum2 = 0, model = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < lab.pixels(); ++i)
      if (skin_mask[i] && std::isfinite(m.surface[i]))
        sum += m.surface[i], sum2 += double(m.surface[i]) * m.surface[i], model += m.surface_sigma[i], ++n;
    r.skin_sigma_measured = std::sqrt(std::max(0.0, sum2 / n - (sum / n) * (sum / n)));
    r.skin_sigma_model = model / n;
  }
  for (int b = 0; b < kBins; ++b)
    r.flag_rate_bin[b] = r.bin_cells[b] ? static_cast<double>(flagged_bin[b]) / r.bin_cells[b] : std::nan("");
  r.flagged_4sigma = r.cells_4sigma ? static_cast<double>(flagged_4) / r.cells_4sigma : std::nan("");
  r.skin_flagged = r.skin_cells ? static_cast<double>(skin_flagged) / r.skin_cells : std::nan("");
  r.bias_10sigma = r.cells_10sigma ? bias_sum / r.cells_10sigma : std::nan("");
  r.bias_red_10sigma = r.cells_10sigma ? bias_red_sum / r.cells_10sigma : std::nan("");
  r.bias_blue_10sigma = r.cells_10sigma ? bias_blue_sum / r.cells_10sigma : std::nan("");
  if (m.surface_correction) r.corrected_cells = m.surface_correction->corrected_pixels;

  // The diffuse maps from the cross-polarised captures.
  const auto table = estimation::ForwardTable::load_or_build(m.set, estimation::TableGrid{},
                                                             estimation::ForwardTable::default_cache_dir());
  estimation::EstimatorOptions estimator_options;
  estimator_options.threads = 2;
  const estimation::Estimator estimator(table, m.set, estimator_options);
  std::vector<estimation::PixelEstimate> estimates(lab.pixels());
  estimator.estimate(m.measured, estimates);
  const bench::Relit truth = bench::relight(lab.truth);
  r.de_highlight = bench::accuracy(truth, lab.truth, estimates, highlight_mask).de_all;
  r.de_skin = bench::accuracy(truth, lab.truth, estimates, skin_mask).de_all;
  r.ratio = r.de_highlight / r.de_skin;
  for (int b = 0; b < kBins; ++b) {
    std::vector<bool> in_bin(lab.pixels());
    for (std::size_t i = 0; i < lab.pixels(); ++i) {
      const double n_sigma = added[i] / lab.surface_sigma;
      in_bin[i] = lab.region[i] == specular && skin_beneath[i] && n_sigma >= kBinEdges[b] && n_sigma < kBinEdges[b + 1];
    }
    const bench::Accuracy a = bench::accuracy(truth, lab.truth, estimates, in_bin);
    r.de_bin[b] = a.pixels ? a.de_all : std::nan("");
  }
  return r;
}

struct Spread {
  double mean = 0, min = 0, max = 0;
};
Spread spread(const std::vector<double>& v) {
  Spread s{0, 1e300, -1e300};
  int n = 0;
  for (double x : v)
    if (std::isfinite(x)) s.mean += x, s.min = std::min(s.min, x), s.max = std::max(s.max, x), ++n;
  if (n == 0) return {std::nan(""), std::nan(""), std::nan("")};
  s.mean /= n;
  return s;
}
std::string show(const Spread& s, double scale, const char* format = "%.2f") {
  char a[32], b[32], c[32];
  std::snprintf(a, sizeof a, format, s.mean * scale), std::snprintf(b, sizeof b, format, s.min * scale),
      std::snprintf(c, sizeof c, format, s.max * scale);
  return std::string(a) + " [" + b + ", " + c + "]";
}

// One row of the table: one extinction ratio, one mode, over the seeds.
struct Row {
  std::vector<double> flagged, skin_rate, de_ratio, bias, bias_red, bias_blue, bins[kBins], de_h, de_s, de_bins[kBins],
      skin_std, skin_model, session_sigma, corrected;
};

void add_run(Row& row, const Run& r) {
  row.flagged.push_back(r.flagged_4sigma), row.skin_rate.push_back(r.skin_flagged), row.de_ratio.push_back(r.ratio);
  row.bias.push_back(r.bias_10sigma), row.de_h.push_back(r.de_highlight), row.de_s.push_back(r.de_skin);
  row.bias_red.push_back(r.bias_red_10sigma), row.bias_blue.push_back(r.bias_blue_10sigma);
  for (int b = 0; b < kBins; ++b) row.bins[b].push_back(r.flag_rate_bin[b]), row.de_bins[b].push_back(r.de_bin[b]);
  row.skin_std.push_back(r.skin_sigma_measured), row.skin_model.push_back(r.skin_sigma_model);
  row.session_sigma.push_back(r.surface_sigma), row.corrected.push_back(static_cast<double>(r.corrected_cells));
}

void print_row(double ratio, const char* mode, const Row& row) {
  std::printf("1:%-5g %-6s | %-22s | %-22s | %-22s | %-22s\n", ratio, mode, show(spread(row.flagged), 100, "%.1f").c_str(),
              show(spread(row.skin_rate), 100, "%.2f").c_str(), show(spread(row.de_ratio), 1).c_str(),
              show(spread(row.bias), 100, "%+.1f").c_str());
}

void print_details(const char* mode, const Row& row) {
  std::printf("        %s: flagged by bin (σ above the sheen):", mode);
  for (int b = 0; b < kBins; ++b)
    std::printf(" %g-%g: %.0f%%", kBinEdges[b], kBinEdges[b + 1] > 1e8 ? INFINITY : kBinEdges[b + 1], 100 * spread(row.bins[b]).mean);
  std::printf("\n        %s: ΔE94 highlight (≥4σ, skin beneath) %s, skin %s; by bin:", mode, show(spread(row.de_h), 1).c_str(),
              show(spread(row.de_s), 1).c_str());
  for (int b = 0; b < kBins; ++b) std::printf(" %.2f", spread(row.de_bins[b]).mean);
  std::printf("\n        %s: surface bias ≥10σ R %s, G %s, B %s; cells corrected by S %s\n", mode,
              show(spread(row.bias_red), 100, "%+.1f").c_str(), show(spread(row.bias), 100, "%+.1f").c_str(),
              show(spread(row.bias_blue), 100, "%+.1f").c_str(), show(spread(row.corrected), 1, "%.0f").c_str());
  std::printf("        %s: surface map on skin: std %s, the flag's σ (measurement noise model) %s, session σ %s\n", mode,
              show(spread(row.skin_std), 1, "%.5f").c_str(), show(spread(row.skin_model), 1, "%.5f").c_str(),
              show(spread(row.session_sigma), 1, "%.5f").c_str());
}

int bench_main(int argc, char** argv) {
  CLI::App app{"Polarisation bench: optical highlight flag, diffuse error under highlights and surface-map bias "
               "against the films' extinction ratio, without and with the estimator knowing the films"};
  std::vector<std::uint64_t> seeds = {101, 102, 103, 104, 105, 201, 202, 203};
  std::vector<double> ratios = {50, 100, 200, 500, 1000};
  int width = 384, height = 288, oily = 14;
  std::string out_dir = "bench/results", modes = "both";
  app.add_option("--seeds", seeds, "held-out scene seeds (the tests use 1-7)");
  app.add_option("--ratios", ratios, "extinction ratios at 550 nm");
  app.add_option("--width", width, "sensor width (even)");
  app.add_option("--height", height, "sensor height (even)");
  app.add_option("--oily", oily, "oily regions per scene (1-20σ, log-spaced)");
  app.add_option("--surface-correction", modes,
                 "off: the estimator without the films (surface map (P − X)/2, cross captures as captured); "
                 "on: with them (surface maps extinction-corrected, cross captures less their surface light); both")
      ->check(CLI::IsMember({"off", "on", "both"}));
  app.add_option("--out", out_dir, "folder for polarisation.csv and polarisation.png");
  CLI11_PARSE(app, argc, argv);
  std::vector<bool> corrections;
  if (modes != "on") corrections.push_back(false);
  if (modes != "off") corrections.push_back(true);
  std::filesystem::create_directories(out_dir);
  std::ofstream csv(std::filesystem::path(out_dir) / "polarisation.csv");
  csv << "extinction_ratio,surface_correction,seed,surface_sigma,sheen_reference,flag_0.5-1,flag_1-2,flag_2-4,flag_4-10,flag_10-20,flag_20+,"
         "flagged_4sigma,cells_4sigma,skin_flagged,skin_cells,de94_highlight,de94_skin,de94_ratio,bias_10sigma,cells_10sigma,"
         "de94_0.5-1,de94_1-2,de94_2-4,de94_4-10,de94_10-20,de94_20+,skin_surface_std,skin_surface_sigma_model,"
         "bias_red_10sigma,bias_blue_10sigma,corrected_cells\n";
  std::printf("sensor %d×%d (measurement %d×%d), %d oily regions, seeds", width, height, width / 2, height / 2, oily);
  for (auto s : seeds) std::printf(" %llu", static_cast<unsigned long long>(s));
  std::printf("; mean [min, max] over seeds. off: the estimator without the films; on: surface maps and cross captures corrected\n\n");
  std::printf("%-14s | %-22s | %-22s | %-22s | %-22s\n", "ER    mode", "flagged ≥4σ (%)", "skin flagged (%)", "ΔE94 ratio hl/skin",
              "surface bias ≥10σ (%)");
  std::ostringstream chart_data;
  for (double ratio : ratios) {
    Row rows[2];
    for (auto seed : seeds)
      for (bool correction : corrections) {
        const Run r = run_one(seed, ratio, width, height, oily, correction);
        add_run(rows[correction], r);
        csv << ratio << ',' << (correction ? "on" : "off") << ',' << seed << ',' << r.surface_sigma << ',' << r.sheen_reference;
        for (double v : r.flag_rate_bin) csv << ',' << v;
        csv << ',' << r.flagged_4sigma << ',' << r.cells_4sigma << ',' << r.skin_flagged << ',' << r.skin_cells << ','
            << r.de_highlight << ',' << r.de_skin << ',' << r.ratio << ',' << r.bias_10sigma << ',' << r.cells_10sigma;
        for (double v : r.de_bin) csv << ',' << v;
        csv << ',' << r.skin_sigma_measured << ',' << r.skin_sigma_model << ',' << r.bias_red_10sigma << ','
            << r.bias_blue_10sigma << ',' << r.corrected_cells << "\n";
      }
    for (bool correction : corrections) print_row(ratio, correction ? "on" : "off", rows[correction]);
    for (bool correction : corrections) print_details(correction ? "on" : "off", rows[correction]);
    std::printf("        ΔE94 ratio per seed:");
    for (bool correction : corrections) {
      std::printf(" %s", correction ? "on" : "off");
      for (double v : rows[correction].de_ratio) std::printf(" %.3f", v);
      std::printf(";");
    }
    std::printf("\n");
    chart_data << ratio;
    for (bool correction : {false, true}) {
      const Row& row = rows[correction];
      const bool present = std::find(corrections.begin(), corrections.end(), correction) != corrections.end();
      chart_data << ' ' << (present ? 100 * spread(row.flagged).mean : NAN) << ' ' << (present ? 100 * spread(row.skin_rate).mean : NAN)
                 << ' ' << (present ? spread(row.de_ratio).mean : NAN) << ' ' << (present ? spread(row.de_ratio).max : NAN) << ' '
                 << (present ? 100 * std::abs(spread(row.bias).mean) : NAN);
    }
    chart_data << "\n";
  }
  std::printf("\ntargets at 1:200: flagged ≥4σ ≥ 95%%, skin ≤ 1%%, ΔE94 ratio ≤ 1.2 (every seed), |bias| ≤ 5%% (every ratio)\n");
  const auto dat = std::filesystem::path(out_dir) / "polarisation.dat";
  std::ofstream(dat) << chart_data.str();
  files::GnuplotChart chart;
  chart.png = std::filesystem::path(out_dir) / "polarisation.png";
  chart.terminal = "pngcairo size 1000,520 font 'DejaVu Sans,10'";
  chart.commands = "set multiplot layout 1,2 title 'Polarised sphere against the extinction ratio (mean over seeds; off / on: estimator without / with the films)'\n"
                   "set logscale x\nset xrange [40:1250]\nset xlabel 'extinction ratio 1:x at 550 nm'\nset grid\nset key bottom right\n"
                   "set ylabel '%'\nset yrange [0:105]\n"
                   "plot '" + dat.string() + "' using 1:7 with linespoints title 'flagged at >= 4 sigma (on)', '' using 1:2 with linespoints dt 2 title 'flagged (off)', "
                   "'' using 1:8 with linespoints title 'skin flagged (on)', 95 dt 2 title 'target 95%'\n"
                   "set yrange [0:*]\nset ylabel 'ratio / %'\nset key top right\n"
                   "plot '" + dat.string() + "' using 1:9 with linespoints title 'dE94 ratio highlight/skin, mean (on)', '' using 1:10 with linespoints title 'worst seed (on)', "
                   "'' using 1:4 with linespoints dt 2 title 'worst seed (off)', "
                   "'' using 1:11 with linespoints title '|surface bias| % (on)', '' using 1:6 with linespoints dt 2 title '|surface bias| % (off)', "
                   "1.2 dt 3 title 'ratio target 1.2', 5 dt 3 title 'bias target 5%'\n"
                   "unset multiplot\n";
  if (const std::string failed = files::draw_chart(chart, std::filesystem::path(out_dir) / "polarisation.gp"); !failed.empty())
    std::fprintf(stderr, "chart: %s\n", failed.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return chromo::bench::guarded_main("polarisation_bench", bench_main, argc, argv); }
