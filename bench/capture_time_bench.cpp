// Accuracy against capture time in the virtual lab (issue 20, part 7): each
// plan at 1 and 4 frames per capture, with the subject still and with the
// subject moving (simulators/scene/subject_motion.hpp, its documented default
// drift and tremor), rendered from the lab's physics for held-out scene seeds
// (simulators/scene/rendered_session.hpp: skin fields, vein, tattoo ink,
// marker, hair and highlights of each seed; the camera's noise) and
// estimated by the default per-pixel estimator (fast inverter, auto model,
// no spatial pass).
//
// Plans: "standard" (the method's, exposure per capture), "multispectral"
// (each LED type alone) and "multispectral+method" (both). Capture time is
// the plan's timeline from the first step to the end of the last (LED settle
// 50 ms, exposure, 43 ms readout per frame; references included, as the
// subject sits through them too).
//
// Per plan, frames and motion, the spread over the seeds (mean [min, max]):
// relit ΔE94 on explained skin cells (six LEDs + D65; and (D65 + A) / 2) and
// on every skin cell (a flagged one by its best fit: motion flags more skin,
// and the explained-only figure would then drop the hardest cells), skin and
// ink+marker flagged, the registration's RMS error against the true motion
// (measurement pixels); a session whose registration does not converge is
// counted as failed (printed with the reason) and left out of the spread. Chart: ΔE94 against capture time with the spread as
// error bars (every skin cell), one series per motion state.
//
//   capture_time_bench [--seeds 11,12,13] [--sensor W H] [--frames 1,4] [--motion 1,5] [--still-only] [--out DIR]
//
// --motion: the moving cases as multiples of the default amplitudes (1: as
// documented in subject_motion.hpp; 5: a restless subject).
//
// Writes DIR/capture_time.csv, DIR/capture_time.png (and its .gp).
#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench_cli.hpp"

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/session/registration.hpp"
#include "chromo/files/gnuplot_chart.hpp"
#include "chromo/planning/plan_advisor.hpp"
#include "chromo/spectral/lab_illuminants.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "relit_accuracy.hpp"
#include "seed_spread.hpp"

namespace chromo::bench {
namespace {

struct Case {
  std::string plan;
  int frames = 1;
  double motion_scale = 0;  // 0: still; else × the default drift and tremor amplitudes
};

std::string motion_label(double scale) {
  if (scale == 0) return "still";
  char text[32];
  std::snprintf(text, sizeof text, "%gx", scale);
  return text;
}

struct Result {
  double capture_seconds = 0;
  double de_all = 0, de_d65_a = 0;  // relit ΔE94 on explained skin
  double de_all_skin = 0;            // on every skin cell, a flagged one by its best fit (no selection by the flags)
  double skin_flagged = 0, ink_flagged = 0;
  double registration_rms_px = 0;  // mean over the moved captures
  std::string failed;               // why the session produced no measurement (registration did not converge)
  estimation::SkinParameters skin_low{1e9, 1e9, 1e9, 1e9}, skin_high{0, 0, 0, 0};  // the skin cells' truth box
  std::vector<estimation::SkinParameters> skin_sample;  // every kSkinSampleStride-th skin cell's truth
};

constexpr std::size_t kSkinSampleStride = 97;  // ~80 cells of a 256×192 session's skin

Result run(const Case& c, std::uint64_t seed, int sensor_width, int sensor_height) {
  simulators::RenderedSessionOptions o;
  o.sensor_width = sensor_width, o.sensor_height = sensor_height, o.seed = seed, o.threads = 2;
  o.plan = c.plan;
  o.exposure_per_capture = c.plan == "standard";
  o.frames_per_capture = c.frames;
  o.noise_free = false;
  o.motion.enabled = c.motion_scale > 0;
  o.motion.seed = seed * 31 + 7;
  o.motion.drift_x_mm_per_s *= c.motion_scale, o.motion.drift_y_mm_per_s *= c.motion_scale;
  o.motion.drift_deg_per_s *= c.motion_scale, o.motion.axial_drift_mm_per_s *= c.motion_scale;
  o.motion.tremor_sigma_mm *= c.motion_scale, o.motion.tremor_sigma_deg *= c.motion_scale;
  simulators::RenderedSession lab;
  try {
    lab = simulators::render_session(o);
  } catch (const session::RegistrationError& e) {
    Result r;
    r.failed = e.what();
    return r;
  }

  Result r;
  std::vector<bool> skin(lab.pixels()), ink(lab.pixels());
  for (std::size_t i = 0; i < lab.pixels(); ++i) {
    skin[i] = lab.region[i] == static_cast<std::uint8_t>(simulators::SceneRegion::kSkin);
    if (skin[i]) {
      const estimation::SkinParameters& t = lab.truth[i];
      r.skin_low = {std::min(r.skin_low.cm, t.cm), std::min(r.skin_low.ch, t.ch), std::min(r.skin_low.bm, t.bm),
                    std::min(r.skin_low.che, t.che)};
      r.skin_high = {std::max(r.skin_high.cm, t.cm), std::max(r.skin_high.ch, t.ch), std::max(r.skin_high.bm, t.bm),
                     std::max(r.skin_high.che, t.che)};
      if (i % kSkinSampleStride == 0) r.skin_sample.push_back(t);
    }
    ink[i] = lab.region[i] == static_cast<std::uint8_t>(simulators::SceneRegion::kTattoo) ||
             lab.region[i] == static_cast<std::uint8_t>(simulators::SceneRegion::kMarker);
  }
  const auto table = std::make_shared<const estimation::ForwardTable>(
      estimation::ForwardTable::build(lab.noisy.set, estimation::TableGrid{}, 2));
  estimation::EstimatorOptions options;
  options.threads = 2;
  std::vector<estimation::PixelEstimate> e(lab.pixels());
  estimation::Estimator(table, lab.noisy.set, options).estimate(lab.noisy.measured, e);

  r.capture_seconds = lab.plan_seconds;
  const Accuracy a = accuracy(relight(lab.truth), lab.truth, e, skin);
  r.de_all = a.de_all;
  r.de_d65_a = 0.5 * (a.de_d65 + relit_under_a(lab.truth, e, skin));
  std::vector<estimation::PixelEstimate> best_fit = e;
  for (estimation::PixelEstimate& p : best_fit)
    if (p.order != 0) p.flag = estimation::PixelFlag::kExplained;
  r.de_all_skin = accuracy(relight(lab.truth), lab.truth, best_fit, skin).de_all;
  std::size_t skin_n = 0, skin_f = 0, ink_n = 0, ink_f = 0;
  for (std::size_t i = 0; i < lab.pixels(); ++i) {
    const bool flagged = e[i].flag != estimation::PixelFlag::kExplained;
    if (skin[i]) ++skin_n, skin_f += flagged;
    if (ink[i]) ++ink_n, ink_f += flagged;
  }
  r.skin_flagged = skin_n ? double(skin_f) / skin_n : 0;
  r.ink_flagged = ink_n ? double(ink_f) / ink_n : 0;
  for (const simulators::CaptureMotion& m : lab.motion) r.registration_rms_px += m.registration_error_rms_px / lab.motion.size();
  return r;
}

// The advisor's description of a lab plan at f frames per capture: standard
// → "standard", multispectral → "multispectral", multispectral+method → the
// six LEDs alone then the method's three mixes, every capture's R, G, B
// (what session::build_measurement gives the estimator).
planning::PlanDescription advisor_plan_of(const std::string& lab_plan, int frames,
                                          const calibration::LedLibrary& library) {
  const std::string suffix = "@" + std::to_string(frames);
  if (lab_plan == "standard") return planning::builtin_plan("standard" + suffix, library);
  if (lab_plan == "multispectral") return planning::builtin_plan("multispectral" + suffix, library);
  planning::PlanDescription both = planning::builtin_plan("multispectral" + suffix, library);
  const planning::PlanDescription method = planning::builtin_plan("standard" + suffix, library);
  both.name = lab_plan + suffix;
  for (planning::PlannedCapture c : method.captures) {
    c.name += "-mix";  // "W57" is an LED type's capture too
    both.captures.push_back(c);
  }
  both.channels.clear();
  return both;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) {
  using namespace chromo;
  using namespace chromo::bench;
  CLI::App app{"relit accuracy against capture time in the virtual lab, per plan, frames and subject motion"};
  std::vector<std::uint64_t> seeds{11, 12, 13};
  std::vector<int> sensor{256, 192};
  std::vector<int> frames{1, 4};
  std::vector<double> motion_scales{1, 5};
  std::string out = "bench/results";
  app.add_option("--seeds", seeds, "held-out scene seeds")->delimiter(',');
  app.add_option("--sensor", sensor, "sensor W H (even)")->expected(2);
  app.add_option("--frames", frames, "frames per capture to compare")->delimiter(',');
  app.add_option("--motion", motion_scales, "moving-subject cases: multiples of the default drift and tremor")
      ->delimiter(',');
  app.add_option("--out", out, "output directory");
  bool still_only = false;
  app.add_flag("--still-only", still_only, "the subject still only (no --motion cases): the advisor's check");
  CLI11_PARSE(app, argc, argv);
  if (still_only) motion_scales.clear();
  if (seeds.empty() || frames.empty()) {
    std::fprintf(stderr, "capture_time_bench: --seeds and --frames need at least one value\n");
    return 2;
  }

  std::map<std::string, std::vector<Result>> still_results;  // "plan@frames" → per seed, subject still
  estimation::SkinParameters skin_low{}, skin_high{};
  bool have_box = false;
  std::vector<Case> cases;
  for (const char* plan : {"standard", "multispectral", "multispectral+method"})
    for (int f : frames)
    {
      cases.push_back({plan, f, 0});
      for (double scale : motion_scales) cases.push_back({plan, f, scale});
    }

  std::printf("capture_time_bench: %dx%d sensor (2x2 binned cells), %zu held-out seeds, fast/auto per pixel, no "
              "spatial pass; mean [min, max] over the seeds\n",
              sensor[0], sensor[1], seeds.size());
  std::printf("%-21s %6s %6s %9s  %-26s %-26s %-26s %-20s %-20s %s\n", "plan", "frames", "motion", "capture",
              "relit dE94, explained", "relit dE94 (D65+A)/2", "relit dE94, every skin cell", "skin flagged",
              "ink+marker flagged", "registration RMS px");
  const std::filesystem::path dir = out;
  std::filesystem::create_directories(dir);
  std::ofstream csv(dir / "capture_time.csv");
  csv << "plan,frames,motion,seed,capture_s,de_all,de_d65_a,de_all_skin,skin_flagged,ink_flagged,registration_rms_px\n";
  std::vector<double> series{0};
  series.insert(series.end(), motion_scales.begin(), motion_scales.end());
  std::vector<std::ofstream> dat;
  for (double scale : series) dat.emplace_back(dir / ("capture_time_" + motion_label(scale) + ".dat"));
  for (const Case& c : cases) {
    std::vector<Result> results;
    std::size_t failed = 0;
    for (std::uint64_t seed : seeds) {
      const Result r = run(c, seed, sensor[0], sensor[1]);
      if (!r.failed.empty()) {
        ++failed;
        csv << c.plan << "," << c.frames << "," << motion_label(c.motion_scale) << "," << seed << ",,,,,,,\n";
        std::printf("  %s x%d %s seed %llu: %s\n", c.plan.c_str(), c.frames, motion_label(c.motion_scale).c_str(),
                    static_cast<unsigned long long>(seed), r.failed.c_str());
        continue;
      }
      results.push_back(r);
      csv << c.plan << "," << c.frames << "," << motion_label(c.motion_scale) << "," << seed << ","
          << r.capture_seconds << "," << r.de_all << "," << r.de_d65_a << "," << r.de_all_skin << "," << r.skin_flagged << "," << r.ink_flagged
          << "," << r.registration_rms_px << "\n";
    }
    if (results.empty()) {
      std::printf("%-21s %6d %6s  every seed failed (registration)\n", c.plan.c_str(), c.frames,
                  motion_label(c.motion_scale).c_str());
      continue;
    }
    if (c.motion_scale == 0 && !have_box) skin_low = results.front().skin_low, skin_high = results.front().skin_high, have_box = true;
    const Spread t = spread(results, [](const Result& r) { return r.capture_seconds; });
    const Spread all = spread(results, [](const Result& r) { return r.de_all; });
    const Spread da = spread(results, [](const Result& r) { return r.de_d65_a; });
    const Spread every = spread(results, [](const Result& r) { return r.de_all_skin; });
    const Spread sk = spread(results, [](const Result& r) { return 100 * r.skin_flagged; });
    const Spread ink = spread(results, [](const Result& r) { return 100 * r.ink_flagged; });
    const Spread reg = spread(results, [](const Result& r) { return r.registration_rms_px; });
    std::printf("%-21s %6d %6s %8.2fs  %.3f [%.3f, %.3f]      %.3f [%.3f, %.3f]      %.3f [%.3f, %.3f]      %.2f%% [%.2f, "
                "%.2f]  %5.1f%% [%.1f, %.1f]  %.3f [%.3f, %.3f]%s\n",
                c.plan.c_str(), c.frames, motion_label(c.motion_scale).c_str(), t.mean, all.mean, all.lo, all.hi, da.mean,
                da.lo, da.hi, every.mean, every.lo, every.hi, sk.mean, sk.lo, sk.hi, ink.mean, ink.lo, ink.hi, reg.mean,
                reg.lo, reg.hi,
                failed ? (" (registration failed on " + std::to_string(failed) + " of " + std::to_string(seeds.size()) + " seeds)").c_str() : "");
    std::fflush(stdout);
    if (c.motion_scale == 0) still_results[c.plan + "@" + std::to_string(c.frames)] = results;
    std::ofstream& series_file = dat[std::find(series.begin(), series.end(), c.motion_scale) - series.begin()];
    series_file << t.mean << " " << every.mean << " " << every.lo << " " << every.hi << " \"" << c.plan << " x" << c.frames
                << "\" " << sk.mean << " " << sk.lo << " " << sk.hi << "\n";
  }
  for (std::ofstream& d : dat) d.close();

  // The plan advisor's prediction (planning/plan_advisor.hpp: Fisher
  // information, no constant fitted) for the same plans, camera (its defaults
  // are the lab camera's) and LED library, relit under the bench's
  // illuminants (six LEDs + D65): the issue's check of the advisor against
  // the many-scene bench. Two populations: the box the first seed's skin
  // cells span (drawn as the advisor draws), and each seed's own skin cells
  // (a sample of its truth), the latter per seed against that seed's bench
  // figure (predicted / bench, mean [min, max] over the seeds).
  // multispectral+method is a plan the advisor was never developed on.
  if (have_box) {
    const calibration::LedLibrary library = simulators::lab_led_library();
    planning::AdvisorOptions advice;
    advice.population.low = skin_low, advice.population.high = skin_high;
    advice.threads = 2;
    for (const spectral::NamedIlluminant& i : spectral::relight_illuminants())
      advice.references.push_back({i.name, i.spectrum});
    std::printf("\nplan advisor against the lab (subject still; box: Cm %.3g-%.3g, Ch %.3g-%.3g, bm %.2f-%.2f, "
                "Che %.3f-%.3f; scene: each seed's skin cells, every %zuth)\n%-21s %6s %9s %9s %9s %9s  %-24s %-24s\n",
                skin_low.cm, skin_high.cm, skin_low.ch, skin_high.ch, skin_low.bm, skin_high.bm, skin_low.che,
                skin_high.che, kSkinSampleStride, "plan", "frames", "lab", "pred box", "pred scn", "pred+flr",
                "pred scene / lab", "pred+floor / lab");
    for (const char* lab_plan : {"standard", "multispectral", "multispectral+method"})
      for (int f : frames) {
        const auto measured = still_results.find(std::string(lab_plan) + "@" + std::to_string(f));
        if (measured == still_results.end()) continue;
        const planning::PlanDescription description = advisor_plan_of(lab_plan, f, library);
        const double box = planning::predict_plan(description, library, planning::CameraNoise{}, advice).delta_e94_mean;
        std::vector<Result> per_seed_scene, per_seed_floor;  // de_all_skin := predicted / lab
        double scene_mean = 0, floor_mean = 0, lab_mean = 0;
        for (const Result& r : measured->second) {
          planning::AdvisorOptions scene = advice;
          scene.population.skins = r.skin_sample;
          const double plain = planning::predict_plan(description, library, planning::CameraNoise{}, scene).delta_e94_mean;
          scene.table_bias = true;
          const double floored = planning::predict_plan(description, library, planning::CameraNoise{}, scene).delta_e94_mean;
          Result ratio;
          ratio.de_all_skin = plain / r.de_all_skin;
          per_seed_scene.push_back(ratio);
          ratio.de_all_skin = floored / r.de_all_skin;
          per_seed_floor.push_back(ratio);
          const double n = measured->second.size();
          scene_mean += plain / n, floor_mean += floored / n, lab_mean += r.de_all_skin / n;
        }
        const Spread rs = spread(per_seed_scene, [](const Result& r) { return r.de_all_skin; });
        const Spread rf = spread(per_seed_floor, [](const Result& r) { return r.de_all_skin; });
        std::printf("%-21s %6d %9.3f %9.3f %9.3f %9.3f  %.2f [%.2f, %.2f]         %.2f [%.2f, %.2f]\n", lab_plan, f,
                    lab_mean, box, scene_mean, floor_mean, rs.mean, rs.lo, rs.hi, rf.mean, rf.lo, rf.hi);
        std::fflush(stdout);
      }
  }

  files::GnuplotChart chart;
  chart.png = dir / "capture_time.png";
  chart.terminal = "pngcairo size 1400,560 font 'DejaVu Sans,10'";
  // Left: relit ΔE94 on every skin cell; right: skin flagged (where motion's cost shows).
  chart.commands = "set multiplot layout 1,2 title 'Virtual lab, held-out seeds: mean and [min, max] against capture "
                   "time'\nset xlabel 'capture time, first step to last (s)'\nset grid\nset logscale x\nset key top right\n";
  for (int panel = 0; panel < 2; ++panel) {
    chart.commands += panel == 0 ? "set title 'relit dE94 on every skin cell (six LEDs + D65)'\nset ylabel 'relit dE94'\n"
                                   "set yrange [0:*]\nplot "
                                 : "set title 'skin flagged'\nset ylabel 'skin cells flagged (%)'\nset logscale y\n"
                                   "set yrange [*:*]\nplot ";
    const std::string columns = panel == 0 ? "1:2:3:4" : "1:6:7:8";
    for (std::size_t k = 0; k < series.size(); ++k) {
      const std::string file = (dir / ("capture_time_" + motion_label(series[k]) + ".dat")).string();
      const std::string title = series[k] == 0 ? std::string("subject still")
                                               : "subject moving, " + motion_label(series[k]) + " the default drift and tremor";
      chart.commands += (k ? ", '" : "'") + file + "' using " + columns + " with yerrorbars pt " + std::to_string(7 - k) +
                        " title '" + title + "'";
      if (k == 0) chart.commands += ", '' using 1:" + std::string(panel == 0 ? "2" : "6") + ":5 with labels offset 0,-1.2 font ',8' notitle";
    }
    chart.commands += "\n";
  }
  chart.commands += "unset multiplot\n";
  if (const std::string failed = files::draw_chart(chart, dir / "capture_time.gp"); !failed.empty())
    std::fprintf(stderr, "chart: %s\n", failed.c_str());
  std::printf("wrote %s and %s\n", (dir / "capture_time.csv").c_str(), chart.png.c_str());
  return 0;
}
