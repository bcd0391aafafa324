// The estimator on real skin (issue 37): scenes whose skin is measured
// spectra (the NIST forearms, held out by subject), side by side with
// scenes rendered by the model itself, under today's statistic (camera noise
// and the table's model error) and the learned discrepancy
// (estimation/model_discrepancy.hpp), for the method's plan and the six LED
// types one at a time.
//
// Folds: the 50 subjects in 5 folds by index (subject i in fold i mod 5).
// For each fold the discrepancy is learned from the other 40 subjects'
// residuals only, and the scene's skin is the fold's 10 held-out spectra,
// each a patch of --patch pixels with a ±3% texture; ink (tattoo), marker,
// vein and highlights on top (4%, 4%, 2%, 2% of the pixels). Camera: four
// frames of a 40,000 e⁻ sensor (160,000 e⁻ at full scale, 12 e⁻ read),
// each capture exposed to put its brightest white channel at full scale
// (simulators::set_exposure_noise), times --noise-scales. The "model" scenes
// draw skin from the model's parameter box with the same anomalies, camera
// and folds' discrepancies.
//
// Per plan, scene, noise scale, seed, fold and statistic: skin flagged,
// tattoo / marker / vein caught; relit ΔE94 of the unflagged skin under D65
// and A (against the pixel's own spectrum; the model scene against its
// truth); the share of order 4; σ coverage: the share of unflagged skin
// pixels whose parameters fall within 2σ of the reference (real skin: the
// 4D full-spectrum fit of the same spectrum at the pixel's texture scale;
// model skin: the truth) and the median |error|/σ, per parameter. Printed per
// run and as the spread (mean [min, max]) over folds × seeds.
//
// Where the relit error comes from: per row also the relit ΔE94 under D65
// and A apart, over every skin pixel (flagged ones too, their fit as it
// stands), and the 4D full-spectrum fit's own relit ΔE94 on the same
// unflagged pixels (the floor no parameter estimate can beat).
//
//   real_skin_bench [--seeds 1,2] [--noise-scales 0.5,1,2,4] [--patch 200] [--prior-widen 1,2]
//                   [--prior-max-channels 4] [--plans method,six-leds] [--out DIR]
//
// Writes DIR/real_skin.csv, DIR/real_skin.png (flagged real skin against
// the noise scale, per plan and statistic), DIR/real_skin_relit.png
// (relit ΔE94 against the noise scale: real skin per statistic, model skin,
// the floor) and DIR/real_skin_relit_layers.png (real skin relit by the
// model, + the posterior discrepancy, + the multi-pixel estimate).
//
// The relit layers past the model (docs/estimation.md "Relighting past the
// model"): per row also the same unflagged pixels relit as model + the
// posterior discrepancy (discrepancy_posterior.hpp; zero-mean prior, and
// the μ_d prior), and after the multi-pixel estimate (skin_denoise.hpp on
// the explained pixels, the frame read as rows of --patch pixels, then the
// estimator again; flags stay the first pass's), with the texture kept
// (the slope of relit Y on true Y within each patch).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench_cli.hpp"

#include "chart.hpp"
#include "chromo/estimation/discrepancy_posterior.hpp"
#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/estimation/parameter_prior.hpp"
#include "chromo/estimation/skin_denoise.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/estimation/spectrum_fit.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/colorimetry.hpp"
#include "chromo/spectral/delta_e.hpp"
#include "chromo/spectral/lab_illuminants.hpp"
#include "guarded_main.hpp"
#include "frame_scale.hpp"
#include "real_skin_camera.hpp"

namespace chromo::bench {
namespace {

using simulators::SyntheticKind;
constexpr int kFolds = 5;
// today: camera noise only; learned: + the discrepancy of the fold's training
// subjects; "subj-s": learned, scaled per held-out subject's frame by the
// frame statistic (estimation/discrepancy_scale.hpp, frame_scale.hpp);
// "frame-s": the same statistic over the whole scene (the old one-frame
// layout); "disc xS": learned × S on every pixel, one per --forced-scales;
// "prior xW": + the parameter prior learned from their 4D fits, widened W×
// (parameter_prior.hpp), one per --prior-widen.
std::vector<std::string> statistics(const std::vector<double>& widen, const std::vector<double>& forced) {
  std::vector<std::string> out{"today", "learned", "subj-s", "frame-s"};
  char name[32];
  for (double f : forced) std::snprintf(name, sizeof name, "disc x%g", f), out.push_back(name);
  for (double w : widen) std::snprintf(name, sizeof name, "prior x%g", w), out.push_back(name);
  return out;
}

std::vector<RealSkinPlan> plans() {
  const spectral::CameraSensitivity camera = spectral::builtin_camera("nikon_d5100");
  std::vector<RealSkinPlan> out{{"method", estimation::method_measurement_set(camera, spectral::led_d65_metamer(),
                                                                     spectral::led_spectrum(spectral::LedType::kBlue)),
                         nullptr},
                        {"six-leds", six_led_measurement_set(camera), nullptr}};
  for (RealSkinPlan& p : out) p.table = default_table(p.set);
  return out;
}

// The 4D full-spectrum fit of a spectrum at texture scales 0.97, 1, 1.03, interpolated in the scale.
struct Reference {
  std::array<estimation::SkinParameters, 3> at;
  estimation::SkinParameters operator()(double scale) const {
    const double t = std::clamp((scale - 0.97) / 0.03, 0.0, 2.0);
    const int k = std::min(static_cast<int>(t), 1);
    const double f = t - k;
    const auto& a = at[k];
    const auto& b = at[k + 1];
    return {a.cm + f * (b.cm - a.cm), a.ch + f * (b.ch - a.ch), a.bm + f * (b.bm - a.bm), a.che + f * (b.che - a.che)};
  }
};

spectral::Lab lab_under(const spectral::Spectrum& albedo, const spectral::Spectrum& light) {
  return spectral::lab_from_xyz(spectral::xyz_of_reflectance(albedo, light), spectral::white_point(light));
}

// ΔE94 between two albedos relit under D65 and under A, the mean of the two.
double mean_relit_de94(const spectral::Spectrum& truth, const spectral::Spectrum& fitted) {
  return 0.5 * (spectral::delta_e94(lab_under(truth, spectral::illuminant_d65()), lab_under(fitted, spectral::illuminant_d65())) +
                spectral::delta_e94(lab_under(truth, spectral::illuminant_a()), lab_under(fitted, spectral::illuminant_a())));
}

struct Run {
  double flagged[simulators::kSyntheticKindCount] = {};
  double de_d65 = 0, de_a = 0, order4 = 0;
  double floor_d65 = 0, floor_a = 0;  // real skin: the 4D full-spectrum fit's own relit ΔE94 on the same pixels
  double de_d65_disc = 0, de_a_disc = 0;  // the same pixels relit as model + posterior discrepancy (discrepancy_posterior.hpp, zero-mean prior)
  double de_d65_disc_mean = 0, de_a_disc_mean = 0;  // the same with the prior μ_d, Σ_d
  // The same pixels after the multi-pixel estimate (skin_denoise.hpp, then the estimator again): model, and model + discrepancy.
  double de_d65_dn = 0, de_a_dn = 0, de_d65_dn_disc = 0, de_a_dn_disc = 0;
  double joined = 0;  // mean pixels averaged per denoised pixel
  // Real skin: the texture kept, the slope of relit Y (D65) on the truth's Y within each held-out patch, mean over patches.
  double texture_slope = 0, texture_slope_dn_disc = 0;
  double de_all = 0;  // relit ΔE94 (mean of D65 and A) over every skin pixel, flagged ones too (their fit as it stands)
  double within_2sigma[4] = {}, median_ratio[4] = {};
  double within_2sigma_log_ch = 0;  // |ln(Ch/Ch_ref)| ≤ 2σ_Ch/Ch: the same σ read as relative (log) spread
  std::size_t explained_skin = 0;
  std::vector<double> flagged_per_spectrum;  // real skin: each held-out spectrum's flagged share
  std::vector<double> scales, weights;       // each part's frame scale and its own term's weight (frame_scale.hpp)
};

Run evaluate(const RealSkinPlan& plan, const simulators::SyntheticFrame& frame, const std::vector<float>& measured,
             const std::vector<spectral::Spectrum>& spectra, const std::vector<Reference>& references,
             std::shared_ptr<const estimation::ModelDiscrepancy> discrepancy,
             std::shared_ptr<const estimation::ParameterPrior> prior, int prior_max_channels,
             const estimation::DiscrepancyPosterior& posterior, const estimation::DiscrepancyPosterior& posterior_mean,
             int width, const estimation::SkinDenoiseOptions& denoise_options, const FrameScaleMode& scale_mode) {
  estimation::EstimatorOptions options;
  options.threads = 2;
  options.tile_pixels = 256;  // both threads on one subject's patch too
  options.prior_max_channels = prior_max_channels;
  options.discrepancy = std::move(discrepancy);
  options.prior = std::move(prior);
  const estimation::Estimator estimator(plan.table, plan.set, options);
  const std::vector<ScaledPart> parts = scaled_parts(estimator, measured, scale_mode, static_cast<std::size_t>(width));
  std::vector<estimation::PixelEstimate> e(frame.pixels());
  estimate_parts(parts, measured, e);
  std::vector<std::uint8_t> skin_like(frame.pixels());
  for (std::size_t i = 0; i < frame.pixels(); ++i) skin_like[i] = e[i].flag == estimation::PixelFlag::kExplained;
  const int height = static_cast<int>(frame.pixels() / width);
  const estimation::DenoisedChannels denoised =
      estimation::denoise_skin_channels(measured, width, height, plan.set, skin_like, denoise_options);
  std::vector<estimation::PixelEstimate> e_dn(frame.pixels());
  estimate_parts(parts, denoised.values, e_dn);
  static const estimation::SkinModel model;
  const Eigen::MatrixXd weights = plan.set.weights();
  // The posterior discrepancy of pixel i fitted as `fitted` from channel values `values`, whose
  // camera noise is the set's divided by `averaged` (pixels averaged into them).
  auto posterior_with = [&](const estimation::DiscrepancyPosterior& posterior, const spectral::Spectrum& fitted,
                            std::span<const float> values, std::size_t i, int averaged) {
    const int channels = plan.set.size();
    std::vector<double> residual(channels), variance(channels);
    const Eigen::VectorXd predicted = weights * fitted.values().matrix();
    for (int c = 0; c < channels; ++c) {
      const double measured_c = values[i * channels + c];
      residual[c] = measured_c - predicted(c);
      variance[c] = plan.set.channels[c].noise.variance(measured_c) / averaged +
                    std::pow(options.model_sigma_relative * std::max(measured_c, 0.0), 2);
    }
    return posterior.mean(residual, variance);
  };
  auto posterior_of = [&](const spectral::Spectrum& fitted, std::span<const float> values, std::size_t i, int averaged) {
    return posterior_with(posterior, fitted, values, i, averaged);
  };
  std::vector<std::array<double, 7>> texture(spectra.size(), std::array<double, 7>{});  // n, Σy, Σy², Σŷ, Σyŷ (model), Σŷ, Σyŷ (denoised + discrepancy)
  const bool real = !frame.spectrum_index.empty();
  std::size_t count[simulators::kSyntheticKindCount] = {}, flagged[simulators::kSyntheticKindCount] = {};
  Run r;
  for (const ScaledPart& p : parts) r.scales.push_back(p.scale), r.weights.push_back(p.weight);
  std::vector<double> ratios[4];
  std::size_t within[4] = {}, within_log_ch = 0, order4 = 0, skin_fitted = 0;
  std::vector<std::size_t> per_count(spectra.size()), per_flagged(spectra.size());
  for (std::size_t i = 0; i < frame.pixels(); ++i) {
    const int k = static_cast<int>(frame.kind[i]);
    ++count[k];
    const bool is_flagged = e[i].flag != estimation::PixelFlag::kExplained;
    if (real && frame.kind[i] == SyntheticKind::kSkin)
      ++per_count[frame.spectrum_index[i]], per_flagged[frame.spectrum_index[i]] += is_flagged;
    if (frame.kind[i] == SyntheticKind::kSkin && std::isfinite(e[i].parameters.cm) && std::isfinite(e[i].parameters.ch)) {
      const spectral::Spectrum truth = real ? spectral::Spectrum(spectra[frame.spectrum_index[i]].values() * frame.skin_scale[i])
                                            : model.albedo(frame.truth[i]);
      r.de_all += mean_relit_de94(truth, model.albedo(e[i].parameters));
      ++skin_fitted;
    }
    if (is_flagged) {
      ++flagged[k];
      continue;
    }
    if (frame.kind[i] != SyntheticKind::kSkin) continue;
    ++r.explained_skin;
    order4 += e[i].order == 4;
    const spectral::Spectrum truth = real ? spectral::Spectrum(spectra[frame.spectrum_index[i]].values() * frame.skin_scale[i])
                                          : model.albedo(frame.truth[i]);
    const spectral::Spectrum fitted = model.albedo(e[i].parameters);
    const spectral::Spectrum relit = fitted + posterior_of(fitted, measured, i, 1);
    r.de_d65_disc += spectral::delta_e94(lab_under(truth, spectral::illuminant_d65()), lab_under(relit, spectral::illuminant_d65()));
    r.de_a_disc += spectral::delta_e94(lab_under(truth, spectral::illuminant_a()), lab_under(relit, spectral::illuminant_a()));
    const spectral::Spectrum relit_mean = fitted + posterior_with(posterior_mean, fitted, measured, i, 1);
    r.de_d65_disc_mean += spectral::delta_e94(lab_under(truth, spectral::illuminant_d65()), lab_under(relit_mean, spectral::illuminant_d65()));
    r.de_a_disc_mean += spectral::delta_e94(lab_under(truth, spectral::illuminant_a()), lab_under(relit_mean, spectral::illuminant_a()));
    {
      const bool refitted = std::isfinite(e_dn[i].parameters.cm) && std::isfinite(e_dn[i].parameters.ch);
      const spectral::Spectrum fitted_dn = refitted ? model.albedo(e_dn[i].parameters) : fitted;
      const spectral::Spectrum relit_dn = fitted_dn + posterior_of(fitted_dn, denoised.values, i, std::max<int>(denoised.joined[i], 1));
      r.de_d65_dn += spectral::delta_e94(lab_under(truth, spectral::illuminant_d65()), lab_under(fitted_dn, spectral::illuminant_d65()));
      r.de_a_dn += spectral::delta_e94(lab_under(truth, spectral::illuminant_a()), lab_under(fitted_dn, spectral::illuminant_a()));
      r.de_d65_dn_disc += spectral::delta_e94(lab_under(truth, spectral::illuminant_d65()), lab_under(relit_dn, spectral::illuminant_d65()));
      r.de_a_dn_disc += spectral::delta_e94(lab_under(truth, spectral::illuminant_a()), lab_under(relit_dn, spectral::illuminant_a()));
      r.joined += denoised.joined[i];
      if (real) {
        auto& t = texture[frame.spectrum_index[i]];
        const double y_true = spectral::xyz_of_reflectance(truth, spectral::illuminant_d65()).Y;
        const double y_model = spectral::xyz_of_reflectance(fitted, spectral::illuminant_d65()).Y;
        const double y_dn = spectral::xyz_of_reflectance(relit_dn, spectral::illuminant_d65()).Y;
        t[0] += 1, t[1] += y_true, t[2] += y_true * y_true, t[3] += y_model, t[4] += y_true * y_model, t[5] += y_dn,
            t[6] += y_true * y_dn;
      }
    }
    r.de_d65 += spectral::delta_e94(lab_under(truth, spectral::illuminant_d65()), lab_under(fitted, spectral::illuminant_d65()));
    r.de_a += spectral::delta_e94(lab_under(truth, spectral::illuminant_a()), lab_under(fitted, spectral::illuminant_a()));
    const estimation::SkinParameters ref = real ? references[frame.spectrum_index[i]](frame.skin_scale[i]) : frame.truth[i];
    if (real) {
      const spectral::Spectrum floor = model.albedo(ref);
      r.floor_d65 += spectral::delta_e94(lab_under(truth, spectral::illuminant_d65()), lab_under(floor, spectral::illuminant_d65()));
      r.floor_a += spectral::delta_e94(lab_under(truth, spectral::illuminant_a()), lab_under(floor, spectral::illuminant_a()));
    }
    const double error[4] = {e[i].parameters.cm - ref.cm, e[i].parameters.ch - ref.ch, e[i].parameters.bm - ref.bm,
                             e[i].parameters.che - ref.che};
    within_log_ch += std::abs(std::log(e[i].parameters.ch / ref.ch)) <= 2 * e[i].sigma[1] / e[i].parameters.ch;
    for (int p = 0; p < 4; ++p) {
      const double ratio = std::abs(error[p]) / std::max(static_cast<double>(e[i].sigma[p]), 1e-12);
      within[p] += ratio <= 2;
      ratios[p].push_back(ratio);
    }
  }
  for (int k = 0; k < simulators::kSyntheticKindCount; ++k) r.flagged[k] = count[k] ? double(flagged[k]) / count[k] : 0;
  if (real)
    for (std::size_t p = 0; p < spectra.size(); ++p)
      r.flagged_per_spectrum.push_back(per_count[p] ? double(per_flagged[p]) / per_count[p] : 0);
  if (skin_fitted) r.de_all /= skin_fitted;
  if (r.explained_skin) {
    r.de_d65 /= r.explained_skin, r.de_a /= r.explained_skin;
    r.de_d65_disc /= r.explained_skin, r.de_a_disc /= r.explained_skin;
    r.de_d65_disc_mean /= r.explained_skin, r.de_a_disc_mean /= r.explained_skin;
    r.de_d65_dn /= r.explained_skin, r.de_a_dn /= r.explained_skin;
    r.de_d65_dn_disc /= r.explained_skin, r.de_a_dn_disc /= r.explained_skin;
    r.joined /= r.explained_skin;
    int patches = 0;
    for (const auto& t : texture) {
      if (t[0] < 3) continue;
      const double var = t[2] / t[0] - std::pow(t[1] / t[0], 2);
      if (!(var > 0)) continue;
      r.texture_slope += (t[4] / t[0] - t[1] / t[0] * t[3] / t[0]) / var;
      r.texture_slope_dn_disc += (t[6] / t[0] - t[1] / t[0] * t[5] / t[0]) / var;
      ++patches;
    }
    if (patches) r.texture_slope /= patches, r.texture_slope_dn_disc /= patches;
    r.floor_d65 /= r.explained_skin, r.floor_a /= r.explained_skin;
    r.order4 = double(order4) / r.explained_skin;
    r.within_2sigma_log_ch = double(within_log_ch) / r.explained_skin;
    for (int p = 0; p < 4; ++p) {
      r.within_2sigma[p] = double(within[p]) / r.explained_skin;
      std::nth_element(ratios[p].begin(), ratios[p].begin() + ratios[p].size() / 2, ratios[p].end());
      r.median_ratio[p] = ratios[p][ratios[p].size() / 2];
    }
  }
  return r;
}

struct Row {
  std::vector<std::string> subjects;  // the fold's held-out subjects
  std::string plan, scene, statistic;
  double noise_scale;
  std::uint64_t seed;
  int fold;
  Run r;
};

int run(int argc, char** argv) {
  CLI::App app{"the estimator on real skin spectra held out by subject, today's statistic against the learned discrepancy"};
  std::vector<std::uint64_t> seeds{1, 2};
  std::vector<double> noise_scales{0.5, 1, 2, 4};
  int patch = 200;
  std::string out = "bench/results";
  app.add_option("--seeds", seeds, "scene seeds")->delimiter(',');
  app.add_option("--noise-scales", noise_scales, "camera noise σ factors")->delimiter(',');
  app.add_option("--patch", patch, "pixels per held-out subject")->check(CLI::Range(10, 100000));
  std::vector<double> prior_widen{1, 2};
  app.add_option("--prior-widen", prior_widen, "the parameter prior's widening factors (>= 1), one statistic each")
      ->delimiter(',');
  int prior_max_channels = 4;
  app.add_option("--prior-max-channels", prior_max_channels,
                 "the prior is used on plans of at most this many channels (4: the method's only; 18: the six LEDs too)")
      ->check(CLI::Range(1, 64));
  std::vector<std::string> plan_names{"method", "six-leds"};
  app.add_option("--plans", plan_names, "plans to run (method, six-leds)")->delimiter(',');
  estimation::SkinDenoiseOptions denoise;
  app.add_option("--denoise-radius", denoise.radius_px, "the multi-pixel estimate's window radius (px)")->capture_default_str();
  app.add_option("--denoise-quantile", denoise.agreement_quantile, "the multi-pixel estimate's agreement quantile")
      ->capture_default_str();
  std::vector<double> forced_scales;
  app.add_option("--forced-scales", forced_scales, "learned discrepancy x S on every pixel, one statistic each (the ink check)")
      ->delimiter(',');
  FrameScaleMode subject_scale{FrameScaleMode::kPerSubject}, frame_scale{FrameScaleMode::kOneFrame};
  app.add_option("--max-weight", subject_scale.options.max_weight, "the bound of the frame term's weight")->capture_default_str();
  std::vector<std::string> only_statistics;
  app.add_option("--statistics", only_statistics, "run only these statistics (default all)")->delimiter(',');
  bool loso = false;
  app.add_flag("--loso", loso, "print the training subjects' leave-one-subject-out frame scales per fold, plan and noise");
  app.add_option("--out", out, "output directory");
  CLI11_PARSE(app, argc, argv);
  for (double s : noise_scales)
    if (!(s >= 0)) throw std::invalid_argument("--noise-scales: every scale must be >= 0 (0: noise-free, declared so)");

  const auto& all_spectra = estimation::nist_forearm_spectra();
  const auto& all_residuals = estimation::nist_forearm_residuals();
  for (double w : prior_widen)
    if (!(w >= 1)) throw std::invalid_argument("--prior-widen: every factor must be >= 1");
  for (double f : forced_scales)
    if (!(f > 0)) throw std::invalid_argument("--forced-scales: every scale must be > 0");
  if (!(subject_scale.options.max_weight >= 0)) throw std::invalid_argument("--max-weight must be >= 0");
  frame_scale.options = subject_scale.options;
  std::vector<std::string> kStatistics;
  for (const std::string& name : statistics(prior_widen, forced_scales))
    if (only_statistics.empty() || std::find(only_statistics.begin(), only_statistics.end(), name) != only_statistics.end())
      kStatistics.push_back(name);
  if (kStatistics.empty()) throw std::invalid_argument("--statistics: none of the statistics named");
  auto scale_mode_of = [&](const std::string& statistic) {
    if (statistic == "subj-s") return subject_scale;
    if (statistic == "frame-s") return frame_scale;
    for (double f : forced_scales) {
      char name[32];
      std::snprintf(name, sizeof name, "disc x%g", f);
      if (statistic == name) return FrameScaleMode{FrameScaleMode::kFixed, f, {}};
    }
    return FrameScaleMode{};
  };
  std::vector<RealSkinPlan> plan_list;
  for (RealSkinPlan& p : plans())
    if (std::find(plan_names.begin(), plan_names.end(), p.name) != plan_names.end()) plan_list.push_back(std::move(p));
  if (plan_list.empty()) throw std::invalid_argument("--plans: none of method, six-leds");
  std::fprintf(stderr, "fitting the reference parameters of %zu subjects at 3 texture scales...\n", all_spectra.size());
  std::vector<Reference> all_references(all_spectra.size());
  for (int s = 0; s < 3; ++s) {
    std::vector<estimation::NamedSpectrum> scaled = all_spectra;
    for (auto& n : scaled) n.albedo *= 0.97 + 0.03 * s;
#pragma omp parallel for schedule(dynamic)
    for (std::size_t i = 0; i < scaled.size(); ++i) all_references[i].at[s] = estimation::fit_spectrum(scaled[i].albedo).parameters;
  }
  std::vector<Row> rows;
  for (int fold = 0; fold < kFolds; ++fold) {
    std::vector<estimation::SpectrumResidual> train;
    std::vector<spectral::Spectrum> test;
    std::vector<Reference> references;
    std::vector<std::string> test_names;
    for (std::size_t i = 0; i < all_spectra.size(); ++i) {
      if (static_cast<int>(i % kFolds) == fold)
        test.push_back(all_spectra[i].albedo), references.push_back(all_references[i]), test_names.push_back(all_spectra[i].name);
      else train.push_back(all_residuals[i]);
    }
    const auto learned = std::make_shared<const estimation::ModelDiscrepancy>(estimation::ModelDiscrepancy::learn(train));
    // By plan, learned from the training folds only: zero-mean prior, and μ_d with Σ_d.
    std::map<std::string, estimation::DiscrepancyPosterior> posteriors, posteriors_mean;
    for (const RealSkinPlan& plan : plan_list) {
      posteriors.emplace(plan.name, estimation::DiscrepancyPosterior(*learned, plan.set));
      posteriors_mean.emplace(plan.name, estimation::DiscrepancyPosterior(*learned, plan.set,
                                                                           estimation::DiscrepancyPrior::kMeanAndCovariance));
    }
    std::vector<estimation::SkinParameters> train_fits;
    for (std::size_t i = 0; i < all_spectra.size(); ++i)
      if (static_cast<int>(i % kFolds) != fold) train_fits.push_back(all_references[i].at[1]);
    std::map<std::string, std::shared_ptr<const estimation::ParameterPrior>> priors;  // by statistic
    for (double w : prior_widen) {
      char name[32];
      std::snprintf(name, sizeof name, "prior x%g", w);
      priors[name] = std::make_shared<const estimation::ParameterPrior>(estimation::ParameterPrior::learn(train_fits, w));
    }
    if (loso)
      for (const RealSkinPlan& plan : plan_list)
        for (double scale : noise_scales) {
          estimation::MeasurementSet set = plan.set;
          simulators::set_exposure_noise(set, real_skin_camera_noise(scale));
          estimation::EstimatorOptions eo;
          eo.threads = 2;
          eo.discrepancy = learned;
          const estimation::Estimator base(plan.table, set, eo);
          std::vector<spectral::Spectrum> train_spectra;
          std::vector<std::string> train_names;
          for (std::size_t i = 0; i < all_spectra.size(); ++i)
            if (static_cast<int>(i % kFolds) != fold) train_spectra.push_back(all_spectra[i].albedo), train_names.push_back(all_spectra[i].name);
          const auto loo = leave_one_out_scales(base, set, train, train_spectra, patch, seeds.front());
          std::vector<std::size_t> order(loo.size());
          for (std::size_t k = 0; k < loo.size(); ++k) order[k] = k;
          std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return loo[a].first > loo[b].first; });
          std::printf("loso fold %d %-8s noise %.2f: scale (weight) largest %.3g (%.3g, %s), %.3g (%.3g, %s), %.3g (%.3g, %s); "
                      "median %.3g; >1: %zu of %zu\n",
                      fold, plan.name.c_str(), scale, loo[order[0]].first, loo[order[0]].second, train_names[order[0]].c_str(),
                      loo[order[1]].first, loo[order[1]].second, train_names[order[1]].c_str(), loo[order[2]].first,
                      loo[order[2]].second, train_names[order[2]].c_str(), loo[order[loo.size() / 2]].first,
                      static_cast<std::size_t>(std::count_if(loo.begin(), loo.end(), [](const auto& v) { return v.first > 1; })),
                      loo.size());
          std::fflush(stdout);
        }
    for (const RealSkinPlan& plan : plan_list)
      for (double scale : noise_scales)
        for (std::uint64_t seed : seeds)
          for (const std::string scene : {"real", "model"}) {
            estimation::MeasurementSet set = plan.set;
            simulators::set_exposure_noise(set, real_skin_camera_noise(scale));
            simulators::SyntheticOptions o;
            o.seed = seed * 100 + fold;
            o.noise.noise_scale = 0;
            o.share[static_cast<int>(SyntheticKind::kTattoo)] = 0.04;
            o.share[static_cast<int>(SyntheticKind::kMarker)] = 0.04;
            o.share[static_cast<int>(SyntheticKind::kVein)] = 0.02;
            o.share[static_cast<int>(SyntheticKind::kSpecular)] = 0.02;
            o.pixels = static_cast<int>(test.size()) * patch;
            if (scene == "real") o.skin_spectra = test, o.patch_pixels = patch;
            estimation::MeasurementSet render_set = set;
            const simulators::SyntheticFrame frame = simulators::make_synthetic_frame(render_set, o);
            const std::vector<float> noisy = simulators::add_channel_noise(frame.clean, set, o.seed * 7919 + 1);
            RealSkinPlan declared = plan;
            declared.set = set;
            for (const std::string statistic : kStatistics)
              rows.push_back({test_names, plan.name, scene, statistic, scale, seed, fold,
                              evaluate(declared, frame, noisy, test, references, statistic == "today" ? nullptr : learned,
                                       priors.contains(statistic) ? priors.at(statistic) : nullptr, prior_max_channels,
                                       posteriors.at(plan.name), posteriors_mean.at(plan.name), patch, denoise,
                                       scale_mode_of(statistic))});
          }
    std::fprintf(stderr, "fold %d of %d done\n", fold + 1, kFolds);
  }

  std::printf("real_skin_bench: %d folds by subject x %zu seeds, %d px per held-out subject, fast inverter, auto model, "
              "no spatial pass, 2 threads\n\n",
              kFolds, seeds.size(), patch);
  std::printf("%-8s %-5s %-7s %5s %4s %4s %7s %7s %7s %7s %7s %7s %6s %6s %6s %6s %6s %5s %5s\n", "plan", "scene", "stat",
              "noise", "seed", "fold", "skin%", "tattoo%", "marker%", "vein%", "dE D65", "dE A", "ord4%", "in2sCm", "in2sCh",
              "in2sBm", "in2sChe", "medCm", "medCh");
  std::filesystem::create_directories(out);
  std::ofstream csv(std::filesystem::path(out) / "real_skin.csv");
  csv << "plan,scene,statistic,noise_scale,seed,fold,skin_flagged,tattoo_caught,marker_caught,vein_caught,de94_d65,de94_a,"
         "order4,within2s_cm,within2s_ch,within2s_bm,within2s_che,median_ratio_cm,median_ratio_ch,median_ratio_bm,"
         "median_ratio_che\n";
  for (const Row& row : rows) {
    const Run& r = row.r;
    std::printf("%-8s %-5s %-7s %5.2f %4llu %4d %7.2f %7.1f %7.1f %7.1f %7.3f %7.3f %6.1f %6.1f %6.1f %6.1f %6.1f %5.2f %5.2f\n",
                row.plan.c_str(), row.scene.c_str(), row.statistic.c_str(), row.noise_scale,
                static_cast<unsigned long long>(row.seed), row.fold, 100 * r.flagged[0], 100 * r.flagged[2],
                100 * r.flagged[3], 100 * r.flagged[1], r.de_d65, r.de_a, 100 * r.order4, 100 * r.within_2sigma[0],
                100 * r.within_2sigma[1], 100 * r.within_2sigma[2], 100 * r.within_2sigma[3], r.median_ratio[0],
                r.median_ratio[1]);
    csv << row.plan << "," << row.scene << "," << row.statistic << "," << row.noise_scale << "," << row.seed << ","
        << row.fold << "," << r.flagged[0] << "," << r.flagged[2] << "," << r.flagged[3] << "," << r.flagged[1] << ","
        << r.de_d65 << "," << r.de_a << "," << r.order4;
    for (double v : r.within_2sigma) csv << "," << v;
    for (double v : r.median_ratio) csv << "," << v;
    csv << "\n";
  }
  csv.close();
  std::printf("\nheld-out subjects whose skin is more than 5%% flagged:\n");
  for (const Row& row : rows)
    for (std::size_t p = 0; p < row.r.flagged_per_spectrum.size(); ++p)
      if (row.r.flagged_per_spectrum[p] > 0.05)
        std::printf("  %-8s %-7s noise %.2f seed %llu fold %d: %s %.1f%%\n", row.plan.c_str(), row.statistic.c_str(),
                    row.noise_scale, static_cast<unsigned long long>(row.seed), row.fold, row.subjects[p].c_str(),
                    100 * row.r.flagged_per_spectrum[p]);

  std::printf("\nframe scales above 1 (subj-s: per held-out subject; frame-s: the whole scene), scale (weight of the frame's own term):\n");
  for (const Row& row : rows)
    for (std::size_t p = 0; p < row.r.scales.size(); ++p)
      if (row.r.scales[p] > 1 && (row.statistic == "subj-s" || row.statistic == "frame-s"))
        std::printf("  %-8s %-5s %-7s noise %.2f seed %llu fold %d: %s %.3g (%.3g)\n", row.plan.c_str(), row.scene.c_str(),
                    row.statistic.c_str(), row.noise_scale, static_cast<unsigned long long>(row.seed), row.fold,
                    row.statistic == "frame-s" ? "scene" : row.scene == "real" ? row.subjects[p].c_str() : ("part " + std::to_string(p)).c_str(),
                    row.r.scales[p], row.r.weights[p]);

  std::printf("\nspread over %d folds x %zu seeds, mean [min, max]:\n", kFolds, seeds.size());
  std::printf("%-8s %-5s %-7s %5s  %-22s %-22s %-22s %-22s %-8s %-8s %-8s %-8s %-6s %-6s %-8s\n", "plan", "scene", "stat",
              "noise", "skin flagged %", "tattoo+marker caught %", "dE94 mean(D65,A)", "order4 %", "in2sCm", "in2sCh", "in2sBm",
              "in2sChe", "medCm", "medCh", "in2sLnCh");
  std::map<std::string, std::vector<std::pair<double, double>>> curves;  // plan/stat -> (noise, flagged)
  std::map<std::string, std::vector<std::pair<double, double>>> relit_curves;  // plan/scene/stat -> (noise, relit ΔE94)
  std::map<std::string, std::vector<std::pair<double, double>>> layer_curves;  // plan/layer -> (noise, relit ΔE94), real skin
  for (const RealSkinPlan& plan : plan_list)
    for (const std::string scene : {"real", "model"})
      for (const std::string& statistic : kStatistics)
        for (double scale : noise_scales) {
          std::vector<const Run*> runs;
          for (const Row& row : rows)
            if (row.plan == plan.name && row.scene == scene && row.statistic == statistic && row.noise_scale == scale)
              runs.push_back(&row.r);
          auto spread = [&](auto get) {
            double sum = 0, lo = get(*runs[0]), hi = lo;
            for (const Run* r : runs) sum += get(*r), lo = std::min(lo, get(*r)), hi = std::max(hi, get(*r));
            return std::array<double, 3>{sum / runs.size(), lo, hi};
          };
          auto text = [](std::array<double, 3> v, double k) {
            char b[64];
            std::snprintf(b, sizeof b, "%.3g [%.3g, %.3g]", k * v[0], k * v[1], k * v[2]);
            return std::string(b);
          };
          const auto skin = spread([](const Run& r) { return r.flagged[0]; });
          const auto ink = spread([](const Run& r) { return (r.flagged[2] + r.flagged[3]) / 2; });
          const auto de = spread([](const Run& r) { return (r.de_d65 + r.de_a) / 2; });
          const auto floor = spread([](const Run& r) { return (r.floor_d65 + r.floor_a) / 2; });
          const auto de_d65 = spread([](const Run& r) { return r.de_d65; });
          const auto de_a = spread([](const Run& r) { return r.de_a; });
          const auto de_all = spread([](const Run& r) { return r.de_all; });
          const auto de_disc = spread([](const Run& r) { return (r.de_d65_disc + r.de_a_disc) / 2; });
          const auto de_d65_disc = spread([](const Run& r) { return r.de_d65_disc; });
          const auto de_a_disc = spread([](const Run& r) { return r.de_a_disc; });
          const auto ord = spread([](const Run& r) { return r.order4; });
          std::array<double, 4> in2s{}, med{};
          for (int p = 0; p < 4; ++p) {
            in2s[p] = spread([p](const Run& r) { return r.within_2sigma[p]; })[0];
            med[p] = spread([p](const Run& r) { return r.median_ratio[p]; })[0];
          }
          const double in2s_log_ch = spread([](const Run& r) { return r.within_2sigma_log_ch; })[0];
          std::printf("%-8s %-5s %-7s %5.2f  %-22s %-22s %-22s %-22s %-8.1f %-8.1f %-8.1f %-8.1f %-6.2f %-6.2f %-8.1f\n",
                      plan.name.c_str(), scene.c_str(), statistic.c_str(), scale, text(skin, 100).c_str(),
                      text(ink, 100).c_str(), text(de, 1).c_str(), text(ord, 100).c_str(), 100 * in2s[0], 100 * in2s[1],
                      100 * in2s[2], 100 * in2s[3], med[0], med[1], 100 * in2s_log_ch);
          std::printf("%-8s %-5s %-7s %5.2f    relit D65 %s, A %s; every skin pixel, flagged too, %s; the 4D "
                      "full-spectrum fit on the unflagged pixels %s\n",
                      plan.name.c_str(), scene.c_str(), statistic.c_str(), scale, text(de_d65, 1).c_str(),
                      text(de_a, 1).c_str(), text(de_all, 1).c_str(), text(floor, 1).c_str());
          const auto de_disc_mean = spread([](const Run& r) { return (r.de_d65_disc_mean + r.de_a_disc_mean) / 2; });
          std::printf("%-8s %-5s %-7s %5.2f    relit model+discrepancy (posterior, same pixels), zero-mean prior: mean(D65,A) "
                      "%s; D65 %s, A %s; prior mu_d, Sigma_d: %s\n",
                      plan.name.c_str(), scene.c_str(), statistic.c_str(), scale, text(de_disc, 1).c_str(),
                      text(de_d65_disc, 1).c_str(), text(de_a_disc, 1).c_str(), text(de_disc_mean, 1).c_str());
          const auto de_dn = spread([](const Run& r) { return (r.de_d65_dn + r.de_a_dn) / 2; });
          const auto de_dn_disc = spread([](const Run& r) { return (r.de_d65_dn_disc + r.de_a_dn_disc) / 2; });
          const auto joined = spread([](const Run& r) { return r.joined; });
          const auto slope = spread([](const Run& r) { return r.texture_slope; });
          const auto slope_dn = spread([](const Run& r) { return r.texture_slope_dn_disc; });
          std::printf("%-8s %-5s %-7s %5.2f    multi-pixel estimate (%s px averaged): model %s, model+discrepancy %s; "
                      "texture kept (slope of relit Y on true Y) %s -> %s\n",
                      plan.name.c_str(), scene.c_str(), statistic.c_str(), scale, text(joined, 1).c_str(),
                      text(de_dn, 1).c_str(), text(de_dn_disc, 1).c_str(), text(slope, 1).c_str(), text(slope_dn, 1).c_str());
          relit_curves[plan.name + " " + scene + " " + statistic].emplace_back(scale, de[0]);
          if (statistic == "learned")
            relit_curves[plan.name + " " + scene + " learned, multi-pixel, model+discrepancy"].emplace_back(scale, de_dn_disc[0]);
          if (statistic == "learned")
            relit_curves[plan.name + " " + scene + " learned, model+discrepancy"].emplace_back(scale, de_disc[0]);
          if (scene == "real" && statistic == "learned") relit_curves[plan.name + " 4D full-spectrum fit (floor)"].emplace_back(scale, floor[0]);
          if (scene == "real") curves[plan.name + " " + statistic].emplace_back(scale, 100 * skin[0]);
          // The relit layers on real skin: the six LEDs with the learned statistic, the method's plan with the
          // widest prior (the lever its four channels need), if any.
          const bool layers = scene == "real" && statistic == (plan.name == "six-leds" ? "learned" : kStatistics.back());
          if (layers) {
            const std::string label = plan.name + " (" + statistic + ")";
            layer_curves[label + ": model"].emplace_back(scale, de[0]);
            layer_curves[label + ": model + discrepancy"].emplace_back(scale, de_disc[0]);
            layer_curves[label + ": multi-pixel, model + discrepancy"].emplace_back(scale, de_dn_disc[0]);
            layer_curves[plan.name + ": 4D full-spectrum fit (floor)"].emplace_back(scale, floor[0]);
          }
        }

  std::vector<LineSeries> series;
  for (const auto& [name, points] : curves) series.push_back({name, points});
  const auto png = std::filesystem::path(out) / "real_skin.png";
  if (write_line_chart(png, "real skin flagged (held-out NIST subjects, 5 folds)",
                       "camera noise (x four frames of a 40,000 e- sensor)", "skin flagged (%)", series, true))
    std::printf("\nchart: %s\n", png.c_str());
  std::vector<LineSeries> relit_series;
  for (const auto& [name, points] : relit_curves)
    if (name.find(" model today") == std::string::npos && name.find(" real today") == std::string::npos)
      relit_series.push_back({name, points});
  const auto relit_png = std::filesystem::path(out) / "real_skin_relit.png";
  if (write_line_chart(relit_png, "where the relit error comes from: held-out real skin, model skin (noise alone), the 4D floor",
                       "camera noise (x four frames of a 40,000 e- sensor)", "relit dE94, mean of D65 and A (unflagged skin)",
                       relit_series, true))
    std::printf("chart: %s\n", relit_png.c_str());
  std::vector<LineSeries> layer_series;
  for (const auto& [name, points] : layer_curves) layer_series.push_back({name, points});
  const auto layers_png = std::filesystem::path(out) / "real_skin_relit_layers.png";
  if (write_line_chart(layers_png,
                       "relit layers on held-out real skin (targets: six LEDs 0.26, method 0.45)",
                       "camera noise (x four frames of a 40,000 e- sensor; 0 = noise-free)",
                       "relit dE94, mean of D65 and A (unflagged skin)", layer_series, false))
    std::printf("chart: %s\n", layers_png.c_str());
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) { return chromo::bench::guarded_main("real_skin_bench", chromo::bench::run, argc, argv); }
