// Registration of a still subject (issues 37 and 39): real-skin scenes
// (`chromo make-real-skin-scene`'s: held-out NIST forearms 041-050 as
// textured patches with ink and marker, four frames of a 40,000 e⁻ sensor),
// whose captures did not move, registered as `chromo estimate` registers a
// MEASUREMENT.json (session::register_images), side by side in one run:
//   before: every pyramid level, the warp and the full-resolution residual
//           check (RegistrationOptions::decide_still_at_coarse_level = false);
//   after:  the still subject decided on the coarse levels (the default).
// Per plan (method, six-leds) and seed: the wall time of registering every
// image, the captures warped, the largest corner motion found, and the
// pixels left non-finite (what the estimator flags non_finite); then the
// spread (mean [min, max]) over the seeds.
//
//   still_registration_bench [--seeds 1,2,3] [--patch 128] [--plans method,six-leds] [--out DIR] [--no-chart]
//
// Writes DIR/still_registration.csv and DIR/still_registration.png (mean
// registration seconds per plan, before and after; DIR: bench/results).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <unistd.h>

#include "chart.hpp"
#include "clocks.hpp"
#include "guarded_main.hpp"
#include "seed_spread.hpp"
#include "chromo/session/measurement_file.hpp"
#include "chromo/simulators/scene/real_skin_scene.hpp"

namespace chromo::bench {
namespace {

namespace fs = std::filesystem;

struct Run {
  std::string plan, variant;
  std::uint64_t seed = 0;
  double seconds = 0, largest_motion_px = 0;
  int warped = 0;
  std::size_t non_finite_pixels = 0, pixels = 0;
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

Run register_scene(const fs::path& json, const std::string& plan, std::uint64_t seed, bool decide_still) {
  session::MeasurementFile m = session::read_measurement_file(json);
  session::RegistrationOptions options;
  options.decide_still_at_coarse_level = decide_still;
  Run run{plan, decide_still ? "after" : "before", seed};
  const auto start = std::chrono::steady_clock::now();
  const std::vector<session::RegistrationReport> reports = session::register_images(m, options);
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const auto& r : reports) run.warped += r.warped, run.largest_motion_px = std::max(run.largest_motion_px, r.motion_px);
  run.non_finite_pixels = non_finite_pixels(m);
  run.pixels = static_cast<std::size_t>(m.width) * m.height;
  return run;
}

int bench_main(int argc, char** argv) {
  CLI::App app{"registration of a still subject, before and after the coarse decision"};
  std::vector<std::uint64_t> seeds{1, 2, 3};
  std::vector<std::string> plans{"method", "six-leds"};
  int patch_px = 128;
  fs::path out = "bench/results";
  bool no_chart = false;
  app.add_option("--seeds", seeds, "scene seeds")->delimiter(',');
  app.add_option("--plans", plans, "method and/or six-leds")->delimiter(',');
  app.add_option("--patch", patch_px, "pixels per subject's patch (10 patches, 5 a row)")->check(CLI::Range(8, 2000));
  app.add_option("--out", out, "results folder");
  app.add_flag("--no-chart", no_chart, "no PNG");
  CLI11_PARSE(app, argc, argv);

  const fs::path scratch = fs::temp_directory_path() / ("still_registration_bench-" + std::to_string(::getpid()));
  std::printf("still_registration_bench: patch %d px, load average %.2f\n", patch_px, load_average());
  fs::create_directories(out);
  std::ofstream csv(out / "still_registration.csv");
  csv << "plan,variant,seed,pixels,seconds,warped,largest_motion_px,non_finite_pixels,load_average\n";
  std::map<std::pair<std::string, std::string>, std::vector<Run>> runs;
  for (const std::string& plan : plans)
    for (const std::uint64_t seed : seeds) {
      simulators::RealSkinSceneOptions scene;
      scene.spectra = simulators::nist_subjects("041-050");
      scene.patch_px = patch_px, scene.plan = plan, scene.seed = seed;
      const fs::path dir = scratch / (plan + "-" + std::to_string(seed));
      simulators::write_real_skin_scene(dir, scene);
      for (const bool decide_still : {false, true}) {  // before, after
        const Run r = register_scene(dir / "MEASUREMENT.json", plan, seed, decide_still);
        std::printf("%-9s seed %llu %-6s %zu px: %.3f s, %d warped, largest motion %.3f px, %zu non-finite px\n",
                    plan.c_str(), static_cast<unsigned long long>(seed), r.variant.c_str(), r.pixels, r.seconds, r.warped,
                    r.largest_motion_px, r.non_finite_pixels);
        csv << plan << "," << r.variant << "," << seed << "," << r.pixels << "," << r.seconds << "," << r.warped << ","
            << r.largest_motion_px << "," << r.non_finite_pixels << "," << load_average() << std::endl;
        runs[{plan, r.variant}].push_back(r);
      }
      fs::remove_all(dir);
    }
  fs::remove_all(scratch);

  std::printf("\nspread over %zu seed(s), mean [min, max] (load average now %.2f):\n", seeds.size(), load_average());
  std::vector<Bar> bars;
  for (const std::string& plan : plans)
    for (const char* variant : {"before", "after"}) {
      const std::vector<Run>& rows = runs[{plan, variant}];
      const Spread s = spread(rows, [](const Run& r) { return r.seconds; });
      const Spread w = spread(rows, [](const Run& r) { return double(r.warped); });
      const Spread nf = spread(rows, [](const Run& r) { return double(r.non_finite_pixels); });
      const Spread mo = spread(rows, [](const Run& r) { return r.largest_motion_px; });
      std::printf("  %-9s %-6s registration %.3f [%.3f, %.3f] s; warped %.1f [%.0f, %.0f]; largest motion %.3f [%.3f, %.3f] px; "
                  "non-finite px %.1f [%.0f, %.0f]\n",
                  plan.c_str(), variant, s.mean, s.lo, s.hi, w.mean, w.lo, w.hi, mo.mean, mo.lo, mo.hi, nf.mean, nf.lo, nf.hi);
      bars.push_back({plan + " " + variant, s.mean});
    }
  std::printf("\nwrote %s\n", (out / "still_registration.csv").c_str());
  if (!no_chart)
    write_bar_chart(out / "still_registration.png", "registration of a still real-skin scene (mean over seeds)",
                    "wall seconds", bars);
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) { return chromo::bench::guarded_main("still_registration_bench", chromo::bench::bench_main, argc, argv); }
