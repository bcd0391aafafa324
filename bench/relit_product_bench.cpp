// The relit layers measured through the product (issue 37): real-skin scenes
// of held-out NIST subjects (and scenes of model-rendered skin in the same
// layout) written by `chromo make-real-skin-scene`'s library, estimated by
// `chromo estimate MEASUREMENT.json`'s chain (registration, forward table from
// the disk cache, the estimator with the learned discrepancy and, optionally,
// the real-skin prior, the spatial pass with or without the multi-pixel
// estimate, the relit layer), written as maps.exr by the product's report
// writer, then relit from the stored maps.exr by the product's relight()
// under D65 and A, with and without the maps' discrepancy layer.
//
// Held out: folds by subject index (subject i in fold i mod 5); the
// discrepancy and the prior of a fold are learned from its 40 training
// subjects only (the product's standard ones are learned from all 50), the
// scene holds its 10 test subjects as patches (±3% texture, ink and marker).
// Model scenes: 10 patches of the model's own albedo (parameters drawn from
// the synthetic scenes' box, no texture), same camera, noise and fold's
// statistics. Scored: relit ΔE94 against the truth spectrum (× its texture
// scale), mean of D65 and A, over unflagged pixels at least 2 px inside their
// patch (skin_mask.png); skin flagged and ink / marker caught.
//
//   relit_product_bench [--seeds 1,2] [--folds 0,1,2,3,4] [--plans method,six-leds] [--patch 32]
//                       [--noise-scale 1] [--prior-widen 1] [--terms 6] [--out bench/results/relit_product]
//
// Writes DIR/relit_product.csv (one row per run) and DIR/relit_product.png
// (mean relit ΔE94 per configuration, layer off and on).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench_cli.hpp"
#include <Eigen/Cholesky>
#include <opencv2/imgcodecs.hpp>
#include <unistd.h>

#include "chart.hpp"
#include "clocks.hpp"
#include "guarded_main.hpp"
#include "seed_spread.hpp"
#include "chromo/estimation/discrepancy_calibration.hpp"
#include "chromo/estimation/parameter_prior.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/estimation/spectrum_fit.hpp"
#include "chromo/maps/estimate_report.hpp"
#include "chromo/maps/relight.hpp"
#include "chromo/session/measurement_file.hpp"
#include "chromo/simulators/scene/real_skin_scene.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/delta_e.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::bench {
namespace {

namespace fs = std::filesystem;
constexpr int kFolds = 5;

// What one configuration runs with.
struct Config {
  std::string plan, scene;  // "method" / "six-leds"; "real" / "model"
  bool prior = false, denoise = false, local_bias = false;
  std::string name() const {
    return plan + (prior ? "+prior" : "") + " " + scene + (denoise ? " denoise-on" : " denoise-off") +
           (local_bias ? " bias-on" : "");
  }
};

struct Score {
  double de[2] = {}, de_d65[2] = {}, de_a[2] = {};  // [layer off, on]: relit ΔE94 over the scored pixels
  double skin_flagged = 0, ink_caught = 0, marker_caught = 0, seconds = 0;
  double skin_pixel_flagged = 0, skin_neighbourhood_flagged = 0;  // skin flagged by the per-pixel pass (1-6) / by code 7
  double skin_006_flagged = -1, ink_006_caught = -1;                // on subject_006's patch when the scene holds it (else -1)
  std::size_t scored = 0, layer_pixels = 0;
};

// 3 × 81 weights giving XYZ of an albedo under the illuminant (relight()'s weights).
spectral::CameraWeights xyz_weights(const spectral::Spectrum& illuminant) {
  spectral::CameraWeights w;
  for (int k = 0; k < spectral::kGridSize; ++k) {
    spectral::Spectrum impulse;
    impulse[k] = 1.0;
    const spectral::Xyz x = spectral::xyz_of_reflectance(impulse, illuminant);
    w(0, k) = x.X, w(1, k) = x.Y, w(2, k) = x.Z;
  }
  return w;
}

// The stored maps relit by the product (relight() from read_parameter_maps) against the scene's truth.
Score score(const fs::path& maps_exr, const fs::path& scene, const std::vector<spectral::Spectrum>& spectra,
            int subject_006) {
  const maps::ParameterMaps stored = maps::read_parameter_maps(maps_exr);
  const files::FloatImage truth = files::read_exr(scene / "truth.exr");
  const cv::Mat mask = cv::imread((scene / "skin_mask.png").string(), cv::IMREAD_GRAYSCALE);
  const auto& index = truth.channel("spectrum");
  const auto& scale = truth.channel("scale");
  const auto& region = truth.channel("region");
  const std::size_t pixels = index.size();
  Score s;
  s.layer_pixels = stored.discrepancy ? stored.discrepancy->pixels : 0;
  std::size_t skin = 0, counts[3] = {}, flagged[3] = {}, skin6 = 0, skin6_flagged = 0, ink6 = 0, ink6_caught = 0;
  for (std::size_t i = 0; i < pixels; ++i) {
    const bool is_flagged = stored.flags[i] != 0.0f;
    const int r = static_cast<int>(region[i]);
    const bool on_006 = static_cast<int>(index[i]) == subject_006;
    if (r >= 0 && r < 3) ++counts[r], flagged[r] += is_flagged;
    if (r == 1 && on_006) ++ink6, ink6_caught += is_flagged;
    if (mask.data[i] == 0) continue;
    ++skin;
    s.skin_flagged += is_flagged;
    s.skin_neighbourhood_flagged += stored.flags[i] == static_cast<float>(estimation::PixelFlag::kNeighbourhood);
    if (on_006) ++skin6, skin6_flagged += is_flagged;
  }
  s.skin_pixel_flagged = skin ? (s.skin_flagged - s.skin_neighbourhood_flagged) / skin : 0;
  s.skin_neighbourhood_flagged = skin ? s.skin_neighbourhood_flagged / skin : 0;
  s.skin_flagged = skin ? s.skin_flagged / skin : 0;
  if (skin6) s.skin_006_flagged = double(skin6_flagged) / skin6;
  if (ink6) s.ink_006_caught = double(ink6_caught) / ink6;
  s.ink_caught = counts[1] ? double(flagged[1]) / counts[1] : 0;
  s.marker_caught = counts[2] ? double(flagged[2]) / counts[2] : 0;
  for (int layer = 0; layer < 2; ++layer) {
    maps::ParameterMaps m = stored;
    if (!layer) m.discrepancy.reset();
    for (int l = 0; l < 2; ++l) {
      const spectral::Spectrum& light = l == 0 ? spectral::illuminant_d65() : spectral::illuminant_a();
      const spectral::Xyz white = spectral::white_point(light);
      const maps::RelitImage relit = maps::relight(m, xyz_weights(light), 2);
      double sum = 0;
      std::size_t n = 0;
      for (std::size_t i = 0; i < pixels; ++i) {
        if (mask.data[i] == 0 || stored.flags[i] != 0.0f || !relit.valid[i]) continue;
        const spectral::Spectrum t(spectra[static_cast<std::size_t>(index[i])].values() * scale[i]);
        const spectral::Xyz x{relit.rgb[3 * i], relit.rgb[3 * i + 1], relit.rgb[3 * i + 2]};
        sum += spectral::delta_e94(spectral::lab_from_xyz(spectral::xyz_of_reflectance(t, light), white),
                                   spectral::lab_from_xyz(x, white));
        ++n;
      }
      (l == 0 ? s.de_d65 : s.de_a)[layer] = n ? sum / n : 0;
      s.scored = n;
    }
    s.de[layer] = 0.5 * (s.de_d65[layer] + s.de_a[layer]);
  }
  return s;
}

// `chromo estimate MEASUREMENT.json`'s chain (cli/estimate_command.cpp) with the fold's statistics, maps.exr into `out`.
// What the per-subject diagnostic needs from one estimate.
struct EstimateRun {
  std::vector<estimation::PixelEstimate> estimates;
  double threshold[5] = {};  // flag threshold by free parameters (2, 4)
  Eigen::MatrixXd discrepancy_channels;  // Σ_disc in the plan's channels
  Eigen::MatrixXd weights;               // the plan's camera weights W (C × 81)
  std::vector<session::RegistrationReport> registration;
  estimation::DiscrepancyCalibration calibration;
};

EstimateRun estimate_scene(const fs::path& scene, const fs::path& out, const fs::path& cache,
                    std::shared_ptr<const estimation::ModelDiscrepancy> discrepancy,
                    std::shared_ptr<const estimation::ParameterPrior> prior, bool denoise, int terms,
                    const estimation::LocalBiasOptions& local_bias, const std::string& registration_mode,
                           double calibration_quantile) {
  session::MeasurementFile m = session::read_measurement_file(scene / "MEASUREMENT.json");
  std::vector<session::RegistrationReport> registration;
  if (registration_mode != "none") {
    session::RegistrationOptions ro;
    ro.exclude_photometric_outliers = registration_mode == "robust";
    registration = session::register_images(m, ro);
  }
  const estimation::MeasurementSet set = m.measurement_set();
  const std::vector<float> measured = m.pixel_major();
  const auto table = estimation::ForwardTable::load_or_build(set, {}, cache, nullptr, 2);
  estimation::EstimatorOptions eo = maps::default_estimator_options();
  eo.threads = 2;
  eo.discrepancy = std::move(discrepancy);
  eo.prior = std::move(prior);
  eo.cache_dir = cache.string();
  eo.order_rule = estimation::EstimatorOptions::OrderRule::kLikelihoodRatio;  // pooled order, as the CLI
  estimation::DiscrepancyCalibration calibration;
  if (eo.discrepancy) {
    estimation::DiscrepancyCalibrationOptions co;
    if (calibration_quantile > 0) co.quantile = calibration_quantile;
    calibration = estimation::calibrate_discrepancy_scale(*eo.discrepancy, set.weights(), co);
  }
  const estimation::Estimator unscaled(table, set, eo);
  const estimation::Estimator estimator =
      calibration_quantile > 0 ? unscaled.with_discrepancy_scale(calibration.scale) : unscaled;
  std::vector<estimation::PixelEstimate> estimates(static_cast<std::size_t>(m.width) * m.height);
  estimation::EstimateSummary summary = estimator.estimate(measured, estimates);
  estimation::NeighbourhoodOptions neighbourhood;
  neighbourhood.local_bias = local_bias;
  const std::optional<estimation::SkinDenoiseOptions> skin_denoise =
      denoise ? std::optional(estimation::SkinDenoiseOptions{}) : std::nullopt;
  const estimation::SpatialPass pass =
      estimation::spatial_pass(estimator, measured, m.width, m.height, estimates, summary, neighbourhood, skin_denoise);
  const std::optional<maps::DiscrepancyLayer> layer = maps::estimate_discrepancy_layer(
      estimator, measured, estimates, pass.skin_refit ? &*pass.skin_refit : nullptr, terms);
  maps::EstimateReport report;
  report.method = std::string(estimator.inverter().name());
  report.model = "auto";
  report.width = m.width, report.height = m.height;
  for (const auto& c : set.channels) report.channel_names.push_back(c.name);
  report.estimates = estimates;
  report.summary = summary;
  report.discrepancy_layer = layer ? &*layer : nullptr;
  fs::create_directories(out);
  maps::write_estimate_report(out, report, [](const fs::path& path, const std::function<void(const fs::path&)>& produce) {
    produce(path);
  }, 1);
  EstimateRun run{estimates, {}, {}, set.weights(), registration};
  run.threshold[2] = estimator.flag_threshold(2), run.threshold[4] = estimator.flag_threshold(4);
  if (eo.discrepancy) run.discrepancy_channels = eo.discrepancy->channel_covariance(set);
  run.calibration = calibration;
  return run;
}

// Per held-out subject: the share of its patch's skin flagged per pixel (1-6) and by code 7, the median χ² over its
// flag threshold, and D² = rᵀ Σ_disc⁻¹ r of its noise-free residual (r = W·(spectrum − its 4D fit)) under the fold's
// discrepancy, against χ²(C − 4)'s 0.999 quantile.
void print_subjects(const EstimateRun& run, const fs::path& scene, const std::vector<estimation::NamedSpectrum>& spectra) {
  const files::FloatImage truth = files::read_exr(scene / "truth.exr");
  const cv::Mat mask = cv::imread((scene / "skin_mask.png").string(), cv::IMREAD_GRAYSCALE);
  const auto& index = truth.channel("spectrum");
  const auto& residuals = estimation::nist_forearm_residuals();
  if (run.calibration.held_out_d2.size())
    std::printf("    nested CV: held-out D2 quantile %.1f vs chi2(C) quantile %.1f -> scale %.2f; max %.1f, median %.1f\n",
                run.calibration.held_out_quantile, run.calibration.expected_quantile, run.calibration.scale,
                *std::max_element(run.calibration.held_out_d2.begin(), run.calibration.held_out_d2.end()),
                [&] { auto v = run.calibration.held_out_d2; std::sort(v.begin(), v.end()); return v[v.size() / 2]; }());
  for (const auto& r : run.registration)
    std::printf("    registration %s -> %s: motion %.3f px (noise %.3f px), %s\n", r.image.c_str(), r.reference.c_str(),
                r.motion_px, r.result.motion_noise_px, r.warped ? "WARPED" : "identity");
  for (std::size_t j = 0; j < spectra.size(); ++j) {
    std::vector<double> ratio;
    std::size_t n = 0, per_pixel = 0, code7 = 0;
    for (std::size_t i = 0; i < index.size(); ++i) {
      if (mask.data[i] == 0 || static_cast<std::size_t>(index[i]) != j) continue;
      const auto& e = run.estimates[i];
      ++n;
      const int flag = static_cast<int>(e.flag);
      per_pixel += flag >= 1 && flag <= 6;
      code7 += e.flag == estimation::PixelFlag::kNeighbourhood;
      if (e.order) ratio.push_back(e.chi2 / run.threshold[e.order == 2 ? 2 : 4]);
    }
    std::sort(ratio.begin(), ratio.end());
    double d2 = -1;
    for (const auto& r : residuals)
      if (r.name == spectra[j].name && run.discrepancy_channels.size() > 0) {
        const Eigen::VectorXd rc = run.weights * r.residual.values().matrix();
        d2 = rc.dot(run.discrepancy_channels.ldlt().solve(rc));
      }
    std::printf("    %-12s per pixel %5.1f%% code 7 %5.1f%%, median chi2/threshold %.2f, D2 %.1f (threshold %.1f)\n",
                spectra[j].name.c_str(), n ? 100.0 * per_pixel / n : 0, n ? 100.0 * code7 / n : 0,
                ratio.empty() ? 0 : ratio[ratio.size() / 2], d2, run.threshold[4]);
  }
}

// The fold's training statistics: the discrepancy and the prior (widened) from its 40 training subjects.
struct FoldStatistics {
  std::shared_ptr<const estimation::ModelDiscrepancy> discrepancy;
  std::shared_ptr<const estimation::ParameterPrior> prior;
  std::vector<estimation::NamedSpectrum> test;
};
FoldStatistics fold_statistics(int fold, const std::vector<estimation::SkinParameters>& fits, double widen) {
  const auto& spectra = estimation::nist_forearm_spectra();
  const auto& residuals = estimation::nist_forearm_residuals();
  std::vector<estimation::SpectrumResidual> train;
  std::vector<estimation::SkinParameters> train_fits;
  FoldStatistics out;
  for (std::size_t i = 0; i < spectra.size(); ++i) {
    if (static_cast<int>(i % kFolds) == fold) {
      out.test.push_back(spectra[i]);
    } else {
      train.push_back(residuals[i]);
      train_fits.push_back(fits[i]);
    }
  }
  out.discrepancy = std::make_shared<const estimation::ModelDiscrepancy>(estimation::ModelDiscrepancy::learn(train));
  out.prior = std::make_shared<const estimation::ParameterPrior>(estimation::ParameterPrior::learn(train_fits, widen));
  return out;
}

// Ten patches of the model's own albedo, parameters drawn from the synthetic scenes' box.
std::vector<estimation::NamedSpectrum> model_spectra(std::uint64_t seed) {
  static const estimation::SkinModel model;
  const simulators::SyntheticOptions box;
  std::vector<estimation::NamedSpectrum> out;
  for (const auto& p : simulators::random_skin_parameters(10, box.low, box.high, seed))
    out.push_back({"model", model.albedo(p)});
  return out;
}

struct Row {
  Config config;
  int fold;
  std::uint64_t seed;
  Score s;
};

void print_spread(const std::vector<Row>& rows, const std::vector<Config>& configs, std::vector<Bar>& bars,
                  std::vector<LineSeries>& flags_chart) {
  std::printf("\nspread over folds x seeds, mean [min, max] (load average now %.2f):\n", load_average());
  std::printf("%-44s %-22s %-22s %-22s %-14s %-14s %-20s %-20s %-10s %-10s\n", "configuration", "relit dE94 model",
              "model + discrepancy", "skin flagged %", "per-pixel %", "code 7 %", "ink %", "marker %", "006 skin %",
              "006 ink %");
  for (const Config& c : configs) {
    std::vector<Row> of;
    for (const Row& r : rows)
      if (r.config.name() == c.name()) of.push_back(r);
    if (of.empty()) continue;
    const Spread off = spread(of, [](const Row& r) { return r.s.de[0]; });
    const Spread on = spread(of, [](const Row& r) { return r.s.de[1]; });
    const Spread fl = spread(of, [](const Row& r) { return 100 * r.s.skin_flagged; });
    const Spread px = spread(of, [](const Row& r) { return 100 * r.s.skin_pixel_flagged; });
    const Spread nb = spread(of, [](const Row& r) { return 100 * r.s.skin_neighbourhood_flagged; });
    const Spread ink = spread(of, [](const Row& r) { return 100 * r.s.ink_caught; });
    const Spread marker = spread(of, [](const Row& r) { return 100 * r.s.marker_caught; });
    std::vector<Row> with_006;
    for (const Row& r : of)
      if (r.s.skin_006_flagged >= 0) with_006.push_back(r);
    Spread s6{-1, -1, -1}, i6{-1, -1, -1};
    if (!with_006.empty()) {
      s6 = spread(with_006, [](const Row& r) { return 100 * r.s.skin_006_flagged; });
      i6 = spread(with_006, [](const Row& r) { return 100 * std::max(r.s.ink_006_caught, 0.0); });
    }
    std::printf("%-44s %.3f [%.3f, %.3f]   %.3f [%.3f, %.3f]   %.2f [%.2f, %.2f]   %.2f [%.2f]   %.2f [%.2f]   "
                "%.1f [%.1f, %.1f]   %.1f [%.1f, %.1f]   %-10.1f %-10.1f\n",
                c.name().c_str(), off.mean, off.lo, off.hi, on.mean, on.lo, on.hi, fl.mean, fl.lo, fl.hi, px.mean, px.hi,
                nb.mean, nb.hi, ink.mean, ink.lo, ink.hi, marker.mean, marker.lo, marker.hi, s6.mean, i6.mean);
    bars.push_back({c.name() + " model", off.mean});
    bars.push_back({c.name() + " +disc", on.mean});
    Config base = c;
    base.local_bias = false;
    const std::string series = base.name();
    auto it = std::find_if(flags_chart.begin(), flags_chart.end(), [&](const LineSeries& l) { return l.title == series; });
    if (it == flags_chart.end()) it = flags_chart.insert(flags_chart.end(), LineSeries{series, {}});
    it->points.push_back({fl.mean, std::min(ink.mean, marker.mean)});
  }
}

int run(int argc, char** argv) {
  CLI::App app{"the relit layers through the product's estimate chain and relight, held-out real skin and model skin"};
  std::vector<std::uint64_t> seeds{1, 2};
  std::vector<int> folds{0, 1, 2, 3, 4};
  std::vector<std::string> plans{"method", "six-leds"};
  int patch = 32, terms = maps::kDiscrepancyLayerTerms;
  double noise_scale = 1, widen = 1;
  fs::path out = "bench/results/relit_product";
  std::vector<std::string> denoise_runs{"on"}, bias_runs{"off"};  // the product's defaults
  bool priors = true, per_subject = false;
  std::string registration_mode = "default";
  double calibration_quantile = 0;
  bool anomalies = true;
  estimation::LocalBiasOptions bias;
  bias.enabled = true;
  app.add_option("--seeds", seeds, "scene seeds")->delimiter(',');
  app.add_option("--folds", folds, "folds (0-4) to run")->delimiter(',')->check(CLI::Range(0, kFolds - 1));
  app.add_option("--plans", plans, "method and/or six-leds")->delimiter(',');
  app.add_option("--patch", patch, "patch side per subject (px)")->check(CLI::Range(8, 512));
  app.add_option("--noise-scale", noise_scale, "camera noise x four frames of a 40,000 e- sensor")->check(CLI::Range(0.0, 16.0));
  app.add_option("--prior-widen", widen, "the real-skin prior's widening (the product's --prior real-skin: 1)")
      ->check(CLI::Range(1.0, 10.0));
  app.add_option("--terms", terms, "the relit layer's basis size")->check(CLI::Range(1, 81));
  app.add_option("--out", out, "results folder");
  app.add_option("--denoise", denoise_runs, "the multi-pixel estimate: off and/or on (default on, as chromod and chromo estimate)")->delimiter(',');
  app.add_option("--local-bias", bias_runs, "the local-bias flag rule (local_bias.hpp): off and/or on")->delimiter(',');
  app.add_option("--priors", priors, "also the method's plan with the real-skin prior (1) or not (0)");
  app.add_option("--bias-window", bias.window_px, "local bias: the reference's window (px)");
  app.add_option("--bias-tile", bias.tile_px, "local bias: tile (px)");
  app.add_option("--bias-cap", bias.max_bias_factor, "local bias: cap, x the flag threshold");
  app.add_flag("--per-subject", per_subject, "print each held-out subject's flags, chi2 and discrepancy D2");
  app.add_option("--registration", registration_mode, "default, robust (exclude_photometric_outliers) or none")
      ->check(CLI::IsMember({"default", "robust", "none"}));
  app.add_option("--calibration-quantile", calibration_quantile,
                 "scale the fold's discrepancy by its nested-CV calibration at this quantile (0: off)")
      ->check(CLI::Range(0.0, 0.999));
  app.add_option("--anomalies", anomalies, "the scenes' ink disc and marker stroke (1) or plain skin (0)");
  CLI11_PARSE(app, argc, argv);

  std::printf("relit_product_bench: patch %d px, noise x%g, prior widen %g, %d terms, local bias window %d px tile %d px "
              "cap %g, registration %s, discrepancy calibration quantile %g (0: off), load average %.2f\n", patch, noise_scale,
              widen, terms, bias.window_px, bias.tile_px, bias.max_bias_factor, registration_mode.c_str(), calibration_quantile,
              load_average());
  const auto& all = estimation::nist_forearm_spectra();
  std::vector<estimation::SkinParameters> fits(all.size());
#pragma omp parallel for schedule(dynamic)
  for (std::size_t i = 0; i < all.size(); ++i) fits[i] = estimation::fit_spectrum(all[i].albedo).parameters;
  std::vector<Config> configs;
  for (const std::string& plan : plans)
    for (const char* scene : {"real", "model"})
      for (const bool prior : plan == "method" && priors ? std::vector<bool>{false, true} : std::vector<bool>{false})
        for (const std::string& denoise : denoise_runs)
          for (const std::string& b : bias_runs) configs.push_back({plan, scene, prior, denoise == "on", b == "on"});
  const fs::path scratch = fs::temp_directory_path() / ("relit_product_bench-" + std::to_string(::getpid()));
  const fs::path cache = estimation::ForwardTable::default_cache_dir();
  fs::create_directories(out);
  std::ofstream csv(out / "relit_product.csv");
  csv << "plan,scene,prior,denoise,local_bias,fold,seed,relit_model,relit_model_disc,d65_model,d65_disc,a_model,a_disc,skin_flagged,"
         "skin_pixel_flagged,skin_neighbourhood_flagged,skin_006_flagged,ink_006_caught,ink_caught,marker_caught,scored_pixels,layer_pixels,seconds,load_average\n";
  std::vector<Row> rows;
  for (const int fold : folds) {
    const FoldStatistics stats = fold_statistics(fold, fits, widen);
    for (const std::uint64_t seed : seeds)
      for (const Config& c : configs) {
        simulators::RealSkinSceneOptions o;
        o.spectra = c.scene == "real" ? stats.test : model_spectra(seed * 100 + static_cast<std::uint64_t>(fold));
        o.texture_relative = c.scene == "real" ? 0.03 : 0.0;
        o.patch_px = patch, o.plan = c.plan, o.noise_scale = noise_scale, o.seed = seed * 100 + static_cast<std::uint64_t>(fold);
        o.threads = 2;
        o.anomalies = anomalies;
        const fs::path scene = scratch / "scene", maps_dir = scratch / "maps";
        fs::remove_all(scratch);
        simulators::write_real_skin_scene(scene, o);
        const auto start = std::chrono::steady_clock::now();
        estimation::LocalBiasOptions run_bias = bias;
        run_bias.enabled = c.local_bias;
        const EstimateRun est = estimate_scene(scene, maps_dir, cache, stats.discrepancy, c.prior ? stats.prior : nullptr,
                                               c.denoise, terms, run_bias, registration_mode,
                                               calibration_quantile);
        std::vector<spectral::Spectrum> truth;
        int subject_006 = -1;
        for (const auto& n : o.spectra) {
          if (c.scene == "real" && n.name.find("006") != std::string::npos) subject_006 = static_cast<int>(truth.size());
          truth.push_back(n.albedo);
        }
        Row row{c, fold, seed, score(maps_dir / "maps.exr", scene, truth, subject_006)};
        row.s.seconds = seconds_since(start);
        std::printf("%-36s fold %d seed %llu: relit %.3f -> %.3f (D65 %.3f -> %.3f, A %.3f -> %.3f), skin flagged %.2f%%, "
                    "(per pixel %.2f%%, code 7 %.2f%%), ink %.1f%%, marker %.1f%%, 006 skin %.1f%% ink %.1f%%, %zu px scored, %.1f s\n",
                    c.name().c_str(), fold, static_cast<unsigned long long>(seed), row.s.de[0], row.s.de[1],
                    row.s.de_d65[0], row.s.de_d65[1], row.s.de_a[0], row.s.de_a[1], 100 * row.s.skin_flagged,
                    100 * row.s.skin_pixel_flagged, 100 * row.s.skin_neighbourhood_flagged, 100 * row.s.ink_caught, 100 * row.s.marker_caught,
                    100 * row.s.skin_006_flagged, 100 * row.s.ink_006_caught, row.s.scored, row.s.seconds);
        if (per_subject && c.scene == "real") print_subjects(est, scene, o.spectra);
        std::fflush(stdout);
        csv << c.plan << "," << c.scene << "," << c.prior << "," << c.denoise << "," << c.local_bias << "," << fold << "," << seed << ","
            << row.s.de[0] << "," << row.s.de[1] << "," << row.s.de_d65[0] << "," << row.s.de_d65[1] << ","
            << row.s.de_a[0] << "," << row.s.de_a[1] << "," << row.s.skin_flagged << "," << row.s.skin_pixel_flagged << ","
            << row.s.skin_neighbourhood_flagged << "," << row.s.skin_006_flagged << "," << row.s.ink_006_caught << ","
            << row.s.ink_caught << ","
            << row.s.marker_caught << "," << row.s.scored << "," << row.s.layer_pixels << "," << row.s.seconds << ","
            << load_average() << std::endl;
        rows.push_back(row);
      }
  }
  fs::remove_all(scratch);
  std::vector<Bar> bars;
  std::vector<LineSeries> flags_chart;
  print_spread(rows, configs, bars, flags_chart);
  write_line_chart(out / "relit_product_flags.png", "skin flagged vs ink/marker caught (the lower), local bias off -> on",
                   "real or model skin flagged, %", "ink / marker caught (the lower), %", flags_chart);
  write_bar_chart(out / "relit_product.png", "relit dE94 (mean of D65, A) through the product: model vs model + discrepancy",
                  "relit dE94, unflagged patch-interior pixels", bars);
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) { return chromo::bench::guarded_main("relit_product_bench", chromo::bench::run, argc, argv); }
