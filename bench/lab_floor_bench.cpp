// What sets the virtual lab's accuracy floor (issue 20): the method's plan
// (the standard session, rendered_session.hpp) on noise-free frames declared
// noise-free, with the lab's imperfections switched off one at a time and
// all together, side by side in one run, over held-out scene seeds.
//
// Imperfections (RenderedSessionOptions):
//   led      linear_led_light: the light is Σ drive · library spectrum, the
//            illuminant the estimator is told (the lab: the LedLab's settled
//            emission at partial drive, junctions cooler than at the
//            library's full drive);
//   cell     cell_uniform_scene: each 2×2 Bayer cell sees one scene pixel
//            (the lab: four sites, four points of a smooth scene, the truth
//            their mean parameters);
//   content  scene_anomalies = false: no vein, tattoo, marker, hair or
//            highlight in the light (labels kept), so nothing leaks into
//            skin cells (the vein's profile tail below its 0.05 label
//            threshold does in the lab).
// Not switched (equal by construction in the rendered session, printed as
// such): the LED library is the lab's true full-drive emission (no
// spectrometer error), the estimator's camera sensitivity is the lab
// camera's, the white target's reflectance is the assumed flat 0.99, the
// illumination is uniform; registration is reported (a still subject: a
// capture is warped only when the found motion exceeds the threshold).
//
// Per configuration, on skin cells (region skin, the four sites agreeing):
// relit ΔE94 (six LEDs + D65) of the fast 4D inverter and of the exhaustive
// 4D search (a fixed subsample of skin cells), on the cells the estimator
// explains and on every skin cell (its best fit); and the oracle: the same
// truths measured by the estimator's own model (MeasurementSet::weights ·
// SkinModel albedo), which is the table and inverter's floor; the
// measurement's deviation from that oracle per channel (signed mean and RMS,
// % of the oracle's value): where the chain's error enters.
//
//   lab_floor_bench [--seeds 11,12,13] [--sensor 256 192] [--exhaustive-cells 800] [--out bench/results]
//
// Writes OUT/lab_floor.csv (per seed), OUT/lab_floor.png (fast 4D, mean
// over seeds, per configuration).
#include "bench_cli.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "chart.hpp"
#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "guarded_main.hpp"
#include "noise_declaration.hpp"
#include "relit_accuracy.hpp"
#include "seed_spread.hpp"

namespace chromo::bench {
namespace {

struct Configuration {
  std::string name;
  bool linear_led_light, cell_uniform_scene, scene_anomalies;
};

// The lab as it is, each imperfection off alone, all off, and all off but each.
const std::vector<Configuration> kConfigurations = {
    {"lab as is", false, false, true},
    {"linear LED light", true, false, true},
    {"cell-uniform scene", false, true, true},
    {"no scene content", false, false, false},
    {"all three off", true, true, false},
    {"only LED drift on", false, true, false},
    {"only Bayer cell on", true, false, false},
    {"only content on", true, true, true},
};

struct Figures {
  double fast_explained = 0, fast_every = 0;  // relit ΔE94 (six LEDs + D65), fast 4D
  double exhaustive_every = 0;                // exhaustive 4D on the subsample, every skin cell
  double fast_subsample_every = 0;            // fast 4D on the same subsample (to compare with exhaustive)
  double oracle_fast = 0;                     // fast 4D on the oracle measurement, every skin cell
  double table_self_fast = 0;                 // fast 4D on the table's own prediction at the truth, every skin cell
  double interpolation_rms_pct = 0;           // table's prediction − oracle at the skin truths, RMS over channels, %
  // On the table's own prediction: the cells the fit leaves more than 0.5
  // relit ΔE94 off the truth, their share and median χ² (≈ 0: another exact
  // solution of the four numbers, not a fit that failed).
  double table_self_far_share = 0, table_self_far_median_chi2 = 0, table_self_median_de = 0;
  estimation::SkinParameters far_error{0, 0, 0, 0};  // their mean signed error: log10 Cm, log10 Ch, βm, Che
  // Their fitted parameters through the exact model (not the table) against
  // the exact model at the truth: RMS over channels and cells, % — small
  // means two parameter sets the four channels cannot tell apart.
  double far_exact_difference_pct = 0;
  double explained_share = 0;
  std::vector<std::string> channel_names;
  std::vector<double> deviation_mean_pct, deviation_rms_pct;  // per channel, measured vs oracle
  double max_warp_motion_px = 0;
  int warped = 0;
};

std::vector<estimation::PixelEstimate> estimate(const std::shared_ptr<const estimation::ForwardTable>& table,
                                                const estimation::MeasurementSet& set, std::span<const float> measured,
                                                estimation::InverterMethod method) {
  estimation::EstimatorOptions o;
  o.threads = 2;
  o.model = estimation::ModelChoice::k4d;
  o.method = method;
  std::vector<estimation::PixelEstimate> e(measured.size() / set.size());
  estimation::Estimator(table, set, o).estimate(measured, e);
  return e;
}

// Every estimate counted, a flagged one by its best fit.
std::vector<estimation::PixelEstimate> best_fits(std::vector<estimation::PixelEstimate> e) {
  for (estimation::PixelEstimate& p : e)
    if (p.order != 0) p.flag = estimation::PixelFlag::kExplained;
  return e;
}

Figures run(const Configuration& c, std::uint64_t seed, int width, int height, std::size_t exhaustive_cells,
            const estimation::TableGrid& grid) {
  simulators::RenderedSessionOptions ro;
  ro.sensor_width = width, ro.sensor_height = height, ro.seed = seed, ro.threads = 2;
  ro.linear_led_light = c.linear_led_light;
  ro.cell_uniform_scene = c.cell_uniform_scene;
  ro.scene_anomalies = c.scene_anomalies;
  const simulators::RenderedSession lab = simulators::render_session(ro);
  const estimation::MeasurementSet set = declared_noise_free(lab.noise_free.set);
  const int channels = set.size();
  std::vector<bool> skin(lab.pixels());
  std::vector<std::size_t> skin_cells;
  for (std::size_t i = 0; i < lab.pixels(); ++i)
    if ((skin[i] = lab.region[i] == static_cast<std::uint8_t>(simulators::SceneRegion::kSkin))) skin_cells.push_back(i);

  // The oracle: the estimator's own model of the truth.
  const Eigen::MatrixXd weights = set.weights();
  std::vector<spectral::Spectrum> albedo(lab.pixels());
  estimation::SkinModel().albedo_batch(lab.truth, albedo);
  std::vector<float> oracle(lab.pixels() * channels);
  for (std::size_t i = 0; i < lab.pixels(); ++i) {
    const Eigen::VectorXd v = weights * albedo[i].values().matrix();
    for (int k = 0; k < channels; ++k) oracle[i * channels + k] = static_cast<float>(v[k]);
  }

  Figures f;
  for (const estimation::MeasurementChannel& ch : set.channels) f.channel_names.push_back(ch.name);
  f.deviation_mean_pct.assign(channels, 0), f.deviation_rms_pct.assign(channels, 0);
  for (std::size_t i : skin_cells)
    for (int k = 0; k < channels; ++k) {
      const double d = 100.0 * (lab.noise_free.measured[i * channels + k] - oracle[i * channels + k]) /
                       oracle[i * channels + k];
      f.deviation_mean_pct[k] += d / skin_cells.size();
      f.deviation_rms_pct[k] += d * d / skin_cells.size();
    }
  for (double& r : f.deviation_rms_pct) r = std::sqrt(r);
  for (const session::RegistrationReport& r : lab.noise_free.registration)
    f.warped += r.warped, f.max_warp_motion_px = std::max(f.max_warp_motion_px, r.motion_px);

  const Relit truth = relight(lab.truth);
  const auto table = std::make_shared<const estimation::ForwardTable>(estimation::ForwardTable::build(set, grid, 2));
  const auto fast = estimate(table, set, lab.noise_free.measured, estimation::InverterMethod::kFast);
  const Accuracy explained = accuracy(truth, lab.truth, fast, skin);
  f.fast_explained = explained.de_all;
  f.explained_share = skin_cells.empty() ? 0 : double(explained.pixels) / skin_cells.size();
  f.fast_every = accuracy(truth, lab.truth, best_fits(fast), skin).de_all;
  f.oracle_fast =
      accuracy(truth, lab.truth, best_fits(estimate(table, set, oracle, estimation::InverterMethod::kFast)), skin).de_all;
  // The table's own prediction at the truth: what is left is the search
  // (several parameter sets predicting the same four numbers), not the
  // table's interpolation error.
  std::vector<float> table_self(lab.pixels() * channels);
  std::vector<double> predicted(channels);
  for (std::size_t i = 0; i < lab.pixels(); ++i) {
    table->predict(table->to_grid(lab.truth[i]), predicted.data());
    for (int k = 0; k < channels; ++k) table_self[i * channels + k] = static_cast<float>(predicted[k]);
  }
  for (std::size_t i : skin_cells)
    for (int k = 0; k < channels; ++k) {
      const double d = 100.0 * (table_self[i * channels + k] - oracle[i * channels + k]) / oracle[i * channels + k];
      f.interpolation_rms_pct += d * d / (skin_cells.size() * channels);
    }
  f.interpolation_rms_pct = std::sqrt(f.interpolation_rms_pct);
  const auto self_fit = best_fits(estimate(table, set, table_self, estimation::InverterMethod::kFast));
  f.table_self_fast = accuracy(truth, lab.truth, self_fit, skin).de_all;
  {
    std::vector<double> de(skin_cells.size()), far_chi2;
    std::vector<estimation::SkinParameters> fitted(skin_cells.size());
    for (std::size_t j = 0; j < skin_cells.size(); ++j) fitted[j] = self_fit[skin_cells[j]].parameters;
    const Relit relit = relight(fitted);
    for (std::size_t j = 0; j < skin_cells.size(); ++j) {
      for (std::size_t l = 0; l < relit.lab.size(); ++l)
        de[j] += spectral::delta_e94(truth.lab[l][skin_cells[j]], relit.lab[l][j]) / relit.lab.size();
      if (de[j] > 0.5) {
        far_chi2.push_back(self_fit[skin_cells[j]].chi2);
        const estimation::SkinParameters& t = lab.truth[skin_cells[j]];
        f.far_error.cm += std::log10(fitted[j].cm / t.cm), f.far_error.ch += std::log10(fitted[j].ch / t.ch);
        f.far_error.bm += fitted[j].bm - t.bm, f.far_error.che += fitted[j].che - t.che;
        const Eigen::VectorXd at_fit = weights * estimation::SkinModel().albedo(fitted[j]).values().matrix();
        for (int k = 0; k < channels; ++k) {
          const double d = 100.0 * (at_fit[k] - oracle[skin_cells[j] * channels + k]) / oracle[skin_cells[j] * channels + k];
          f.far_exact_difference_pct += d * d;
        }
      }
    }
    auto median = [](std::vector<double> v) {
      if (v.empty()) return 0.0;
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      return v[v.size() / 2];
    };
    f.table_self_far_share = skin_cells.empty() ? 0 : double(far_chi2.size()) / skin_cells.size();
    f.table_self_far_median_chi2 = median(far_chi2);
    if (!far_chi2.empty()) {
      for (double* e : {&f.far_error.cm, &f.far_error.ch, &f.far_error.bm, &f.far_error.che}) *e /= far_chi2.size();
      f.far_exact_difference_pct = std::sqrt(f.far_exact_difference_pct / (far_chi2.size() * channels));
    }
    f.table_self_median_de = median(de);
  }

  // The exhaustive search on a fixed subsample of skin cells (evenly spaced).
  const std::size_t n = std::min(exhaustive_cells, skin_cells.size());
  if (n > 0) {
    std::vector<float> sub(n * channels);
    std::vector<estimation::SkinParameters> sub_truth(n);
    std::vector<estimation::PixelEstimate> sub_fast(n);
    for (std::size_t j = 0; j < n; ++j) {
      const std::size_t i = skin_cells[j * skin_cells.size() / n];
      std::copy_n(lab.noise_free.measured.begin() + i * channels, channels, sub.begin() + j * channels);
      sub_truth[j] = lab.truth[i], sub_fast[j] = fast[i];
    }
    const std::vector<bool> all(n, true);
    const Relit sub_relit = relight(sub_truth);
    f.exhaustive_every =
        accuracy(sub_relit, sub_truth, best_fits(estimate(table, set, sub, estimation::InverterMethod::kExhaustive)), all)
            .de_all;
    f.fast_subsample_every = accuracy(sub_relit, sub_truth, best_fits(sub_fast), all).de_all;
  }
  return f;
}

std::string text(const Spread& s, const char* format = "%.3f [%.3f, %.3f]") {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, s.mean, s.lo, s.hi);
  return buffer;
}

int bench_main(int argc, char** argv) {
  CLI::App app{"what sets the virtual lab's accuracy floor: the method's plan, noise-free, imperfections off one at a time"};
  std::vector<std::uint64_t> seeds{11, 12, 13};
  std::vector<int> sensor{256, 192};
  std::size_t exhaustive_cells = 800;
  std::vector<int> fine_grid{81, 81, 41, 41};
  std::string out = "bench/results";
  app.add_option("--seeds", seeds, "held-out scene seeds")->delimiter(',');
  app.add_option("--sensor", sensor, "sensor W H (even)")->expected(2);
  app.add_option("--exhaustive-cells", exhaustive_cells, "skin cells (evenly spaced) for the exhaustive search");
  app.add_option("--fine-grid", fine_grid, "the finer forward table (Cm, Ch, betam, Che nodes) for the table's share; "
                 "empty: skip")->delimiter(',');
  app.add_option("--out", out, "output directory");
  CLI11_PARSE(app, argc, argv);
  if (seeds.empty()) throw std::invalid_argument("--seeds: at least one seed");

  std::printf("lab_floor_bench: the method's plan (standard session, one exposure), %dx%d sensor (2x2 binned cells), "
              "noise-free frames declared noise-free, 4D; held-out seeds",
              sensor[0], sensor[1]);
  for (std::uint64_t s : seeds) std::printf(" %llu", static_cast<unsigned long long>(s));
  std::printf("; mean [min, max] over the seeds\n");
  std::printf("equal by construction (not switched): LED library = the lab's true full-drive emission; camera "
              "sensitivity = the lab camera's; white target = the assumed flat 0.99; uniform illumination\n\n");

  const std::filesystem::path dir = out;
  std::filesystem::create_directories(dir);
  std::ofstream csv(dir / "lab_floor.csv");
  csv << "configuration,linear_led_light,cell_uniform_scene,scene_anomalies,seed,fast_explained,explained_share,"
         "fast_every,exhaustive_every_subsample,fast_every_subsample,oracle_fast_every,warped_captures,"
         "deviation_mean_pct,deviation_rms_pct\n";
  std::vector<Bar> bars;
  std::printf("%-20s %-24s %-8s %-24s %-24s %-24s %-24s %s\n", "configuration", "fast 4D, explained", "expl.",
              "fast 4D, every skin cell", "exhaustive (subsample)", "fast (same subsample)", "oracle: fast 4D",
              "warped");
  std::vector<std::vector<Figures>> all;
  for (const Configuration& c : kConfigurations) {
    std::vector<Figures> rows;
    for (std::uint64_t seed : seeds) {
      rows.push_back(run(c, seed, sensor[0], sensor[1], exhaustive_cells, estimation::TableGrid{}));
      const Figures& f = rows.back();
      csv << '"' << c.name << "\"," << c.linear_led_light << ',' << c.cell_uniform_scene << ',' << c.scene_anomalies
          << ',' << seed << ',' << f.fast_explained << ',' << f.explained_share << ',' << f.fast_every << ','
          << f.exhaustive_every << ',' << f.fast_subsample_every << ',' << f.oracle_fast << ',' << f.warped << ",\"";
      for (double d : f.deviation_mean_pct) csv << d << ' ';
      csv << "\",\"";
      for (double d : f.deviation_rms_pct) csv << d << ' ';
      csv << "\"\n";
    }
    int warped = 0;
    for (const Figures& f : rows) warped += f.warped;
    std::printf("%-20s %-24s %-8s %-24s %-24s %-24s %-24s %d\n", c.name.c_str(),
                text(spread(rows, [](const Figures& f) { return f.fast_explained; })).c_str(),
                text(spread(rows, [](const Figures& f) { return 100 * f.explained_share; }), "%.1f%%").c_str(),
                text(spread(rows, [](const Figures& f) { return f.fast_every; })).c_str(),
                text(spread(rows, [](const Figures& f) { return f.exhaustive_every; })).c_str(),
                text(spread(rows, [](const Figures& f) { return f.fast_subsample_every; })).c_str(),
                text(spread(rows, [](const Figures& f) { return f.oracle_fast; })).c_str(), warped);
    bars.push_back({c.name, spread(rows, [](const Figures& f) { return f.fast_every; }).mean});
    all.push_back(std::move(rows));
  }
  bars.push_back({"oracle (exact data)", spread(all[0], [](const Figures& f) { return f.oracle_fast; }).mean});
  bars.push_back({"table's own prediction", spread(all[0], [](const Figures& f) { return f.table_self_fast; }).mean});

  const std::vector<std::string>& channel_names = all.front().front().channel_names;
  std::printf("\nmeasurement - oracle on skin cells, %% of the oracle: signed mean [min, max over seeds] / RMS (mean)\n");
  std::printf("%-20s", "configuration");
  for (const std::string& name : channel_names) std::printf(" %-34s", name.c_str());
  std::printf("\n");
  for (std::size_t c = 0; c < kConfigurations.size(); ++c) {
    std::printf("%-20s", kConfigurations[c].name.c_str());
    for (std::size_t k = 0; k < channel_names.size(); ++k) {
      const std::string mean = text(spread(all[c], [k](const Figures& f) { return f.deviation_mean_pct[k]; }),
                                    "%+.2f [%+.2f, %+.2f]");
      const Spread rms = spread(all[c], [k](const Figures& f) { return f.deviation_rms_pct[k]; });
      char cell[64];
      std::snprintf(cell, sizeof cell, "%s / %.2f", mean.c_str(), rms.mean);
      std::printf(" %-34s", cell);
    }
    std::printf("\n");
  }

  std::printf("\nthe estimator on exact data (lab as is truths): oracle %s; the table's own prediction at the truth %s; "
              "the table's interpolation error at the truths (RMS over channels) %.3f%%\n",
              text(spread(all[0], [](const Figures& f) { return f.oracle_fast; })).c_str(),
              text(spread(all[0], [](const Figures& f) { return f.table_self_fast; })).c_str(),
              spread(all[0], [](const Figures& f) { return f.interpolation_rms_pct; }).mean);
  std::printf("  on the table's own prediction: median cell %s; cells > 0.5 off %s, their median chi2 %s\n",
              text(spread(all[0], [](const Figures& f) { return f.table_self_median_de; })).c_str(),
              text(spread(all[0], [](const Figures& f) { return 100 * f.table_self_far_share; }), "%.1f%% [%.1f, %.1f]").c_str(),
              text(spread(all[0], [](const Figures& f) { return f.table_self_far_median_chi2; }), "%.2g [%.2g, %.2g]").c_str());
  std::printf("  those cells' mean signed error: log10 Cm %s, log10 Ch %s, betam %s, Che %s\n",
              text(spread(all[0], [](const Figures& f) { return f.far_error.cm; }), "%+.3f [%+.3f, %+.3f]").c_str(),
              text(spread(all[0], [](const Figures& f) { return f.far_error.ch; }), "%+.3f [%+.3f, %+.3f]").c_str(),
              text(spread(all[0], [](const Figures& f) { return f.far_error.bm; }), "%+.3f [%+.3f, %+.3f]").c_str(),
              text(spread(all[0], [](const Figures& f) { return f.far_error.che; }), "%+.4f [%+.4f, %+.4f]").c_str());
  std::printf("  the exact model (no table) at those fits against at the truth: RMS %s%% of the channel\n",
              text(spread(all[0], [](const Figures& f) { return f.far_exact_difference_pct; })).c_str());
  std::printf("\neach imperfection's share of the floor (fast 4D, every skin cell, mean over seeds):\n");
  const double lab_as_is = bars[0].value, ideal = bars[4].value;
  for (std::size_t c = 1; c <= 3; ++c)
    std::printf("  %-20s off alone: %+.3f    alone on the ideal lab: %+.3f\n", kConfigurations[c].name.c_str(),
                bars[c].value - lab_as_is, bars[c + 4].value - ideal);
  std::printf("  all three off: %.3f of %.3f (the rest: table, inverter and the noise-free frames' 1/16 DN)\n", ideal,
              lab_as_is);
  if (fine_grid.size() == 4) {
    const estimation::TableGrid grid{fine_grid[0], fine_grid[1], fine_grid[2], fine_grid[3]};
    if (std::string error; !grid.IsValid(&error)) throw std::invalid_argument("--fine-grid: " + error);
    std::printf("\nthe forward table's share: fast 4D with a %dx%dx%dx%d table (default %dx%dx%dx%d), every skin cell\n",
                grid.cm_nodes, grid.ch_nodes, grid.bm_nodes, grid.che_nodes, estimation::TableGrid{}.cm_nodes,
                estimation::TableGrid{}.ch_nodes, estimation::TableGrid{}.bm_nodes, estimation::TableGrid{}.che_nodes);
    for (std::size_t c : {std::size_t{0}, std::size_t{4}}) {
      std::vector<Figures> rows;
      for (std::uint64_t seed : seeds) rows.push_back(run(kConfigurations[c], seed, sensor[0], sensor[1], 0, grid));
      const Spread lab = spread(rows, [](const Figures& f) { return f.fast_every; });
      const Spread oracle = spread(rows, [](const Figures& f) { return f.oracle_fast; });
      std::printf("  %-20s measurement %s   oracle %s   table's own prediction %s   interpolation RMS %.3f%%\n",
                  kConfigurations[c].name.c_str(), text(lab).c_str(), text(oracle).c_str(),
                  text(spread(rows, [](const Figures& f) { return f.table_self_fast; })).c_str(),
                  spread(rows, [](const Figures& f) { return f.interpolation_rms_pct; }).mean);
      for (std::size_t k = 0; k < rows.size(); ++k)
        csv << '"' << kConfigurations[c].name << ", fine table\"," << kConfigurations[c].linear_led_light << ','
            << kConfigurations[c].cell_uniform_scene << ',' << kConfigurations[c].scene_anomalies << ',' << seeds[k]
            << ',' << rows[k].fast_explained << ',' << rows[k].explained_share << ',' << rows[k].fast_every << ",,,"
            << rows[k].oracle_fast << ',' << rows[k].warped << ",,\n";
      bars.push_back({kConfigurations[c].name + ", fine table", lab.mean});
    }
  }
  write_bar_chart(dir / "lab_floor.png", "Lab floor: method plan, noise-free declared so, fast 4D, every skin cell",
                  "relit dE94 (six LEDs + D65)", bars);
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) { return chromo::bench::guarded_main("lab_floor_bench", chromo::bench::bench_main, argc, argv); }
