// The standard plan before and after exposure per capture (issue 20), side
// by side on the same virtual-lab scenes: the standard session rendered from
// the lab's physics (simulators/scene/rendered_session.hpp) under
//
//   before  one exposure for every step, set so that the brightest white of
//           the three (D65') sits at 0.85 of full scale; mixes "w57+blue", "w57";
//   after   exposure per capture: the D65' and W57+blue whites each metered
//           to 0.85 of full scale, W57 at W57+blue's exposure, each subject at
//           its white's; mixes "w57+blue:R", "w57:R" (--blue-ratio R);
//   refs    after, with --reference-frames N frames of each dark and white
//           (the subject's frames unchanged: references are not subject time);
//   subject refs, each subject metered on a first frame of it (its
//           --subject-percentile in its brightest channel at --subject-fill of
//           full scale, at most --max-subject-ratio times its white's
//           exposure), each white scaled by that ratio and checked for
//           linearity (docs/estimation.md "Exposure per capture");
//
// all with --frames frames per subject capture (and, before and after, per
// reference too), the whites metered to --white-fill of full scale. Per plan and scene seed: the
// blue-only channel's relative noise on the white beside D65' B's (predicted
// from the camera model's shot and read noise; measured: the estimator's
// noise figure, which session::build_measurement estimates from the
// dark and white frames), and the fast inverter's relit ΔE94 against the
// truth on the skin cells (six LEDs + D65), 4D model and auto model, noisy
// frames; then the spread over the seeds.
//
//   exposure_plan_bench [--seeds 5,11,12,13] [--sensor W H] [--blue-ratio R] [--frames N]
//                       [--reference-frames N] [--white-fill F] [--subject-fill F]
//                       [--subject-percentile P] [--max-subject-ratio R] [--out DIR]
//
// Writes DIR/exposure_plan.csv and DIR/exposure_plan.png (relit ΔE94 per seed, the three plans).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "bench_cli.hpp"

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/files/gnuplot_chart.hpp"
#include "chromo/simulators/camera/camera_model.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "relit_accuracy.hpp"

namespace chromo::bench {
namespace {

struct PlanResult {
  double blue_relative_predicted = 0, d65_b_relative_predicted = 0;  // σ/ρ on the white, camera model
  double blue_relative_measured = 0, d65_b_relative_measured = 0;    // σ/ρ on the white, estimator's noise figure
  double exposure_d65_us = 0, exposure_blue_us = 0;
  double subject_ratio_d65 = 1, subject_ratio_blue = 1;  // subject exposure / its white's
  std::size_t saturated_pixels = 0, skin_cells = 0;  // cells with a clipped subject sample; skin cells
  Accuracy fast4d, fastauto;
};

struct SeedResult {
  std::uint64_t seed = 0;
  PlanResult before, after, refs, subject;
};

// Relative noise σ(ρ)/ρ of a channel on the white by its noise figure.
double relative_noise(const estimation::ChannelNoise& noise, double rho) { return std::sqrt(noise.variance(rho)) / rho; }

// The camera model's prediction for a white of response `response` (per
// channel) at `exposure_us`, N frames averaged for subject, white and dark:
// the albedo of a white photographed against the white reference has
// variance 2σ²/S² (subject and reference alike, the dark's noise aside).
double predicted_relative(const simulators::CameraModel& camera, double response, double exposure_us, int frames) {
  const double signal = camera.expected_dn(response, exposure_us, 0) - camera.options().black_level_dn;
  return std::sqrt(2.0 / frames) * camera.noise_sigma_dn(response, exposure_us, 0) / signal;
}
double predicted_blue_relative(const simulators::CameraModel& camera, double mix, double base, double exposure_us,
                               int frames) {
  const double d = camera.expected_dn(mix, exposure_us, 0) - camera.expected_dn(base, exposure_us, 0);
  const double v = std::pow(camera.noise_sigma_dn(mix, exposure_us, 0), 2) + std::pow(camera.noise_sigma_dn(base, exposure_us, 0), 2);
  return std::sqrt(2.0 * v / frames) / d;
}

Accuracy estimate_skin(const simulators::RenderedSession& lab, estimation::ModelChoice model, const Relit& truth_relit,
                       const std::vector<bool>& skin) {
  auto table = std::make_shared<const estimation::ForwardTable>(
      estimation::ForwardTable::build(lab.noisy.set, estimation::TableGrid{}, 2));
  estimation::EstimatorOptions options;
  options.method = estimation::InverterMethod::kFast;
  options.model = model;
  options.threads = 2;
  const estimation::Estimator estimator(table, lab.noisy.set, options);
  std::vector<estimation::PixelEstimate> e(lab.pixels());
  estimator.estimate(lab.noisy.measured, e);
  return accuracy(truth_relit, lab.truth, e, skin);
}

struct PlanChoice {
  bool per_capture = false;
  double blue_ratio = 0;
  int frames = 1, reference_frames = 0;
  double white_fill = 0.85;
  double subject_fill = 0, subject_percentile = 0.99, max_subject_ratio = 8;
};

PlanResult run_plan(std::uint64_t seed, int width, int height, const PlanChoice& plan) {
  const bool per_capture = plan.per_capture;
  const int frames = plan.frames;
  simulators::RenderedSessionOptions ro;
  ro.sensor_width = width, ro.sensor_height = height, ro.seed = seed, ro.threads = 2;
  ro.noise_free = false;
  ro.exposure_per_capture = per_capture;
  ro.blue_ratio = per_capture ? plan.blue_ratio : 0;
  ro.frames_per_capture = frames;
  ro.reference_frames = plan.reference_frames;
  ro.white_fill = plan.white_fill;
  ro.subject_fill = plan.subject_fill;
  ro.subject_percentile = plan.subject_percentile;
  ro.max_subject_exposure_ratio = plan.max_subject_ratio;
  const simulators::RenderedSession lab = simulators::render_session(ro);
  PlanResult r;
  const simulators::CameraModel camera{simulators::CameraModelOptions{}};
  r.exposure_d65_us = lab.exposure_us_of_step.at("subject_d65");
  r.exposure_blue_us = lab.exposure_us_of_step.at("subject_w57+blue");
  r.subject_ratio_d65 = r.exposure_d65_us / lab.exposure_us_of_step.at("white_d65");
  r.subject_ratio_blue = r.exposure_blue_us / lab.exposure_us_of_step.at("white_w57+blue");
  r.saturated_pixels = lab.noisy.saturated_pixels;
  // Predicted at the whites' exposures (subject and white at one exposure: the subject plan's longer
  // subject exposure is not in the prediction).
  const double white_d65_us = lab.exposure_us_of_step.at("white_d65"), white_blue_us = lab.exposure_us_of_step.at("white_w57+blue");
  r.d65_b_relative_predicted = predicted_relative(camera, lab.white_response.at("d65")[2], white_d65_us, frames);
  r.blue_relative_predicted = predicted_blue_relative(camera, lab.white_response.at("w57+blue")[2],
                                                      lab.white_response.at("w57")[2], white_blue_us, frames);
  const double rho = simulators::kWhiteTargetReflectance;
  r.d65_b_relative_measured = relative_noise(lab.noisy.set.channels[2].noise, rho);
  r.blue_relative_measured = relative_noise(lab.noisy.set.channels[3].noise, rho);
  std::vector<bool> skin(lab.pixels());
  for (std::size_t i = 0; i < lab.pixels(); ++i)
    skin[i] = lab.region[i] == static_cast<std::uint8_t>(simulators::SceneRegion::kSkin);
  r.skin_cells = static_cast<std::size_t>(std::count(skin.begin(), skin.end(), true));
  const Relit truth = relight(lab.truth);
  r.fast4d = estimate_skin(lab, estimation::ModelChoice::k4d, truth, skin);
  r.fastauto = estimate_skin(lab, estimation::ModelChoice::kAuto, truth, skin);
  return r;
}

void print_plan(const char* label, const PlanResult& p) {
  std::printf("  %-7s subject/white exposure D65' %.2f, W57(+blue) %.2f; %zu cells saturated; skin cells explained "
              "(in the dE94) 4d %.4f, auto %.4f of %zu\n",
              label, p.subject_ratio_d65, p.subject_ratio_blue, p.saturated_pixels,
              static_cast<double>(p.fast4d.pixels) / static_cast<double>(p.skin_cells),
              static_cast<double>(p.fastauto.pixels) / static_cast<double>(p.skin_cells), p.skin_cells);
  std::printf("  %-7s exposure D65' %7.0f us, W57(+blue) %7.0f us | rel. noise on white: blue-only %.4f (pred %.4f), "
              "D65' B %.4f (pred %.4f), ratio %.2f | relit dE94 fast/4d %.3f (D65 %.3f), fast/auto %.3f\n",
              label, p.exposure_d65_us, p.exposure_blue_us, p.blue_relative_measured, p.blue_relative_predicted,
              p.d65_b_relative_measured, p.d65_b_relative_predicted, p.blue_relative_measured / p.d65_b_relative_measured,
              p.fast4d.de_all, p.fast4d.de_d65, p.fastauto.de_all);
}

struct Spread {
  double mean = 0, min = 1e300, max = -1e300;
};
template <typename Get>
Spread spread(const std::vector<SeedResult>& results, Get get) {
  Spread s;
  for (const auto& r : results) {
    const double v = get(r);
    s.mean += v / static_cast<double>(results.size());
    s.min = std::min(s.min, v), s.max = std::max(s.max, v);
  }
  return s;
}

int bench_main(int argc, char** argv) {
  CLI::App app{"the standard plan before and after exposure per capture, on virtual-lab scenes"};
  std::vector<std::uint64_t> seeds{5, 11, 12, 13};
  std::vector<int> sensor{2592, 1944};
  double blue_ratio = 8;
  int frames = 1, reference_frames = 8;
  double white_fill = 0.85;
  double subject_fill = 0.85, subject_percentile = 0.99, max_subject_ratio = 8;
  std::filesystem::path out = "bench/results";
  app.add_option("--seeds", seeds, "scene seeds")->delimiter(',');
  app.add_option("--sensor", sensor, "sensor W H (even)")->expected(2);
  app.add_option("--blue-ratio", blue_ratio, "R of the metered plan's w57+blue:R")->check(CLI::Range(0.1, 100.0));
  app.add_option("--frames", frames, "frames per subject capture (all plans)")->check(CLI::Range(1, 64));
  app.add_option("--reference-frames", reference_frames, "the refs plan's frames per dark and white")
      ->check(CLI::Range(1, 64));
  app.add_option("--white-fill", white_fill, "the whites' brightest channel, share of full scale")
      ->check(CLI::Range(0.06, 0.98));
  app.add_option("--subject-fill", subject_fill, "the subject plan's metered percentile, share of full scale")
      ->check(CLI::Range(0.06, 0.98));
  app.add_option("--subject-percentile", subject_percentile, "the subject plan's metered percentile of the subject's pixels")
      ->check(CLI::Range(0.5, 1.0));
  app.add_option("--max-subject-ratio", max_subject_ratio, "the subject plan's cap on subject / white exposure")
      ->check(CLI::Range(1.0, 64.0));
  app.add_option("--out", out, "where the CSV and chart go");
  CLI11_PARSE(app, argc, argv);
  std::filesystem::create_directories(out);
  std::printf("sensor %dx%d, %d frame(s) per subject capture; white at %.2f of full scale; after: exposure per "
              "capture, w57+blue:%g; refs: after with %d frames per reference; subject: refs with the subjects' %.3f "
              "percentile metered to %.2f (ratio <= %g)\n",
              sensor[0], sensor[1], frames, white_fill, blue_ratio, reference_frames, subject_percentile, subject_fill,
              max_subject_ratio);
  std::vector<SeedResult> results;
  for (std::uint64_t seed : seeds) {
    SeedResult r;
    r.seed = seed;
    r.before = run_plan(seed, sensor[0], sensor[1], {false, 0, frames, 0, white_fill});
    r.after = run_plan(seed, sensor[0], sensor[1], {true, blue_ratio, frames, 0, white_fill});
    r.refs = run_plan(seed, sensor[0], sensor[1], {true, blue_ratio, frames, reference_frames, white_fill});
    r.subject = run_plan(seed, sensor[0], sensor[1],
                         {true, blue_ratio, frames, reference_frames, white_fill, subject_fill, subject_percentile,
                          max_subject_ratio});
    std::printf("seed %llu\n", static_cast<unsigned long long>(seed));
    print_plan("before", r.before);
    print_plan("after", r.after);
    print_plan("refs", r.refs);
    print_plan("subject", r.subject);
    std::fflush(stdout);
    results.push_back(r);
  }
  std::printf("spread over %zu seeds (mean [min, max]):\n", results.size());
  // One figure per plan: its spread, and refs / after as a ratio.
  auto show = [&](const char* what, auto get) {
    const Spread b = spread(results, [&](const SeedResult& r) { return get(r.before); });
    const Spread a = spread(results, [&](const SeedResult& r) { return get(r.after); });
    const Spread f = spread(results, [&](const SeedResult& r) { return get(r.refs); });
    const Spread m = spread(results, [&](const SeedResult& r) { return get(r.subject); });
    std::printf("  %-44s before %.4f [%.4f, %.4f]   after %.4f [%.4f, %.4f]   refs %.4f [%.4f, %.4f] (refs/after %.3f)   "
                "subject %.4f [%.4f, %.4f] (subject/refs %.3f)\n",
                what, b.mean, b.min, b.max, a.mean, a.min, a.max, f.mean, f.min, f.max, f.mean / a.mean, m.mean, m.min,
                m.max, m.mean / f.mean);
  };
  show("relit dE94 fast/4d noisy (six LEDs + D65)", [](const PlanResult& p) { return p.fast4d.de_all; });
  show("relit dE94 fast/auto noisy (six LEDs + D65)", [](const PlanResult& p) { return p.fastauto.de_all; });
  show("blue-only / D65' B relative noise on white",
       [](const PlanResult& p) { return p.blue_relative_measured / p.d65_b_relative_measured; });
  show("blue-only relative noise on white", [](const PlanResult& p) { return p.blue_relative_measured; });
  show("D65' B relative noise on white", [](const PlanResult& p) { return p.d65_b_relative_measured; });
  show("skin cells explained, fast/4d (share)",
       [](const PlanResult& p) { return static_cast<double>(p.fast4d.pixels) / static_cast<double>(p.skin_cells); });
  show("subject / white exposure, D65'", [](const PlanResult& p) { return p.subject_ratio_d65; });
  show("subject / white exposure, W57+blue", [](const PlanResult& p) { return p.subject_ratio_blue; });

  const auto csv = out / "exposure_plan.csv";
  {
    std::ofstream f(csv);
    f << "seed,before_de_fast4d,after_de_fast4d,before_de_fastauto,after_de_fastauto,before_blue_rel_noise,"
         "after_blue_rel_noise,before_d65b_rel_noise,after_d65b_rel_noise,before_blue_rel_pred,after_blue_rel_pred,"
         "refs_de_fast4d,refs_de_fastauto,refs_blue_rel_noise,refs_d65b_rel_noise,subject_de_fast4d,subject_de_fastauto,"
         "subject_ratio_d65,subject_ratio_blue,subject_saturated_cells\n";
    for (const auto& r : results)
      f << r.seed << "," << r.before.fast4d.de_all << "," << r.after.fast4d.de_all << "," << r.before.fastauto.de_all
        << "," << r.after.fastauto.de_all << "," << r.before.blue_relative_measured << ","
        << r.after.blue_relative_measured << "," << r.before.d65_b_relative_measured << ","
        << r.after.d65_b_relative_measured << "," << r.before.blue_relative_predicted << ","
        << r.after.blue_relative_predicted << "," << r.refs.fast4d.de_all << "," << r.refs.fastauto.de_all << ","
        << r.refs.blue_relative_measured << "," << r.refs.d65_b_relative_measured << "," << r.subject.fast4d.de_all << ","
        << r.subject.fastauto.de_all << "," << r.subject.subject_ratio_d65 << "," << r.subject.subject_ratio_blue << ","
        << r.subject.saturated_pixels << "\n";
  }
  files::GnuplotChart chart;
  chart.png = out / "exposure_plan.png";
  chart.commands = "set datafile separator ','\nset key top right\nset style data histograms\nset style fill solid 0.8\n"
                   "set title 'Standard plan: one exposure, exposure per capture, + reference frames, + subject exposure (skin, noisy)'\n"
                   "set xlabel 'scene seed'\nset ylabel 'relit dE94 vs truth, fast/4d (six LEDs + D65)'\nset yrange [0:*]\n"
                   "plot '" + csv.string() + "' every ::1 using 2:xtic(1) title 'before: one exposure', '' every ::1 using 3 "
                   "title 'after: exposure per capture', '' every ::1 using 12 title 'refs: after + " +
                   std::to_string(reference_frames) + " reference frames', '' every ::1 using 16 title 'subject: refs + "
                   "subject exposure metered'\n";
  if (const std::string error = files::draw_chart(chart); !error.empty()) std::printf("chart: %s\n", error.c_str());
  std::printf("wrote %s and %s\n", csv.c_str(), (out / "exposure_plan.png").c_str());
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) {
  try {
    return chromo::bench::bench_main(argc, argv);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "exposure_plan_bench: %s\n", error.what());
    return 1;
  }
}
