// The seed's own study on real skin, and past the model's floor (issue 38),
// side by side in one run over held-out folds and seeds.
//
// Scenes: the NIST forearm spectra (estimation::nist_forearm_spectra), 5
// folds by subject (subject i in fold i mod 5); each fold's 10 held-out
// subjects a patch of --patch pixels with a ±3% texture, with and without
// subsurface spread (subsurface_spread.hpp). Camera: the Nikon D5100
// sensitivity, four frames of a 40,000 e⁻ sensor (160,000 e⁻ at full
// scale, 12 e⁻ read) per capture, each exposed to put its brightest white
// channel at full scale (simulators::set_exposure_noise), times
// --noise-scales. Estimator: the product's defaults (fast inverter, auto
// model order) with the learned discrepancy of the fold's 40 training
// subjects.
//
// Part 1, the broadband study: W57, W40, W27, D65' alone (R, G, B) and each
// + blue (R, G, B + the blue-only B, as the method's), relit under the nine
// illuminants W57, W40, W27, R, G, B, D65', D65, A against each pixel's own
// spectrum: ΔE94 under the plan's own illuminant and the mean over the
// others, per skin-tone quartile (ITA° of the spectrum under D65), parameter
// noise (the spread of each estimated parameter within a subject's patch
// around its linear trend in the texture factor: log10 Cm, log10 Ch, βm,
// Che), and the seed's five claims checked against these figures.
//
// Part 2, past the model's floor: the six LEDs one at a time (18 channels).
// A residual basis (estimation/residual_basis.hpp) is learned per fold from
// the 40 training subjects only (a training scene of --train-patch pixels
// each, same camera, noise and spread, another seed): channel residuals of
// the estimate → the basis's coefficients. Relit ΔE94 (mean of D65 and A) on
// the held-out subjects: the 4D estimate, the corrected appearance per
// number of basis spectra (--components), and the 4D model's own floor (the
// full-spectrum fit of each held-out spectrum against it).
//
//   seed_study_bench [--seeds 1,2] [--folds 5] [--patch 60] [--train-patch 20]
//                    [--noise-scales 1] [--components 1,2,3,4,6] [--out DIR]
//
// Writes DIR/seed_study.csv (one row per plan × scene × noise × seed × fold),
// DIR/seed_study.png (part 1: relit ΔE94 per illuminant, per plan, spread-free
// scene at the first noise scale) and DIR/past_floor.png (part 2).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "bench_cli.hpp"
#include <Eigen/Dense>

#include "chart.hpp"
#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/estimation/residual_basis.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/files/gnuplot_chart.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/colorimetry.hpp"
#include "chromo/spectral/delta_e.hpp"
#include "chromo/spectral/lab_illuminants.hpp"
#include "guarded_main.hpp"
#include "real_skin_camera.hpp"
#include "seed_spread.hpp"
#include "subsurface_spread.hpp"

namespace chromo::bench {
namespace {

using spectral::LedType;

// The nine illuminants the study relights under; a plan's own is one of the first seven.
struct Illuminant {
  std::string name;
  spectral::Spectrum spectrum;
  spectral::Xyz white;
};
std::vector<Illuminant> study_illuminants() {
  std::vector<Illuminant> out;
  auto add = [&](std::string name, const spectral::Spectrum& s) { out.push_back({std::move(name), s, spectral::white_point(s)}); };
  for (auto type : spectral::kAllLedTypes) add(std::string(spectral::led_type_name(type)), spectral::led_spectrum(type));
  add("D65'", spectral::led_d65_metamer());
  add("D65", spectral::illuminant_d65());
  add("A", spectral::illuminant_a());
  return out;
}
constexpr int kIlluminants = 9, kD65 = 7, kA = 8;

struct Plan {
  std::string name;
  int own = -1;  // index of its broadband in study_illuminants(); -1: none (six LEDs)
  estimation::MeasurementSet set;
  std::shared_ptr<const estimation::ForwardTable> table;
};

std::vector<Plan> plans() {
  const spectral::CameraSensitivity camera = spectral::builtin_camera("nikon_d5100");
  const spectral::Spectrum& blue = spectral::led_spectrum(LedType::kBlue);
  std::vector<Plan> out;
  const std::pair<std::string, int> broadbands[] = {{"W57", 0}, {"W40", 1}, {"W27", 2}, {"D65'", 6}};
  const auto illuminants = study_illuminants();
  for (const auto& [name, own] : broadbands) {
    out.push_back({name, own, estimation::rgb_measurement_set(camera, illuminants[own].spectrum, {}, name), nullptr});
    out.push_back({name + "+blue", own, estimation::method_measurement_set(camera, illuminants[own].spectrum, blue), nullptr});
  }
  out.push_back({"six-leds", -1, six_led_measurement_set(camera), nullptr});
  for (Plan& p : out) p.table = default_table(p.set);
  return out;
}

spectral::Lab lab_under(const spectral::Spectrum& albedo, const Illuminant& light) {
  return spectral::lab_from_xyz(spectral::xyz_of_reflectance(albedo, light.spectrum), light.white);
}

// ITA° = atan((L* − 50) / b*) of a spectrum under D65: larger is lighter skin.
double ita_degrees(const spectral::Spectrum& albedo) {
  const spectral::Lab lab = spectral::lab_from_xyz(spectral::xyz_of_reflectance(albedo, spectral::illuminant_d65()),
                                                   spectral::white_point(spectral::illuminant_d65()));
  return std::atan2(lab.L - 50, lab.b) * 180 / std::numbers::pi;
}

// A scene of `spectra` (patch_pixels each) rendered for `set`: its true albedo
// per pixel (with or without spread), noise-free and noisy channels.
struct Scene {
  std::vector<spectral::Spectrum> truth;
  std::vector<int> subject;     // index into the scene's spectra
  std::vector<float> texture;   // s_i
  std::vector<float> noisy;
};

Scene render(const estimation::MeasurementSet& set, const std::vector<spectral::Spectrum>& spectra, int patch_pixels,
             bool spread, std::uint64_t seed) {
  simulators::SyntheticOptions o;
  o.seed = seed;
  o.noise.noise_scale = 0;
  o.pixels = static_cast<int>(spectra.size()) * patch_pixels;
  o.skin_spectra = spectra;
  o.patch_pixels = patch_pixels;
  estimation::MeasurementSet render_set = set;  // make_synthetic_frame replaces its noise; only the texture draw is used
  const simulators::SyntheticFrame frame = simulators::make_synthetic_frame(render_set, o);
  const auto textures = spread_texture(frame.skin_scale, patch_pixels, spread);
  const Eigen::MatrixXd w = set.weights();
  Scene s;
  std::vector<float> clean(frame.pixels() * set.size());
  for (std::size_t i = 0; i < frame.pixels(); ++i) {
    s.truth.emplace_back(spectra[frame.spectrum_index[i]].values() * textures[i]);
    s.subject.push_back(frame.spectrum_index[i]);
    s.texture.push_back(frame.skin_scale[i]);
    const Eigen::VectorXd c = w * s.truth.back().values().matrix();
    for (int k = 0; k < set.size(); ++k) clean[i * set.size() + k] = static_cast<float>(c[k]);
  }
  s.noisy = simulators::add_channel_noise(clean, set, seed * 7919 + 1);
  return s;
}

std::vector<estimation::PixelEstimate> estimate(const Plan& plan, const estimation::MeasurementSet& set, const Scene& scene,
                                                std::shared_ptr<const estimation::ModelDiscrepancy> discrepancy) {
  estimation::EstimatorOptions options;
  options.threads = 2;
  options.discrepancy = std::move(discrepancy);
  const estimation::Estimator estimator(plan.table, set, options);
  std::vector<estimation::PixelEstimate> e(scene.truth.size());
  estimator.estimate(scene.noisy, e);
  return e;
}

// The spread of values around their least-squares line in x (NaN below 3 points).
double detrended_sd(const std::vector<double>& x, const std::vector<double>& y) {
  const std::size_t n = x.size();
  if (n < 3) return std::nan("");
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < n; ++i) mx += x[i] / n, my += y[i] / n;
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < n; ++i) sxx += (x[i] - mx) * (x[i] - mx), sxy += (x[i] - mx) * (y[i] - my);
  const double slope = sxx > 0 ? sxy / sxx : 0;
  double ss = 0;
  for (std::size_t i = 0; i < n; ++i) ss += std::pow(y[i] - my - slope * (x[i] - mx), 2);
  return std::sqrt(ss / (n - 2));
}

constexpr int kTones = 4;

struct Run {
  std::string plan, scene;
  double noise_scale = 0;
  std::uint64_t seed = 0;
  int fold = 0;
  double flagged = 0;
  double order4 = 0;  // share of the explained skin fitted at order 4
  std::array<double, kIlluminants> de{};                  // mean relit ΔE94 per illuminant, explained skin
  std::array<std::array<double, kIlluminants>, kTones> de_tone{};  // per tone quartile (NaN when the fold has none)
  std::array<double, 4> parameter_noise{};                // log10 Cm, log10 Ch, βm, Che
  // Part 2 (six LEDs): relit mean(D65, A) of the corrected appearance per --components, and the floor.
  std::vector<double> corrected_d65_a;
  int chosen_components = 0;  // the basis size inner cross-validation on the training subjects picks
  double corrected_chosen_d65_a = std::nan("");
  double floor_d65_a = std::nan("");
};

double mean_d65_a(const std::array<double, kIlluminants>& de) { return (de[kD65] + de[kA]) / 2; }
double others(const std::array<double, kIlluminants>& de, int own) {
  double sum = 0;
  for (int l = 0; l < kIlluminants; ++l)
    if (l != own) sum += de[l];
  return sum / (kIlluminants - 1);
}

struct FoldData {
  std::vector<spectral::Spectrum> test, train;
  std::vector<int> test_tone;
  std::vector<spectral::Spectrum> test_floor_fit;  // the 4D full-spectrum fit of each held-out spectrum
  std::shared_ptr<const estimation::ModelDiscrepancy> discrepancy;
};

Run evaluate(const FoldData& fold, const Scene& scene, const std::vector<estimation::PixelEstimate>& e,
             const std::vector<Illuminant>& lights) {
  static const estimation::SkinModel model;
  Run r;
  r.de.fill(0);
  std::array<std::array<double, kIlluminants>, kTones> tone_sum{};
  std::array<std::size_t, kTones> tone_count{};
  std::size_t explained = 0;
  std::vector<std::vector<double>> x(fold.test.size());
  std::vector<std::vector<std::vector<double>>> per(4, std::vector<std::vector<double>>(fold.test.size()));
  for (std::size_t i = 0; i < e.size(); ++i) {
    if (e[i].flag != estimation::PixelFlag::kExplained) continue;
    ++explained;
    r.order4 += e[i].order == 4;
    const spectral::Spectrum fitted = model.albedo(e[i].parameters);
    const int tone = fold.test_tone[scene.subject[i]];
    for (int l = 0; l < kIlluminants; ++l) {
      const double de = spectral::delta_e94(lab_under(scene.truth[i], lights[l]), lab_under(fitted, lights[l]));
      r.de[l] += de;
      tone_sum[tone][l] += de;
    }
    ++tone_count[tone];
    const int s = scene.subject[i];
    x[s].push_back(scene.texture[i]);
    const auto& p = e[i].parameters;
    per[0][s].push_back(std::log10(p.cm)), per[1][s].push_back(std::log10(p.ch)), per[2][s].push_back(p.bm),
        per[3][s].push_back(p.che);
  }
  r.flagged = 1 - double(explained) / e.size();
  r.order4 = explained ? r.order4 / explained : std::nan("");
  for (int l = 0; l < kIlluminants; ++l) r.de[l] = explained ? r.de[l] / explained : std::nan("");
  for (int t = 0; t < kTones; ++t)
    for (int l = 0; l < kIlluminants; ++l) r.de_tone[t][l] = tone_count[t] ? tone_sum[t][l] / tone_count[t] : std::nan("");
  for (int p = 0; p < 4; ++p) {
    double sum = 0;
    int n = 0;
    for (std::size_t s = 0; s < fold.test.size(); ++s)
      if (const double sd = detrended_sd(x[s], per[p][s]); std::isfinite(sd)) sum += sd, ++n;
    r.parameter_noise[p] = n ? sum / n : std::nan("");
  }
  return r;
}

// Part 2: one explained pixel's residual sample, with the model albedo at its estimate and its subject.
struct ResidualPixel {
  estimation::ResidualSample sample;
  spectral::Spectrum model_albedo;
  int subject = 0;
};

std::vector<ResidualPixel> residual_pixels(const estimation::MeasurementSet& set, const Scene& scene,
                                           const std::vector<estimation::PixelEstimate>& e) {
  static const estimation::SkinModel model;
  const Eigen::MatrixXd w = set.weights();
  std::vector<ResidualPixel> out;
  for (std::size_t i = 0; i < e.size(); ++i) {
    if (e[i].flag != estimation::PixelFlag::kExplained) continue;
    const spectral::Spectrum fitted = model.albedo(e[i].parameters);
    const Eigen::VectorXd predicted = w * fitted.values().matrix();
    Eigen::VectorXd d(set.size());
    for (int k = 0; k < set.size(); ++k) d[k] = scene.noisy[i * set.size() + k] - predicted[k];
    out.push_back({{d, spectral::Spectrum(scene.truth[i].values() - fitted.values())}, fitted, scene.subject[i]});
  }
  return out;
}

std::vector<estimation::ResidualSample> samples_of(const std::vector<ResidualPixel>& pixels) {
  std::vector<estimation::ResidualSample> out;
  for (const ResidualPixel& p : pixels) out.push_back(p.sample);
  return out;
}

// Mean relit ΔE94 (mean of D65 and A) of the corrected appearance of `pixels` against their truth.
double corrected_error(const estimation::ResidualBasis& basis, const std::vector<ResidualPixel>& pixels,
                       const std::vector<Illuminant>& lights) {
  double sum = 0;
  for (const ResidualPixel& p : pixels) {
    const Eigen::VectorXd& d = p.sample.channel_residual;
    const spectral::Spectrum truth(p.model_albedo.values() + p.sample.spectral_residual.values());
    const spectral::Spectrum corrected(p.model_albedo.values() +
                                       basis.correction(basis.coefficients({d.data(), static_cast<std::size_t>(d.size())})).values());
    for (int l : {kD65, kA}) sum += spectral::delta_e94(lab_under(truth, lights[l]), lab_under(corrected, lights[l])) / 2;
  }
  return pixels.empty() ? std::nan("") : sum / pixels.size();
}

// The basis size of `components` with the lowest corrected error over 4
// inner folds of the training subjects (subject mod 4): chosen without the
// held-out subjects.
int choose_components(const std::vector<ResidualPixel>& train, const std::vector<int>& components,
                      const std::vector<Illuminant>& lights) {
  int best = components.front();
  double best_error = INFINITY;
  for (int k : components) {
    double error = 0;
    for (int inner = 0; inner < 4; ++inner) {
      std::vector<ResidualPixel> fit, check;
      for (const ResidualPixel& p : train) (p.subject % 4 == inner ? check : fit).push_back(p);
      error += corrected_error(estimation::ResidualBasis::learn(samples_of(fit), {.components = k}), check, lights) / 4;
    }
    if (error < best_error) best_error = error, best = k;
  }
  return best;
}

void correct(Run& r, const std::vector<ResidualPixel>& test, const std::vector<ResidualPixel>& train,
             const std::vector<int>& components, const std::vector<Illuminant>& lights) {
  const std::vector<estimation::ResidualSample> train_samples = samples_of(train);
  for (int k : components)
    r.corrected_d65_a.push_back(corrected_error(estimation::ResidualBasis::learn(train_samples, {.components = k}), test, lights));
  r.chosen_components = choose_components(train, components, lights);
  r.corrected_chosen_d65_a =
      corrected_error(estimation::ResidualBasis::learn(train_samples, {.components = r.chosen_components}), test, lights);
}

void write_study_chart(const std::filesystem::path& png, const std::vector<Run>& runs, const std::vector<std::string>& plan_names,
                       const std::vector<Illuminant>& lights, const std::string& scene, double noise_scale) {
  const auto dat = std::filesystem::path(png).replace_extension(".dat");
  {
    std::ofstream data(dat);
    data << "illuminant";
    for (const auto& p : plan_names) data << " \"" << p << "\"";
    data << "\n";
    for (int l = 0; l < kIlluminants; ++l) {
      data << '"' << lights[l].name << '"';
      for (const auto& p : plan_names) {
        std::vector<Run> mine;
        for (const Run& r : runs)
          if (r.plan == p && r.scene == scene && r.noise_scale == noise_scale) mine.push_back(r);
        data << " " << spread(mine, [l](const Run& r) { return r.de[l]; }).mean;
      }
      data << "\n";
    }
  }
  files::GnuplotChart chart;
  chart.png = png;
  chart.terminal = "pngcairo size 1100,520 font 'DejaVu Sans,10'";
  std::string plot = "plot ";
  for (std::size_t p = 0; p < plan_names.size(); ++p)
    plot += (p ? ", '' using " : "'" + dat.string() + "' using ") + std::to_string(p + 2) + (p ? "" : ":xtic(1)") + " title columnheader(" +
            std::to_string(p + 2) + ")";
  chart.commands = "set title 'relit ΔE94 of held-out NIST skin, by capture plan (" + scene + " scene, noise x" +
                   std::to_string(noise_scale).substr(0, 4) +
                   ", mean over folds x seeds)'\nset ylabel 'relit ΔE94'\nset xlabel 'relit under'\n"
                   "set style data histograms\nset style histogram clustered gap 1\nset style fill solid 0.85 border -1\n"
                   "set boxwidth 0.9\nset grid ytics\nset key outside right\nset yrange [0:*]\n" +
                   plot + "\n";
  if (const std::string failed = files::draw_chart(chart, std::filesystem::path(png).replace_extension(".gp")); !failed.empty())
    std::fprintf(stderr, "chart: %s; figures are in %s\n", failed.c_str(), dat.c_str());
  else
    std::printf("chart: %s\n", png.c_str());
}

std::string text(Spread s, double k = 1) {
  char b[64];
  std::snprintf(b, sizeof b, "%.3f [%.3f, %.3f]", k * s.mean, k * s.lo, k * s.hi);
  return b;
}

int run(int argc, char** argv) {
  CLI::App app{"the seed's broadband study on real skin, and the residual basis past the model's floor"};
  std::vector<std::uint64_t> seeds{1, 2};
  std::vector<double> noise_scales{1};
  std::vector<int> components{1, 2, 3, 4, 6};
  int folds = 5, patch = 60, train_patch = 20;
  std::string out = "bench/results";
  app.add_option("--seeds", seeds, "scene seeds")->delimiter(',');
  app.add_option("--folds", folds, "folds run (of 5 by subject)")->check(CLI::Range(1, 5));
  app.add_option("--patch", patch, "pixels per held-out subject")->check(CLI::Range(10, 100000));
  app.add_option("--train-patch", train_patch, "pixels per training subject (part 2)")->check(CLI::Range(1, 100000));
  app.add_option("--noise-scales", noise_scales, "camera noise σ factors")->delimiter(',');
  app.add_option("--components", components, "residual basis sizes (part 2)")->delimiter(',')->check(CLI::Range(1, 20));
  app.add_option("--out", out, "output directory");
  CLI11_PARSE(app, argc, argv);
  for (double s : noise_scales)
    if (!(s > 0)) throw std::invalid_argument("--noise-scales: every scale must be > 0");

  const auto& spectra = estimation::nist_forearm_spectra();
  const auto& residuals = estimation::nist_forearm_residuals();
  const auto lights = study_illuminants();
  // Skin-tone quartiles by ITA° over all subjects (0 lightest).
  std::vector<double> ita;
  for (const auto& s : spectra) ita.push_back(ita_degrees(s.albedo));
  std::vector<double> sorted = ita;
  std::sort(sorted.begin(), sorted.end(), std::greater<>());
  auto tone_of = [&](double v) {
    for (int t = 0; t < kTones - 1; ++t)
      if (v >= sorted[(t + 1) * sorted.size() / kTones - 1]) return t;
    return kTones - 1;
  };
  std::fprintf(stderr, "building the forward tables of 9 plans...\n");
  const std::vector<Plan> plan_list = plans();

  std::vector<Run> runs;
  for (int f = 0; f < folds; ++f) {
    FoldData fold;
    std::vector<estimation::SpectrumResidual> train_residuals;
    for (std::size_t i = 0; i < spectra.size(); ++i)
      if (static_cast<int>(i % 5) == f)
        fold.test.push_back(spectra[i].albedo), fold.test_tone.push_back(tone_of(ita[i])), fold.test_floor_fit.push_back(residuals[i].fitted);
      else fold.train.push_back(spectra[i].albedo), train_residuals.push_back(residuals[i]);
    fold.discrepancy = std::make_shared<const estimation::ModelDiscrepancy>(estimation::ModelDiscrepancy::learn(train_residuals));
    double floor = 0;
    for (std::size_t s = 0; s < fold.test.size(); ++s)
      for (int l : {kD65, kA})
        floor += spectral::delta_e94(lab_under(fold.test[s], lights[l]), lab_under(fold.test_floor_fit[s], lights[l])) / 2 / fold.test.size();
    for (double scale : noise_scales)
      for (std::uint64_t seed : seeds)
        for (const bool spread_on : {false, true})
          for (const Plan& plan : plan_list) {
            estimation::MeasurementSet set = plan.set;
            simulators::set_exposure_noise(set, real_skin_camera_noise(scale));
            const Scene scene = render(set, fold.test, patch, spread_on, seed * 100 + f);
            const auto e = estimate(plan, set, scene, fold.discrepancy);
            Run r = evaluate(fold, scene, e, lights);
            r.plan = plan.name, r.scene = spread_on ? "spread" : "flat", r.noise_scale = scale, r.seed = seed, r.fold = f;
            if (plan.own < 0) {
              const Scene train_scene = render(set, fold.train, train_patch, spread_on, seed * 100 + f + 50000);
              correct(r, residual_pixels(set, scene, e),
                      residual_pixels(set, train_scene, estimate(plan, set, train_scene, fold.discrepancy)), components, lights);
              r.floor_d65_a = floor;
            }
            runs.push_back(std::move(r));
          }
    std::fprintf(stderr, "fold %d of %d done\n", f + 1, folds);
  }

  std::filesystem::create_directories(out);
  std::ofstream csv(std::filesystem::path(out) / "seed_study.csv");
  csv << "plan,scene,noise_scale,seed,fold,flagged,order4";
  for (const auto& l : lights) csv << ",de94_" << l.name;
  csv << ",noise_log10_cm,noise_log10_ch,noise_bm,noise_che,floor_d65_a";
  for (int k : components) csv << ",corrected_d65_a_k" << k;
  csv << ",chosen_k,corrected_chosen_d65_a";
  csv << "\n";
  for (const Run& r : runs) {
    csv << r.plan << "," << r.scene << "," << r.noise_scale << "," << r.seed << "," << r.fold << "," << r.flagged << "," << r.order4;
    for (double v : r.de) csv << "," << v;
    for (double v : r.parameter_noise) csv << "," << v;
    csv << "," << r.floor_d65_a;
    for (std::size_t k = 0; k < components.size(); ++k) csv << "," << (r.corrected_d65_a.empty() ? std::nan("") : r.corrected_d65_a[k]);
    csv << "," << r.chosen_components << "," << r.corrected_chosen_d65_a;
    csv << "\n";
  }
  csv.close();

  std::printf("seed_study_bench: %d folds by subject x %zu seeds, %d px per held-out subject, noise scales", folds, seeds.size(), patch);
  for (double s : noise_scales) std::printf(" %.2f", s);
  std::printf(", product estimator (fast inverter, auto order, learned discrepancy of the fold's training subjects)\n");
  auto select = [&](const std::string& plan, const std::string& scene, double scale) {
    std::vector<Run> mine;
    for (const Run& r : runs)
      if (r.plan == plan && r.scene == scene && r.noise_scale == scale) mine.push_back(r);
    return mine;
  };
  std::vector<std::string> study_names;
  for (const Plan& p : plan_list)
    if (p.own >= 0) study_names.push_back(p.name);
  std::map<std::string, int> own_of;
  for (const Plan& p : plan_list) own_of[p.name] = p.own;

  for (double scale : noise_scales)
    for (const std::string scene : {"flat", "spread"}) {
      std::printf("\n== part 1: the broadband study, %s scene, noise x%.2f: relit ΔE94, mean over %d folds x %zu seeds ==\n",
                  scene.c_str(), scale, folds, seeds.size());
      std::printf("%-9s", "plan");
      for (const auto& l : lights) std::printf(" %6s", l.name.c_str());
      std::printf("  %-22s %-22s %6s %6s %7s %7s %7s %7s\n", "own [min, max]", "others [min, max]", "flag%", "ord4%", "sdlgCm",
                  "sdlgCh", "sdBm", "sdChe");
      for (const std::string& name : study_names) {
        const auto mine = select(name, scene, scale);
        std::printf("%-9s", name.c_str());
        for (int l = 0; l < kIlluminants; ++l) std::printf(" %6.3f", spread(mine, [l](const Run& r) { return r.de[l]; }).mean);
        const int own = own_of[name];
        std::printf("  %-22s %-22s %6.2f %6.1f %7.4f %7.4f %7.4f %7.4f\n",
                    text(spread(mine, [own](const Run& r) { return r.de[own]; })).c_str(),
                    text(spread(mine, [own](const Run& r) { return others(r.de, own); })).c_str(),
                    100 * spread(mine, [](const Run& r) { return r.flagged; }).mean,
                    100 * spread(mine, [](const Run& r) { return r.order4; }).mean,
                    spread(mine, [](const Run& r) { return r.parameter_noise[0]; }).mean,
                    spread(mine, [](const Run& r) { return r.parameter_noise[1]; }).mean,
                    spread(mine, [](const Run& r) { return r.parameter_noise[2]; }).mean,
                    spread(mine, [](const Run& r) { return r.parameter_noise[3]; }).mean);
      }
      std::printf("\nrelit ΔE94 under the others, per skin-tone quartile (ITA° of the spectrum under D65; Q1 lightest):\n%-9s",
                  "plan");
      for (int t = 0; t < kTones; ++t) std::printf("      Q%d", t + 1);
      std::printf("\n");
      for (const std::string& name : study_names) {
        const auto mine = select(name, scene, scale);
        const int own = own_of[name];
        std::printf("%-9s", name.c_str());
        for (int t = 0; t < kTones; ++t) {
          double sum = 0;
          int n = 0;
          for (const Run& r : mine)
            if (const double v = others(r.de_tone[t], own); std::isfinite(v)) sum += v, ++n;
          std::printf("  %6.3f", n ? sum / n : std::nan(""));
        }
        std::printf("\n");
      }

      // The seed's claims, each against the runs (fold x seed) where it holds.
      auto runs_where = [&](auto holds) {
        const auto a = select("W57", scene, scale);
        int n = 0;
        for (std::size_t k = 0; k < a.size(); ++k) n += holds(k);
        return std::to_string(n) + "/" + std::to_string(a.size());
      };
      auto at = [&](const std::string& plan, std::size_t k) { return select(plan, scene, scale)[k]; };
      auto gen = [&](const std::string& plan, std::size_t k) { return others(at(plan, k).de, own_of[plan]); };
      std::printf("\nthe seed's claims (%s scene, noise x%.2f), runs where each holds:\n", scene.c_str(), scale);
      std::printf("  1. generalisation W57 < W40 < W27 (ΔE94 under the others): %s\n",
                  runs_where([&](std::size_t k) { return gen("W57", k) < gen("W40", k) && gen("W40", k) < gen("W27", k); }).c_str());
      std::printf("  1'. per tone quartile, W57 < W40 < W27 in the mean:");
      for (int t = 0; t < kTones; ++t) {
        auto tone_gen = [&](const std::string& plan) {
          double sum = 0;
          int n = 0;
          for (const Run& r : select(plan, scene, scale))
            if (const double v = others(r.de_tone[t], own_of[plan]); std::isfinite(v)) sum += v, ++n;
          return sum / n;
        };
        std::printf(" Q%d %s", t + 1, tone_gen("W57") < tone_gen("W40") && tone_gen("W40") < tone_gen("W27") ? "yes" : "no");
      }
      std::printf("\n");
      for (const std::string b : {"W57", "W40", "W27"}) {
        std::printf("  2. %s's own illuminant is its best of the nine: %s; of W57/W40/W27 plans under %s, %s is best: %s\n",
                    b.c_str(), runs_where([&](std::size_t k) {
                      const auto& de = at(b, k).de;
                      return std::min_element(de.begin(), de.end()) - de.begin() == own_of[b];
                    }).c_str(),
                    b.c_str(), b.c_str(), runs_where([&](std::size_t k) {
                      const int l = own_of[b];
                      return at(b, k).de[l] <= std::min({at("W57", k).de[l], at("W40", k).de[l], at("W27", k).de[l]});
                    }).c_str());
      }
      std::printf("  3. D65' generalises better than W57 (others): %s; on the illuminants own to neither (W40, W27, R, G, B, D65, A): %s\n",
                  runs_where([&](std::size_t k) { return gen("D65'", k) < gen("W57", k); }).c_str(),
                  runs_where([&](std::size_t k) {
                    double d = 0, w = 0;
                    for (int l : {1, 2, 3, 4, 5, 7, 8}) d += at("D65'", k).de[l], w += at("W57", k).de[l];
                    return d < w;
                  }).c_str());
      for (const std::string b : {"W57", "D65'"})
        std::printf("  4. %s+blue has less parameter noise than %s (all four): %s; lower relit ΔE94 under the others: %s\n", b.c_str(),
                    b.c_str(), runs_where([&](std::size_t k) {
                      for (int p = 0; p < 4; ++p)
                        if (!(at(b + "+blue", k).parameter_noise[p] < at(b, k).parameter_noise[p])) return false;
                      return true;
                    }).c_str(),
                    runs_where([&](std::size_t k) { return gen(b + "+blue", k) < gen(b, k); }).c_str());
      std::printf("  5. D65'+blue has less parameter noise than W57+blue (all four): %s; generalises better: %s\n",
                  runs_where([&](std::size_t k) {
                    for (int p = 0; p < 4; ++p)
                      if (!(at("D65'+blue", k).parameter_noise[p] < at("W57+blue", k).parameter_noise[p])) return false;
                    return true;
                  }).c_str(),
                  runs_where([&](std::size_t k) { return gen("D65'+blue", k) < gen("W57+blue", k); }).c_str());

      const auto six = select("six-leds", scene, scale);
      std::printf("\n== part 2: past the model's floor, six LEDs (18 channels), %s scene, noise x%.2f ==\n", scene.c_str(), scale);
      std::printf("relit ΔE94 mean(D65, A) on held-out subjects, mean [min, max] over folds x seeds:\n");
      std::printf("  4D full-spectrum fit (the floor): %s\n", text(spread(six, [](const Run& r) { return r.floor_d65_a; })).c_str());
      std::printf("  4D estimate from 18 channels:     %s\n", text(spread(six, [](const Run& r) { return mean_d65_a(r.de); })).c_str());
      for (std::size_t k = 0; k < components.size(); ++k) {
        const Spread c = spread(six, [k](const Run& r) { return r.corrected_d65_a[k]; });
        const Spread below = spread(six, [k](const Run& r) { return 1 - r.corrected_d65_a[k] / r.floor_d65_a; });
        std::printf("  corrected, %d basis spectra:      %s   below the floor by %s%%\n", components[k], text(c).c_str(),
                    text(below, 100).c_str());
      }
      {
        const Spread c = spread(six, [](const Run& r) { return r.corrected_chosen_d65_a; });
        const Spread below = spread(six, [](const Run& r) { return 1 - r.corrected_chosen_d65_a / r.floor_d65_a; });
        const Spread k = spread(six, [](const Run& r) { return double(r.chosen_components); });
        std::printf("  corrected, k by inner CV (%.0f-%.0f): %s   below the floor by %s%%\n", k.lo, k.hi, text(c).c_str(),
                    text(below, 100).c_str());
      }
    }

  write_study_chart(std::filesystem::path(out) / "seed_study.png", runs, study_names, lights, "flat", noise_scales.front());
  std::vector<Bar> bars;
  const auto six = select("six-leds", "flat", noise_scales.front());
  bars.push_back({"4D full-spectrum fit (floor)", spread(six, [](const Run& r) { return r.floor_d65_a; }).mean});
  bars.push_back({"4D estimate (18 ch)", spread(six, [](const Run& r) { return mean_d65_a(r.de); }).mean});
  for (std::size_t k = 0; k < components.size(); ++k)
    bars.push_back({"corrected, k=" + std::to_string(components[k]), spread(six, [k](const Run& r) { return r.corrected_d65_a[k]; }).mean});
  bars.push_back({"corrected, k by inner CV", spread(six, [](const Run& r) { return r.corrected_chosen_d65_a; }).mean});
  const auto png = std::filesystem::path(out) / "past_floor.png";
  if (write_bar_chart(png, "past the model floor: six LEDs, held-out NIST skin (flat scene)", "relit ΔE94, mean of D65 and A", bars))
    std::printf("chart: %s\n", png.c_str());
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) { return chromo::bench::guarded_main("seed_study_bench", chromo::bench::run, argc, argv); }
