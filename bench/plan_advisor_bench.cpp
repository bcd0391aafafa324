// plan_advisor_bench: does the plan advisor (planning/, docs/plan-advisor.md)
// predict what a bounded fit of simulated frames achieves? For each plan
// (the method at 1 and 4 frames, the blue channel poorly exposed (the blue
// LED alone at 5% of full scale) and well exposed (85%), the six LED types
// one at a time at 1 and 4 frames), each skin population (MODEL.md's skin
// box, whose βm and Che reach their bounds, and the interior box) and each
// population seed (1-4: the advisor has no constant fitted to anything, so
// every seed is held out), it prints the predicted mean relit ΔE94 (D65, A,
// six LEDs), the Monte Carlo fits' and their ratio, and the share of fits on
// a range edge. Charts: predicted against Monte Carlo, and accuracy against
// capture time.
//
// Part two (issue 20 part 4): the cost of a longer plan in the virtual lab
// with subject motion on (simulators/scene/subject_motion.hpp, default
// amplitudes): the rendered session (256×192 sensor window of the 5-MP
// scene) at LED settle times 50-2000 ms per step, the registration error of
// the W57 and W57+blue captures against the true motion; chart: error
// against time since the reference capture.
//
// usage: plan_advisor_bench [--skins N] [--draws N] [--out DIR]
#include "bench_cli.hpp"
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <numeric>

#include "chromo/calibration/led_library.hpp"
#include "chromo/files/gnuplot_chart.hpp"
#include "chromo/planning/plan_advisor.hpp"
#include "chromo/planning/plan_description.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"

using namespace chromo;

namespace {

struct NamedPlan {
  std::string label;
  planning::PlanDescription plan;
};

std::vector<NamedPlan> bench_plans(const calibration::LedLibrary& library) {
  std::vector<NamedPlan> plans;
  plans.push_back({"standard@1", planning::builtin_plan("standard", library)});
  plans.push_back({"standard@4", planning::builtin_plan("standard@4", library)});
  planning::PlanDescription poor = planning::builtin_plan("standard-blue", library);
  poor.captures[1].white_fill = 0.05;
  poor.name = "blue-at-5%";
  plans.push_back({"blue-at-5%", poor});
  plans.push_back({"blue-at-85%", planning::builtin_plan("standard-blue", library)});
  plans.push_back({"multispectral@1", planning::builtin_plan("multispectral", library)});
  plans.push_back({"multispectral@4", planning::builtin_plan("multispectral@4", library)});
  return plans;
}

void draw(const std::filesystem::path& png, const std::string& commands) {
  files::GnuplotChart chart;
  chart.png = png;
  chart.terminal = "pngcairo size 900,600 font 'DejaVu Sans,10'";
  chart.commands = commands;
  std::filesystem::path script = png;
  script.replace_extension(".gp");
  if (const std::string error = files::draw_chart(chart, script); !error.empty())
    std::fprintf(stderr, "chart: %s\n", error.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"plan advisor: predicted vs Monte Carlo relit ΔE94; registration error vs plan duration"};
  int skins = 48, draws = 4, threads = 2;
  std::string out_dir = "bench/results/plan_advisor";
  bool skip_motion = false;
  app.add_option("--skins", skins, "skins per population and seed");
  app.add_option("--draws", draws, "Monte Carlo draws per skin");
  app.add_option("--threads", threads, "threads");
  app.add_option("--out", out_dir, "results folder");
  app.add_flag("--skip-motion", skip_motion, "advisor only");
  CLI11_PARSE(app, argc, argv);
  const std::filesystem::path out(out_dir);
  std::filesystem::create_directories(out);

  const calibration::LedLibrary library = simulators::lab_led_library();  // the lab's units: real exposures
  const planning::CameraNoise camera;
  const std::vector<NamedPlan> plans = bench_plans(library);
  std::ofstream csv(out / "advisor.csv");
  csv << "plan,population,seed,subject_s,predicted,monte_carlo,ratio,bound_share,predicted_A,monte_carlo_A\n";
  fmt::print("# plan advisor vs Monte Carlo: {} skins × {} draws per population and seed; ΔE94 = mean relit over D65, A, six LEDs\n",
             skins, draws);
  fmt::print("{:<16} {:<9} {:>4} {:>9} {:>9} {:>9} {:>6} {:>6}\n", "plan", "skins", "seed", "subject_s", "predicted", "MC", "ratio", "bound");
  std::vector<double> ratios_interior, ratios_skin;
  for (const char* population : {"skin", "interior"}) {
    for (std::uint64_t seed = 1; seed <= 4; ++seed) {
      for (const NamedPlan& p : plans) {
        planning::AdvisorOptions options;
        if (std::string(population) == "interior") options.population = planning::interior_population();
        options.population.count = skins;
        options.population.seed = seed;
        options.threads = threads;
        planning::MonteCarloOptions mc;
        mc.draws_per_skin = draws;
        mc.seed = 100 + seed;
        const planning::PlanPrediction prediction = planning::predict_plan(p.plan, library, camera, options);
        const planning::MonteCarloCheck check = planning::monte_carlo_check(p.plan, library, camera, options, mc, prediction);
        fmt::print("{:<16} {:<9} {:>4} {:>9.3f} {:>9.3f} {:>9.3f} {:>6.2f} {:>6.2f}\n", p.label, population, seed,
                   prediction.time.subject_s, prediction.delta_e94_mean, check.delta_e94_mean, check.ratio, check.bound_share);
        csv << p.label << "," << population << "," << seed << "," << prediction.time.subject_s << ","
            << prediction.delta_e94_mean << "," << check.delta_e94_mean << "," << check.ratio << "," << check.bound_share
            << "," << prediction.delta_e94[1] << "," << check.delta_e94[1] << "\n";
        (std::string(population) == "interior" ? ratios_interior : ratios_skin).push_back(check.ratio);
      }
    }
  }
  csv.close();
  for (const auto& [name, ratios] : {std::pair{"skin", &ratios_skin}, std::pair{"interior", &ratios_interior}}) {
    const auto [lo, hi] = std::minmax_element(ratios->begin(), ratios->end());
    const double mean = std::accumulate(ratios->begin(), ratios->end(), 0.0) / ratios->size();
    const auto within = std::count_if(ratios->begin(), ratios->end(), [](double r) { return r >= 0.75 && r <= 1.25; });
    fmt::print("# {} population: predicted/MC ratio mean {:.3f}, min {:.3f}, max {:.3f}; within ±25%: {} of {}\n", name,
               mean, *lo, *hi, within, ratios->size());
  }
  const std::string data = (out / "advisor.csv").string();
  draw(out / "advisor_predicted_vs_mc.png",
       fmt::format("set datafile separator ','\nset grid\nset key top left\nset logscale xy\n"
                   "set title 'Plan advisor: predicted vs Monte Carlo mean relit {{/Symbol D}}E94 (plans × populations × seeds)'\n"
                   "set xlabel 'Monte Carlo fits (bounded least squares)'\nset ylabel 'predicted (Fisher information)'\n"
                   "f(x)=x\nplot [0.1:5] '{0}' every ::1 using 6:(strcol(2) eq 'skin' ? $5 : 1/0) with points pt 7 title 'skin box', "
                   "'{0}' every ::1 using 6:(strcol(2) eq 'interior' ? $5 : 1/0) with points pt 6 ps 1.5 title 'interior box', "
                   "f(x) with lines lc 'black' title 'equal', 1.25*x with lines dt 2 lc 'gray' title '±25%', 0.75*x with lines dt 2 lc 'gray' notitle\n",
                   data));
  draw(out / "advisor_accuracy_vs_time.png",
       fmt::format("set datafile separator ','\nset grid\nset logscale x\nset key top right\n"
                   "set title 'Plan advisor: predicted relit {{/Symbol D}}E94 vs subject capture time (skin box, seed 1)'\n"
                   "set xlabel 'subject capture time (s)'\nset ylabel 'mean relit {{/Symbol D}}E94'\n"
                   "plot '{0}' every ::1 using 4:((strcol(2) eq 'skin' && $3 == 1) ? $5 : 1/0) with points pt 7 ps 1.5 title 'predicted', "
                   "'{0}' every ::1 using 4:((strcol(2) eq 'skin' && $3 == 1) ? $6 : 1/0) with points pt 6 ps 2 title 'Monte Carlo', "
                   "'{0}' every ::1 using 4:((strcol(2) eq 'skin' && $3 == 1) ? $5 : 1/0):1 with labels noenhanced offset 0,1 notitle\n",
                   data));
  fmt::print("# charts: {}/advisor_predicted_vs_mc.png, advisor_accuracy_vs_time.png\n", out.string());

  if (skip_motion) return 0;
  std::ofstream motion(out / "motion.csv");
  motion << "settle_ms,plan_s,capture,seconds_since_reference,found_motion_px,error_max_px,error_rms_px\n";
  fmt::print("\n# subject motion on (default amplitudes): registration error vs plan duration (256×192 sensor, 128×96 measurement)\n");
  fmt::print("{:>9} {:>7} {:<9} {:>7} {:>9} {:>9} {:>9}\n", "settle_ms", "plan_s", "capture", "t_s", "found_px", "err_max", "err_rms");
  for (std::uint32_t settle : {50u, 250u, 500u, 1000u, 2000u}) {
    simulators::RenderedSessionOptions o;
    o.sensor_width = 256, o.sensor_height = 192;
    o.scene_width = 2592, o.scene_height = 1944;
    o.window_x = 640, o.window_y = 1680;
    o.seed = 5;
    o.noise_free = false;
    o.threads = threads;
    o.motion.enabled = true;
    o.settle_ms = settle;
    const simulators::RenderedSession s = simulators::render_session(o);
    for (const simulators::CaptureMotion& c : s.motion) {
      fmt::print("{:>9} {:>7.2f} {:<9} {:>7.2f} {:>9.2f} {:>9.3f} {:>9.3f}\n", settle, s.plan_seconds, c.capture,
                 c.seconds_since_reference, c.found_motion_px, c.registration_error_max_px, c.registration_error_rms_px);
      motion << settle << "," << s.plan_seconds << "," << c.capture << "," << c.seconds_since_reference << ","
             << c.found_motion_px << "," << c.registration_error_max_px << "," << c.registration_error_rms_px << "\n";
    }
  }
  motion.close();
  draw(out / "motion_registration_error.png",
       fmt::format("set datafile separator ','\nset grid\nset key top left\n"
                   "set title 'Subject motion: registration error vs time since the reference capture'\n"
                   "set xlabel 'time since the reference (D65) subject capture (s)'\nset ylabel 'registration error (measurement px)'\n"
                   "plot '{0}' every ::1 using 4:6 with points pt 7 ps 1.5 title 'largest over the image', "
                   "'{0}' every ::1 using 4:7 with points pt 6 ps 1.5 title 'RMS over the image'\n",
                   (out / "motion.csv").string()));
  fmt::print("# chart: {}/motion_registration_error.png\n", out.string());
  return 0;
}
