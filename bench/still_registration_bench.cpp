// Registration of a still subject, and of one moved by a known sub-pixel
// shift (issues 37 and 39): real-skin scenes (`chromo make-real-skin-scene`'s:
// NIST forearms as textured patches with ink and marker), rendered noise-free,
// every capture after the first moved by t · (0.8, 0.6) px (t = 0: still),
// then the declared noise of four frames of a 40,000 e⁻ sensor added
// (still_scene_captures.hpp), registered as `chromo estimate` registers a
// MEASUREMENT.json (session::register_images), side by side in one run:
//   before: ECC alone (RegistrationOptions::tile_consensus off, the default
//           until still37d), one round on every pixel;
//   after:  the tile consensus (the default since still37d) deciding still or moved and
//           checking ECC's warp (src/tile_motion.hpp);
//   --robust-trial: also the opt-in robust round without the tiles
//           (exclude_photometric_outliers: the pixels whose ratio between the
//           captures departs from their one gain left out), as "robust";
//   --signal-trial: also the opt-in still decision on the channel less its
//           local mean (RegistrationSignal::kLessLocalMean, --sigma), as "local-mean".
// Per plan, subject set, seed and motion: the wall time of registering every
// image, the captures warped, the largest corner motion found, the largest
// corner error of what was applied (the identity when not warped) against
// the true motion, the largest registration noise, the largest share of a
// capture's pixels left out by the robust round, and the pixels left
// non-finite; then the spread (mean [min, max]) over subject sets and seeds.
//
// --cause: why a still scene moves (before): the six-LED scene of subjects
// 041-050, seed 1, still, and the same scene without its ink and marker, with
// one subject's spectrum in every patch (no colour edges between patches),
// and both: each capture's shift, rotation and corner motion.
//
//   still_registration_bench [--seeds 1,2,3] [--subjects 041-050,021-030,001-010] [--patch 128]
//                            [--plans method,six-leds] [--motions 0,0.2,0.4,1] [--sigma 8] [--variants before,after] [--robust-trial] [--signal-trial] [--cause]
//                            [--out DIR] [--no-chart]
//
// Writes DIR/still_registration.csv and DIR/still_registration.png (largest
// corner error per plan, motion and variant; DIR: bench/results).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "bench_cli.hpp"
#include <unistd.h>

#include "chart.hpp"
#include "clocks.hpp"
#include "guarded_main.hpp"
#include "seed_spread.hpp"
#include "still_scene_captures.hpp"
#include "chromo/simulators/scene/real_skin_scene.hpp"

namespace chromo::bench {
namespace {

namespace fs = std::filesystem;
using session::RegistrationSignal;

struct Run {
  std::string plan, subjects, variant;
  std::uint64_t seed = 0;
  double motion_px = 0;
  double seconds = 0, largest_found_px = 0, largest_error_px = 0, largest_noise_px = 0, largest_outlier_share = 0;
  int warped = 0, captures = 0;
  std::size_t non_finite_pixels = 0;
};

// Pixels with any non-finite channel in the measurement as registered.
std::size_t non_finite_pixels(const session::MeasurementFile& m) {
  const std::vector<float> values = m.pixel_major();
  const std::size_t n = static_cast<std::size_t>(m.width) * m.height, channels = values.size() / n;
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i)
    count += std::any_of(values.begin() + i * channels, values.begin() + (i + 1) * channels,
                         [](float v) { return !std::isfinite(v); });
  return count;
}

double g_local_mean_sigma_px = session::RegistrationOptions{}.local_mean_sigma_px;  // --sigma

// The registration options of a variant: "before" (the default: one round,
// no tile consensus), "after" (the opt-in tile consensus), "robust" (before + the opt-in robust round) or "local-mean".
session::RegistrationOptions variant_options(const std::string& variant) {
  session::RegistrationOptions options;
  options.tile_consensus = variant == "after";
  if (variant == "robust") options.exclude_photometric_outliers = true;
  if (variant == "local-mean") {
    options.exclude_photometric_outliers = false;
    options.signal = RegistrationSignal::kLessLocalMean;
    options.local_mean_sigma_px = g_local_mean_sigma_px;
  }
  return options;
}

Run register_captures(session::MeasurementFile m, const std::string& variant, double tx, double ty) {
  const session::RegistrationOptions options = variant_options(variant);
  Run run;
  run.variant = variant;
  const auto start = std::chrono::steady_clock::now();
  const std::vector<session::RegistrationReport> reports = session::register_images(m, options);
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const auto& r : reports) {
    run.warped += r.warped, ++run.captures;
    run.largest_found_px = std::max(run.largest_found_px, r.motion_px);
    run.largest_error_px = std::max(run.largest_error_px, corner_error_px(r, m.width, m.height, tx, ty));
    run.largest_noise_px = std::max(run.largest_noise_px, r.result.motion_noise_px);
    run.largest_outlier_share = std::max(run.largest_outlier_share, r.result.photometric_outlier_share);
  }
  run.non_finite_pixels = non_finite_pixels(m);
  return run;
}

// The scene's noise-free MEASUREMENT.json, read back.
session::MeasurementFile clean_scene(const fs::path& dir, simulators::RealSkinSceneOptions scene) {
  scene.noise_scale = 0;
  simulators::write_real_skin_scene(dir, scene);
  session::MeasurementFile m = session::read_measurement_file(dir / "MEASUREMENT.json");
  fs::remove_all(dir);
  return m;
}

// --cause: each capture's registration of a still six-LED scene and of the same without its edges.
void print_cause(const fs::path& scratch, int patch_px) {
  std::printf("\ncause: six LEDs, subjects 041-050, seed 1, still, patch %d px; per capture: shift x, y (px), "
              "rotation (°), corner motion (px), warped\n", patch_px);
  struct Variant {
    const char* name;
    bool anomalies, one_subject;
  };
  for (const Variant v : {Variant{"as made", true, false}, Variant{"no ink, no marker", false, false},
                          Variant{"one subject in every patch", true, true},
                          Variant{"one subject, no ink, no marker", false, true}}) {
    simulators::RealSkinSceneOptions scene;
    scene.spectra = simulators::nist_subjects("041-050");
    if (v.one_subject) std::fill(scene.spectra.begin(), scene.spectra.end(), scene.spectra.front());
    scene.patch_px = patch_px, scene.plan = "six-leds", scene.seed = 1, scene.anomalies = v.anomalies;
    const session::MeasurementFile clean = clean_scene(scratch / "cause", scene);
    for (const char* variant : {"before", "after"}) {
      session::MeasurementFile m = moved_noisy_captures(clean, 0, 0, 1);
      std::printf("  %-31s %-6s", v.name, variant);
      for (const auto& r : session::register_images(m, variant_options(variant)))
        std::printf(" | %s on %s %+.3f %+.3f %+.4f° %.3f%s out %.2f%%", r.image.c_str(), r.channel.c_str(),
                    r.result.shift_x_px, r.result.shift_y_px, r.result.rotation_deg, r.motion_px, r.warped ? " W" : "",
                    100 * r.result.photometric_outlier_share);
      std::printf("\n");
    }
  }
}

void print_spread(const std::vector<std::string>& plans, const std::vector<double>& motions, const std::vector<std::string>& variants,
                  std::map<std::tuple<std::string, double, std::string>, std::vector<Run>>& runs, std::vector<Bar>& bars) {
  for (const std::string& plan : plans)
    for (const double t : motions)
      for (const std::string& variant : variants) {
        const std::vector<Run>& rows = runs[{plan, t, variant}];
        if (rows.empty()) continue;
        const Spread s = spread(rows, [](const Run& r) { return r.seconds; });
        const Spread w = spread(rows, [](const Run& r) { return double(r.warped); });
        const Spread f = spread(rows, [](const Run& r) { return r.largest_found_px; });
        const Spread e = spread(rows, [](const Run& r) { return r.largest_error_px; });
        const Spread nf = spread(rows, [](const Run& r) { return double(r.non_finite_pixels); });
        const Spread o = spread(rows, [](const Run& r) { return 100 * r.largest_outlier_share; });
        std::printf("  %-8s t %.1f %-10s warped %.2f [%.0f, %.0f] of %d; found %.3f [%.3f, %.3f] px; error %.3f [%.3f, %.3f] px; "
                    "left out %.2f [%.2f, %.2f]%%; non-finite %.0f [%.0f, %.0f]; %.3f [%.3f, %.3f] s\n",
                    plan.c_str(), t, variant.c_str(), w.mean, w.lo, w.hi, rows.front().captures, f.mean, f.lo, f.hi, e.mean,
                    e.lo, e.hi, o.mean, o.lo, o.hi, nf.mean, nf.lo, nf.hi, s.mean, s.lo, s.hi);
        char label[64];
        std::snprintf(label, sizeof label, "%s t=%.1f %s", plan.c_str(), t, variant.c_str());
        bars.push_back({label, e.mean});
      }
}

int bench_main(int argc, char** argv) {
  CLI::App app{"registration of a still real-skin scene and of known motions, ECC alone and with the tile consensus"};
  std::vector<std::uint64_t> seeds{1, 2, 3};
  std::vector<std::string> plans{"method", "six-leds"}, subject_sets{"041-050", "021-030", "001-010"};
  std::vector<double> motions{0, 0.2, 0.4, 1.0};
  int patch_px = 128;
  fs::path out = "bench/results";
  bool no_chart = false, cause = false, signal_trial = false, robust_trial = false;
  std::vector<std::string> variants{"before", "after"};
  app.add_option("--seeds", seeds, "scene and noise seeds")->delimiter(',');
  app.add_option("--plans", plans, "method and/or six-leds")->delimiter(',');
  app.add_option("--subjects", subject_sets, "NIST subject sets, one scene each (10 patches, 5 a row)")->delimiter(',');
  app.add_option("--motions", motions, "shifts t of every capture after the first, px (along (0.8, 0.6))")->delimiter(',');
  app.add_option("--patch", patch_px, "pixels per subject's patch")->check(CLI::Range(8, 512));
  app.add_option("--sigma", g_local_mean_sigma_px, "--signal-trial: the local mean's σ, px at each pyramid level")
      ->check(CLI::Range(0.5, 100.0));
  app.add_flag("--cause", cause, "also: why a still scene moved before");
  app.add_flag("--signal-trial", signal_trial, "also: the still decision on the channel less its local mean");
  app.add_option("--variants", variants, "before and/or after (one alone: its CPU time by /usr/bin/time)")
      ->delimiter(',')->check(CLI::IsMember({"before", "after"}));
  app.add_flag("--robust-trial", robust_trial, "also: the opt-in robust round (exclude_photometric_outliers)");
  app.add_option("--out", out, "results folder");
  app.add_flag("--no-chart", no_chart, "no PNG");
  CLI11_PARSE(app, argc, argv);

  const fs::path scratch = fs::temp_directory_path() / ("still_registration_bench-" + std::to_string(::getpid()));
  if (robust_trial) variants.push_back("robust");
  if (signal_trial) variants.push_back("local-mean");
  std::printf("still_registration_bench: patch %d px, load average %.2f\n", patch_px, load_average());
  fs::create_directories(out);
  std::ofstream csv(out / "still_registration.csv");
  csv << "plan,subjects,seed,motion_px,variant,seconds,captures,warped,largest_found_px,largest_error_px,"
         "largest_noise_px,largest_outlier_share,non_finite_pixels,load_average\n";
  std::map<std::tuple<std::string, double, std::string>, std::vector<Run>> runs;
  for (const std::string& plan : plans)
    for (const std::string& subjects : subject_sets)
      for (const std::uint64_t seed : seeds) {
        simulators::RealSkinSceneOptions scene;
        scene.spectra = simulators::nist_subjects(subjects);
        scene.patch_px = patch_px, scene.plan = plan, scene.seed = seed;
        const session::MeasurementFile clean = clean_scene(scratch / "scene", scene);
        for (const double t : motions) {
          const double tx = 0.8 * t, ty = 0.6 * t;
          const session::MeasurementFile captures = moved_noisy_captures(clean, tx, ty, seed);
          for (const std::string& variant : variants) {
            Run r = register_captures(captures, variant, tx, ty);
            r.plan = plan, r.subjects = subjects, r.seed = seed, r.motion_px = t;
            std::printf("%-8s %s seed %llu t %.1f %-10s: %.3f s, %d/%d warped, found %.3f px, error %.3f px, noise %.4f px, "
                        "left out %.2f%%, %zu non-finite px\n",
                        plan.c_str(), subjects.c_str(), static_cast<unsigned long long>(seed), t, r.variant.c_str(),
                        r.seconds, r.warped, r.captures, r.largest_found_px, r.largest_error_px, r.largest_noise_px,
                        100 * r.largest_outlier_share, r.non_finite_pixels);
            csv << plan << "," << subjects << "," << seed << "," << t << "," << r.variant << "," << r.seconds << ","
                << r.captures << "," << r.warped << "," << r.largest_found_px << "," << r.largest_error_px << ","
                << r.largest_noise_px << "," << r.largest_outlier_share << "," << r.non_finite_pixels << "," << load_average() << std::endl;
            runs[{plan, t, r.variant}].push_back(r);
          }
        }
      }
  std::printf("\nspread over %zu subject set(s) × %zu seed(s), mean [min, max] (load average now %.2f):\n",
              subject_sets.size(), seeds.size(), load_average());
  std::vector<Bar> bars;
  print_spread(plans, motions, variants, runs, bars);
  if (cause) print_cause(scratch, patch_px);
  fs::remove_all(scratch);
  std::printf("\nwrote %s\n", (out / "still_registration.csv").c_str());
  if (!no_chart)
    write_bar_chart(out / "still_registration.png", "registration error of the applied warp, real-skin scenes (mean)",
                    "largest corner error, px", bars);
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) { return chromo::bench::guarded_main("still_registration_bench", chromo::bench::bench_main, argc, argv); }
