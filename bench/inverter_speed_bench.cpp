// Speed against accuracy of every inverter on every plan (issue 39, items 1,
// 2 and 4), side by side in one run:
//  - plans: the method's 4 channels, four LEDs one at a time (W57, red,
//    green, blue: 12), the six LEDs one at a time (18), the six LEDs and the
//    method's three mixes (D65', W57, W57+blue: 27);
//  - inverters: the exhaustive search (the reference, on a fixed sample of
//    every k-th pixel), today's fast inverter and the subspace inverter,
//    with the auto model and 4D;
//  - scenes: skin rendered by the model (parameter box, seeds) and real skin
//    (NIST forearm spectra held out by subject: fold = seed mod 5, the
//    discrepancy learned from the other 40), each with 4% tattoo ink and 4%
//    marker, noisy (four frames of a 40,000 e⁻ sensor, each capture exposed
//    to full scale) and noise-free (the same noise declared);
//  - per run: wall pixels/s of Estimator::estimate on 2 threads and CPU µs
//    per pixel, relit ΔE94 (mean of D65 and A) of every skin pixel of the
//    sample (a flagged one by its best fit; the same pixels for every
//    inverter) and of the whole frame, skin flagged and ink+marker caught;
//    the accuracy rule: subspace within 1.05× or 0.005 of the exhaustive
//    search on the same pixels;
//  - table set-up: the forward table's build and the subspace table's per plan;
//  - growth with channels: the inverter alone (4D fit, one thread, CPU µs per
//    skin cell) for each plan, and its ratio to the method's 4 channels.
//
//   inverter_speed_bench [--seeds 11,12] [--pixels 6000] [--exhaustive-every 30] [--out DIR]
//
// Writes DIR/inverter_speed.csv, DIR/inverter_speed.png (relit ΔE94 against
// pixels/s) and DIR/inverter_channels.png (µs per cell against channels).
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench_cli.hpp"

#include "chart.hpp"
#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/estimation/subspace_table.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/colorimetry.hpp"
#include "chromo/spectral/delta_e.hpp"
#include "chromo/spectral/lab_illuminants.hpp"
#include "clocks.hpp"
#include "guarded_main.hpp"
#include "real_skin_camera.hpp"
#include "seed_spread.hpp"

namespace chromo::bench {
namespace {

using estimation::InverterMethod;
using estimation::ModelChoice;
using simulators::SyntheticKind;
constexpr int kFolds = 5;

spectral::Spectrum led(spectral::LedType t) { return spectral::led_spectrum(t); }

std::vector<RealSkinPlan> make_plans(const std::vector<std::string>& only) {
  using spectral::LedType;
  const spectral::CameraSensitivity camera = spectral::builtin_camera("nikon_d5100");
  std::vector<std::pair<std::string, spectral::Spectrum>> four, six;
  for (LedType t : {LedType::kW57, LedType::kRed, LedType::kGreen, LedType::kBlue})
    four.emplace_back(std::string(spectral::led_type_name(t)), led(t));
  for (auto t : spectral::kAllLedTypes) six.emplace_back(std::string(spectral::led_type_name(t)), led(t));
  auto all = six;
  all.emplace_back("D65'", spectral::led_d65_metamer());
  all.emplace_back("W57-mix", led(LedType::kW57));
  all.emplace_back("W57+blue", led(LedType::kW57) + led(LedType::kBlue));
  std::vector<RealSkinPlan> plans{
      {"method", estimation::method_measurement_set(camera, spectral::led_d65_metamer(), led(LedType::kBlue))},
      {"four-leds", simulators::capture_measurement_set(camera, four)},
      {"six-leds", simulators::capture_measurement_set(camera, six)},
      {"six-leds+method", simulators::capture_measurement_set(camera, all)}};
  if (!only.empty()) {
    std::erase_if(plans, [&](const RealSkinPlan& p) { return std::find(only.begin(), only.end(), p.name) == only.end(); });
    if (plans.empty()) throw std::invalid_argument("--plans: no known plan named");
  }
  for (RealSkinPlan& p : plans) {
    const auto start = std::chrono::steady_clock::now();
    p.table = std::make_shared<const estimation::ForwardTable>(estimation::ForwardTable::build(p.set, {}, 2));
    p.table_build_s = seconds_since(start);
    std::vector<double> sigma;
    for (const auto& c : p.set.channels) sigma.push_back(std::sqrt(c.noise.variance(0.2)));
    const auto sub_start = std::chrono::steady_clock::now();
    const estimation::SubspaceTable subspace(p.table, sigma, 2);
    p.subspace_build_s = seconds_since(sub_start);
    std::fprintf(stderr, "%s: %d channels, forward table %.2f s, subspace table %.2f s (captured %.9f, off %.3f sigma)\n",
                 p.name.c_str(), p.set.size(), p.table_build_s, p.subspace_build_s, subspace.captured_variance(),
                 subspace.off_subspace_rms());
  }
  return plans;
}

spectral::Lab lab_under(const spectral::Spectrum& albedo, const spectral::Spectrum& light) {
  return spectral::lab_from_xyz(spectral::xyz_of_reflectance(albedo, light), spectral::white_point(light));
}

struct Scene {
  simulators::SyntheticFrame frame;
  std::vector<float> measured;
  std::vector<spectral::Spectrum> spectra;  // real skin: the held-out spectra
  std::shared_ptr<const estimation::ModelDiscrepancy> discrepancy;
  std::vector<std::size_t> sample;          // the exhaustive search's pixels
  std::vector<spectral::Lab> truth_d65, truth_a;  // per pixel (skin only)
};

struct Run {
  std::string plan, scene, noise, inverter, model;
  std::uint64_t seed = 0;
  int channels = 0;
  double pixels_per_s = 0, cpu_us_per_pixel = 0;
  double de_sample = 0, de_frame = 0;  // relit ΔE94 (D65+A)/2 on skin
  double skin_flagged = 0, ink_caught = 0;
};

double relit(const estimation::PixelEstimate& e, const Scene& s, std::size_t i) {
  static const estimation::SkinModel model;
  const spectral::Spectrum fitted = model.albedo(e.parameters);
  return 0.5 * (spectral::delta_e94(s.truth_d65[i], lab_under(fitted, spectral::illuminant_d65())) +
                spectral::delta_e94(s.truth_a[i], lab_under(fitted, spectral::illuminant_a())));
}

estimation::SubspaceInverterOptions subspace_options;  // --polish-steps, --subspace-steps

Run run_inverter(const RealSkinPlan& plan, const estimation::MeasurementSet& set, const Scene& s, InverterMethod method,
                 ModelChoice model) {
  estimation::EstimatorOptions options;
  options.subspace = subspace_options;
  options.subspace_beyond_four_channels = false;  // "fast" is today's fast inverter here
  options.threads = 2;
  options.method = method;
  options.model = model;
  options.discrepancy = s.discrepancy;
  const estimation::Estimator estimator(plan.table, set, options);
  const int c_count = set.size();
  const bool exhaustive = method == InverterMethod::kExhaustive;
  std::vector<float> input;
  std::vector<std::size_t> pixels;
  if (exhaustive) {
    for (std::size_t i : s.sample) {
      input.insert(input.end(), s.measured.begin() + i * c_count, s.measured.begin() + (i + 1) * c_count);
      pixels.push_back(i);
    }
  } else {
    input = s.measured;
    for (std::size_t i = 0; i < s.frame.pixels(); ++i) pixels.push_back(i);
  }
  std::vector<estimation::PixelEstimate> out(pixels.size());
  const double cpu0 = process_cpu_seconds();
  const auto start = std::chrono::steady_clock::now();
  estimator.estimate(input, out);
  const double wall = seconds_since(start), cpu = process_cpu_seconds() - cpu0;
  Run r;
  r.inverter = std::string(estimation::method_name(method));
  r.model = std::string(estimation::model_name(model));
  r.channels = c_count;
  r.pixels_per_s = pixels.size() / wall;
  r.cpu_us_per_pixel = 1e6 * cpu / pixels.size();
  std::map<std::size_t, std::size_t> position;
  for (std::size_t k = 0; k < pixels.size(); ++k) position[pixels[k]] = k;
  std::size_t skin = 0, flagged = 0, ink = 0, caught = 0, sample_skin = 0;
  for (std::size_t k = 0; k < pixels.size(); ++k) {
    const std::size_t i = pixels[k];
    const bool is_flagged = out[k].flag != estimation::PixelFlag::kExplained;
    const SyntheticKind kind = s.frame.kind[i];
    if (kind == SyntheticKind::kTattoo || kind == SyntheticKind::kMarker) ++ink, caught += is_flagged;
    if (kind != SyntheticKind::kSkin) continue;
    ++skin, flagged += is_flagged;
    r.de_frame += relit(out[k], s, i);
  }
  for (std::size_t i : s.sample) {
    if (s.frame.kind[i] != SyntheticKind::kSkin) continue;
    ++sample_skin;
    r.de_sample += relit(out[position.at(i)], s, i);
  }
  r.de_frame /= std::max<std::size_t>(skin, 1);
  r.de_sample /= std::max<std::size_t>(sample_skin, 1);
  r.skin_flagged = double(flagged) / std::max<std::size_t>(skin, 1);
  r.ink_caught = double(caught) / std::max<std::size_t>(ink, 1);
  return r;
}

// CPU µs per skin cell of the inverter alone (4D fits, this thread).
double inverter_us(const RealSkinPlan& plan, const estimation::MeasurementSet& set, const Scene& s, InverterMethod method,
                   int cells) {
  estimation::EstimatorOptions options;
  options.subspace = subspace_options;
  options.subspace_beyond_four_channels = false;
  options.threads = 1;
  options.method = method;
  options.model = ModelChoice::k4d;
  options.discrepancy = s.discrepancy;
  const estimation::Estimator estimator(plan.table, set, options);
  const int c_count = set.size();
  std::vector<double> m(c_count), w(c_count);
  int done = 0, iterations = 0;
  double sink = 0;
  const double t0 = thread_cpu_seconds();
  for (std::size_t i = 0; i < s.frame.pixels() && done < cells; ++i) {
    if (s.frame.kind[i] != SyntheticKind::kSkin) continue;
    for (int c = 0; c < c_count; ++c) m[c] = s.measured[i * c_count + c], w[c] = estimator.weight(c, m[c]);
    const estimation::Fit f = estimator.inverter().fit(m.data(), w.data(), 4);
    sink += f.chi2, iterations += f.iterations;
    ++done;
  }
  std::printf("%s on %s: %.2f iterations per fit (its last stage's)\n",
               std::string(estimation::method_name(method)).c_str(), plan.name.c_str(), double(iterations) / std::max(done, 1));
  const double us = 1e6 * (thread_cpu_seconds() - t0) / std::max(done, 1);
  return sink >= 0 ? us : -us;
}

Scene make_scene(const estimation::MeasurementSet& set, bool real, bool noisy, std::uint64_t seed, int pixels,
                 int exhaustive_every) {
  Scene s;
  const auto& spectra = estimation::nist_forearm_spectra();
  const auto& residuals = estimation::nist_forearm_residuals();
  const int fold = static_cast<int>(seed % kFolds);
  std::vector<estimation::SpectrumResidual> train;
  for (std::size_t i = 0; i < spectra.size(); ++i) {
    if (static_cast<int>(i % kFolds) == fold) s.spectra.push_back(spectra[i].albedo);
    else train.push_back(residuals[i]);
  }
  s.discrepancy = std::make_shared<const estimation::ModelDiscrepancy>(estimation::ModelDiscrepancy::learn(train));
  simulators::SyntheticOptions o;
  o.seed = seed * 100 + (real ? 1 : 0);
  o.noise.noise_scale = 0;
  o.pixels = pixels;
  o.share[static_cast<int>(SyntheticKind::kTattoo)] = 0.04;
  o.share[static_cast<int>(SyntheticKind::kMarker)] = 0.04;
  if (real) o.skin_spectra = s.spectra, o.patch_pixels = std::max(1, pixels / static_cast<int>(s.spectra.size()));
  estimation::MeasurementSet render = set;
  s.frame = simulators::make_synthetic_frame(render, o);
  s.measured = noisy ? simulators::add_channel_noise(s.frame.clean, set, o.seed * 7919 + 1) : s.frame.clean;
  for (std::size_t i = 0; i < s.frame.pixels(); i += exhaustive_every) s.sample.push_back(i);
  static const estimation::SkinModel model;
  s.truth_d65.resize(s.frame.pixels()), s.truth_a.resize(s.frame.pixels());
  for (std::size_t i = 0; i < s.frame.pixels(); ++i) {
    if (s.frame.kind[i] != SyntheticKind::kSkin) continue;
    const spectral::Spectrum truth = real ? spectral::Spectrum(s.spectra[s.frame.spectrum_index[i]].values() * s.frame.skin_scale[i])
                                          : model.albedo(s.frame.truth[i]);
    s.truth_d65[i] = lab_under(truth, spectral::illuminant_d65());
    s.truth_a[i] = lab_under(truth, spectral::illuminant_a());
  }
  return s;
}

int run(int argc, char** argv) {
  CLI::App app{"speed against relit accuracy of every inverter on every plan (issue 39)"};
  std::vector<std::uint64_t> seeds{11, 12};
  int pixels = 6000, exhaustive_every = 30, inverter_cells = 2000;
  std::string out = "bench/results";
  app.add_option("--seeds", seeds, "scene seeds (real skin: fold = seed mod 5 held out)")->delimiter(',');
  app.add_option("--pixels", pixels, "pixels per scene")->check(CLI::Range(200, 10000000));
  app.add_option("--exhaustive-every", exhaustive_every, "the exhaustive search's sample: every k-th pixel")
      ->check(CLI::Range(1, 100000));
  app.add_option("--inverter-cells", inverter_cells, "skin cells timed for the inverter alone")->check(CLI::Range(10, 1000000));
  app.add_option("--out", out, "output directory");
  std::vector<std::string> plan_names;
  app.add_option("--plans", plan_names, "plans to run (default all: method, four-leds, six-leds, six-leds+method)")->delimiter(',');
  app.add_option("--polish-steps", subspace_options.polish_steps, "the subspace inverter's polish steps");
  app.add_option("--subspace-steps", subspace_options.subspace_steps, "the subspace inverter's Gauss-Newton steps in the subspace");
  bool inverter_only = false;
  std::vector<std::string> timed{"fast", "subspace"};
  app.add_option("--timed-inverters", timed, "inverters timed alone (fast, subspace)")->delimiter(',');
  app.add_flag("--inverter-only", inverter_only, "only the inverter alone per plan (for a profiler)");
  CLI11_PARSE(app, argc, argv);

  std::vector<RealSkinPlan> plans = make_plans(plan_names);
  std::vector<Run> runs;
  std::map<std::string, std::map<std::string, std::vector<double>>> channel_us;  // inverter -> plan -> µs per seed
  for (const RealSkinPlan& plan : plans) {
    estimation::MeasurementSet set = plan.set;
    simulators::set_exposure_noise(set, real_skin_camera_noise(1.0));
    for (std::uint64_t seed : seeds)
      for (const bool real : {false, true})
        for (const bool noisy : {true, false}) {
          const Scene scene = make_scene(set, real, noisy, seed, pixels, exhaustive_every);
          if (!real && noisy)
            for (InverterMethod m : {InverterMethod::kFast, InverterMethod::kSubspace})
              if (std::count(timed.begin(), timed.end(), std::string(estimation::method_name(m))))
              channel_us[std::string(estimation::method_name(m))][plan.name].push_back(
                  inverter_us(plan, set, scene, m, inverter_cells));
          if (inverter_only) continue;
          for (ModelChoice model : {ModelChoice::kAuto, ModelChoice::k4d})
            for (InverterMethod m : {InverterMethod::kExhaustive, InverterMethod::kFast, InverterMethod::kSubspace}) {
              Run r = run_inverter(plan, set, scene, m, model);
              r.plan = plan.name, r.scene = real ? "real" : "model", r.noise = noisy ? "noisy" : "noise-free", r.seed = seed;
              runs.push_back(r);
            }
          std::fprintf(stderr, "%s seed %llu %s %s done\n", plan.name.c_str(), static_cast<unsigned long long>(seed),
                       real ? "real" : "model", noisy ? "noisy" : "noise-free");
        }
  }

  std::printf("inverter_speed_bench: %d pixels per scene (4%% ink, 4%% marker), exhaustive on every %d-th pixel, seeds",
              pixels, exhaustive_every);
  for (auto s : seeds) std::printf(" %llu", static_cast<unsigned long long>(s));
  std::printf("; Estimator on 2 threads, no spatial pass; load average at the end: see below\n\n");
  std::printf("table set-up (this run): plan, channels, forward table s, subspace table s\n");
  for (const RealSkinPlan& p : plans)
    std::printf("  %-16s %3d  %.2f  %.2f\n", p.name.c_str(), p.set.size(), p.table_build_s, p.subspace_build_s);

  std::filesystem::create_directories(out);
  std::ofstream csv(std::filesystem::path(out) / "inverter_speed.csv");
  csv << "plan,channels,scene,noise,seed,inverter,model,pixels_per_s,cpu_us_per_pixel,de94_sample,de94_frame,skin_flagged,"
         "ink_caught\n";
  std::printf("\n%-16s %-5s %-10s %4s %-10s %-4s %11s %9s %9s %9s %7s %7s\n", "plan", "scene", "noise", "seed", "inverter",
              "model", "pixels/s", "cpu us/px", "dE sample", "dE frame", "skin%", "ink%");
  for (const Run& r : runs) {
    std::printf("%-16s %-5s %-10s %4llu %-10s %-4s %11.0f %9.2f %9.4f %9.4f %7.2f %7.1f\n", r.plan.c_str(), r.scene.c_str(),
                r.noise.c_str(), static_cast<unsigned long long>(r.seed), r.inverter.c_str(), r.model.c_str(),
                r.pixels_per_s, r.cpu_us_per_pixel, r.de_sample, r.de_frame, 100 * r.skin_flagged, 100 * r.ink_caught);
    csv << r.plan << "," << r.channels << "," << r.scene << "," << r.noise << "," << r.seed << "," << r.inverter << ","
        << r.model << "," << r.pixels_per_s << "," << r.cpu_us_per_pixel << "," << r.de_sample << "," << r.de_frame << ","
        << r.skin_flagged << "," << r.ink_caught << "\n";
  }

  // The accuracy rule per (plan, scene, noise, model), over seeds: subspace
  // and fast against the exhaustive search on the same pixels.
  std::printf("\naccuracy rule (same sample pixels): within max(1.05 x exhaustive, exhaustive + 0.005); speed ratios "
              "subspace/fast in pixels/s; mean [min, max] over seeds\n");
  std::printf("%-16s %-5s %-10s %-4s %-26s %-26s %-26s %-6s %-24s\n", "plan", "scene", "noise", "model", "dE exhaustive",
              "dE fast", "dE subspace", "rule", "speed subspace/fast");
  std::map<std::string, std::vector<std::pair<double, double>>> chart;  // inverter -> (pixels/s, dE) per plan
  bool all_met = true;
  for (const RealSkinPlan& p : plans)
    for (const std::string scene : inverter_only ? std::vector<std::string>{} : std::vector<std::string>{"model", "real"})
      for (const std::string noise : {"noisy", "noise-free"})
        for (const std::string model : {"auto", "4d"}) {
          std::vector<const Run*> e, f, s;
          for (const Run& r : runs)
            if (r.plan == p.name && r.scene == scene && r.noise == noise && r.model == model)
              (r.inverter == "exhaustive" ? e : r.inverter == "fast" ? f : s).push_back(&r);
          auto de = [](const std::vector<const Run*>& v) { return spread(v, [](const Run* r) { return r->de_sample; }); };
          std::vector<double> ratio;
          bool met = true;
          for (std::size_t k = 0; k < s.size(); ++k) {
            ratio.push_back(s[k]->pixels_per_s / f[k]->pixels_per_s);
            met = met && s[k]->de_sample <= std::max(1.05 * e[k]->de_sample, e[k]->de_sample + 0.005);
          }
          all_met = all_met && met;
          const Spread se = de(e), sf = de(f), ss = de(s);
          const Spread sr = spread(ratio, [](double v) { return v; });
          char a[64], b[64], c[64], d[64];
          std::snprintf(a, sizeof a, "%.4f [%.4f, %.4f]", se.mean, se.lo, se.hi);
          std::snprintf(b, sizeof b, "%.4f [%.4f, %.4f]", sf.mean, sf.lo, sf.hi);
          std::snprintf(c, sizeof c, "%.4f [%.4f, %.4f]", ss.mean, ss.lo, ss.hi);
          std::snprintf(d, sizeof d, "%.2f [%.2f, %.2f]", sr.mean, sr.lo, sr.hi);
          std::printf("%-16s %-5s %-10s %-4s %-26s %-26s %-26s %-6s %-24s\n", p.name.c_str(), scene.c_str(), noise.c_str(),
                      model.c_str(), a, b, c, met ? "met" : "MISSED", d);
          if (model == "auto" && noise == "noisy")
            for (const auto* v : {&f, &s}) {
              const Spread px = spread(*v, [](const Run* r) { return r->pixels_per_s; });
              const Spread dv = spread(*v, [](const Run* r) { return r->de_frame; });
              chart[(*v)[0]->inverter + " " + scene].emplace_back(px.mean, dv.mean);
            }
        }
  std::printf("accuracy rule on every plan, scene, noise and model: %s\n", all_met ? "met" : "NOT met");

  std::printf("\nthe inverter alone, 4D fits of noisy model skin, one thread, CPU us per cell: mean [min, max] over seeds\n");
  std::vector<LineSeries> growth;
  for (const auto& [inverter, per_plan] : channel_us) {
    LineSeries line{inverter, {}};
    const double base = spread(per_plan.at(plans.front().name), [](double v) { return v; }).mean;
    for (const RealSkinPlan& p : plans) {
      const Spread u = spread(per_plan.at(p.name), [](double v) { return v; });
      line.points.emplace_back(p.set.size(), u.mean);
      std::printf("%-10s %-16s %3d channels: %7.2f [%7.2f, %7.2f] us per cell, %.2fx the %s plan's\n", inverter.c_str(),
                  p.name.c_str(), p.set.size(), u.mean, u.lo, u.hi, u.mean / base, plans.front().name.c_str());
    }
    growth.push_back(line);
  }
  if (channel_us.size() == 2)
    for (const RealSkinPlan& p : plans)
      std::printf("subspace / fast on %-16s: %.3f\n", p.name.c_str(),
                  spread(channel_us["subspace"][p.name], [](double v) { return v; }).mean /
                      spread(channel_us["fast"][p.name], [](double v) { return v; }).mean);
  std::ifstream load("/proc/loadavg");
  std::string load_text;
  std::getline(load, load_text);
  std::printf("load average at the end: %s\n", load_text.c_str());

  std::vector<LineSeries> speed;
  for (auto& [name, points] : chart)
    if (!points.empty()) speed.push_back({name, points});
  const auto png = std::filesystem::path(out) / "inverter_speed.png";
  if (write_line_chart(png, "relit dE94 (D65, A) of noisy skin against pixels/s, auto model; points: plans of 4-27 channels",
                       "pixels per second (2 threads)", "relit dE94", speed, true))
    std::printf("chart: %s\n", png.c_str());
  const auto png2 = std::filesystem::path(out) / "inverter_channels.png";
  if (write_line_chart(png2, "the inverter alone: CPU us per skin cell (4D, one thread)", "channels", "us per cell", growth))
    std::printf("chart: %s\n", png2.c_str());
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) { return chromo::bench::guarded_main("inverter_speed_bench", chromo::bench::run, argc, argv); }
