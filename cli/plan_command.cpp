// chromo plan compare [PLAN...]: the plan advisor (planning/, docs/plan-advisor.md)
// on built-in plans and plan files — capture time, σ per parameter, predicted
// relit ΔE94 per reference illuminant and its Monte Carlo check — as a table
// and a chart of accuracy against capture time.
#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <vector>
#include <nlohmann/json.hpp>

#include "chromo/calibration/led_library.hpp"
#include "chromo/calibration/led_library_io.hpp"
#include "chromo/files/bounded_read.hpp"
#include "chromo/files/gnuplot_chart.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/planning/plan_advisor.hpp"
#include "chromo/planning/plan_description.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/spectral/camera.hpp"
#include "commands.hpp"

namespace chromo::cli {
namespace {

struct PlanCompareOptions {
  std::vector<std::string> plans;
  std::string library = "lab";   // "lab", "nominal" or an LED library JSON
  std::string camera = "nikon_d5100";
  std::string population = "skin";  // "skin" (MODEL.md's skin box) or "interior"
  int skins = 64;
  std::uint64_t seed = 1;
  int mc_draws = 2;              // Monte Carlo draws per skin; 0: no check
  int threads = 2;
  std::string discrepancy = "learned";  // "learned" or "none" (AdvisorOptions::discrepancy)
  std::string chart = "plan_compare.png";
  bool json = false;
};

// A plan argument: a built-in name (optionally @N) or a JSON file of docs/formats/plan-advisor.md.
planning::PlanDescription load_plan(const std::string& argument, const calibration::LedLibrary& library) {
  const std::filesystem::path path(argument);
  if (path.extension() == ".json" || std::filesystem::is_regular_file(path)) {
    const std::string text = files::read_text_file(path, "plan file");
    nlohmann::json json;
    try {
      json = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
      throw std::invalid_argument(argument + ": not JSON: " + e.what());
    }
    try {
      return planning::plan_from_json(json);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(argument + ": " + e.what());
    }
  }
  return planning::builtin_plan(argument, library);
}

// The LED library plan compare models: capture times need a library in the
// camera model's irradiance units: the virtual lab's true LEDs are; the
// nominal library's spectra are relative (radiant flux 1 per white COB), so
// its exposures are only relative.
calibration::LedLibrary advisor_library(const PlanCompareOptions& o) {
  return o.library == "lab"       ? simulators::lab_led_library()
         : o.library == "nominal" ? calibration::nominal_led_library()
                                  : calibration::load_led_library(o.library);
}

// The advisor's options from the command line; std::invalid_argument naming the option.
planning::AdvisorOptions advisor_options(const PlanCompareOptions& o) {
  planning::AdvisorOptions options;
  if (o.population == "interior") options.population = planning::interior_population();
  else if (o.population != "skin") throw std::invalid_argument("--population: must be 'skin' or 'interior'");
  options.population.count = o.skins;
  options.population.seed = o.seed;
  options.threads = o.threads;
  if (o.discrepancy == "learned") options.discrepancy = estimation::ModelDiscrepancy::standard();
  else if (o.discrepancy != "none") throw std::invalid_argument("--discrepancy: must be 'learned' or 'none'");
  if (std::string error; !options.IsValid(&error)) throw std::invalid_argument("--skins/--threads: " + error);
  return options;
}

struct PlanComparison {
  std::vector<planning::PlanPrediction> predictions;
  std::vector<std::optional<planning::MonteCarloCheck>> checks;  // per plan; empty without --mc-draws
};

void print_comparison_json(const PlanCompareOptions& o, const PlanComparison& compared) {
  const auto& predictions = compared.predictions;
  const auto& checks = compared.checks;
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < predictions.size(); ++i) {
    const auto& p = predictions[i];
    nlohmann::ordered_json row{{"plan", p.plan}, {"channels", p.channels}, {"subject_s", p.time.subject_s},
                               {"reference_s", p.time.reference_s},
                               {"sigma", {{"cm", p.sigma.cm}, {"ch", p.sigma.ch}, {"bm", p.sigma.bm}, {"che", p.sigma.che}}},
                               {"illuminants", p.illuminants}, {"predicted_delta_e94", p.delta_e94},
                               {"predicted_delta_e94_mean", p.delta_e94_mean}, {"skins", p.skins},
                               {"discrepancy", o.discrepancy}};
    if (checks[i]) {
      const auto& c = *checks[i];
      row["monte_carlo"] = {{"delta_e94", c.delta_e94}, {"delta_e94_mean", c.delta_e94_mean}, {"ratio", c.ratio},
                            {"bound_share", c.bound_share}, {"fits", c.fits}, {"failed_fits", c.failed_fits}};
    }
    out.push_back(row);
  }
  std::cout << out.dump(2) << "\n";
}

void print_comparison_table(const PlanCompareOptions& o, const planning::AdvisorOptions& options,
                            const PlanComparison& compared) {
  const auto& predictions = compared.predictions;
  const auto& checks = compared.checks;
  fmt::print("# plan advisor: {} skins ({} population, seed {}), camera {}, library {}, discrepancy {}\n",
             options.population.count, o.population, o.seed, o.camera, o.library, o.discrepancy);
  fmt::print("# σ: Cramér-Rao RMS over the skins; ΔE94: predicted mean relit ΔE94; MC: Monte Carlo fits' mean, "
             "ratio = predicted/MC, bound = share of fits on a range edge\n");
  fmt::print("{:<18} {:>3} {:>9} {:>9} {:>8} {:>8} {:>7} {:>7}", "plan", "ch", "subject_s", "refs_s", "σCm", "σCh",
             "σβm", "σChe");
  for (const std::string& name : predictions.front().illuminants) fmt::print(" {:>6}", name);
  fmt::print(" {:>6} {:>6} {:>6} {:>6}\n", "mean", "MC", "ratio", "bound");
  for (std::size_t i = 0; i < predictions.size(); ++i) {
    const auto& p = predictions[i];
    fmt::print("{:<18} {:>3} {:>9.3f} {:>9.3f} {:>8.5f} {:>8.5f} {:>7.4f} {:>7.4f}", p.plan, p.channels.size(),
               p.time.subject_s, p.time.reference_s, p.sigma.cm, p.sigma.ch, p.sigma.bm, p.sigma.che);
    for (double d : p.delta_e94) fmt::print(" {:>6.3f}", d);
    fmt::print(" {:>6.3f}", p.delta_e94_mean);
    if (checks[i]) fmt::print(" {:>6.3f} {:>6.2f} {:>6.2f}\n", checks[i]->delta_e94_mean, checks[i]->ratio, checks[i]->bound_share);
    else fmt::print(" {:>6} {:>6} {:>6}\n", "-", "-", "-");
  }
}

// The chart of accuracy against capture time (o.chart, its data beside it as
// CSV); false (said on stderr) when gnuplot could not draw it.
bool write_comparison_chart(const PlanCompareOptions& o, const PlanComparison& compared) {
  const auto& predictions = compared.predictions;
  const auto& checks = compared.checks;
  const std::filesystem::path png(o.chart);
  std::filesystem::path csv = png;
  csv.replace_extension(".csv");
  {
    std::ofstream out(csv);
    out << "plan,subject_s,predicted_delta_e94,monte_carlo_delta_e94\n";
    for (std::size_t i = 0; i < predictions.size(); ++i)
      out << predictions[i].plan << "," << predictions[i].time.subject_s << "," << predictions[i].delta_e94_mean << ","
          << (checks[i] ? checks[i]->delta_e94_mean : std::nan("")) << "\n";
    if (!out) throw std::runtime_error(csv.string() + ": cannot be written");
  }
  files::GnuplotChart chart;
  chart.png = png;
  chart.commands = fmt::format(
      "set datafile separator ','\nset key top right\nset grid\n"
      "set title 'Plan advisor: predicted relit {{/Symbol D}}E94 (mean over D65, A, six LEDs) vs capture time'\n"
      "set xlabel 'subject capture time (s)'\nset ylabel 'mean relit {{/Symbol D}}E94'\nset logscale x\n"
      "plot '{0}' every ::1 using 2:3 with points pt 7 ps 1.5 title 'predicted (Fisher)', "
      "'{0}' every ::1 using 2:4 with points pt 6 ps 2 title 'Monte Carlo fits', "
      "'{0}' every ::1 using 2:3:1 with labels noenhanced offset 0,1 notitle\n",
      csv.string());
  if (const std::string error = files::draw_chart(chart); !error.empty()) {
    std::cerr << "chromo plan compare: chart: " << error << "\n";
    return false;
  }
  if (!o.json) fmt::print("# chart: {} (data {})\n", png.string(), csv.string());
  return true;
}

int run_plan_compare(const PlanCompareOptions& o) {
  const calibration::LedLibrary library = advisor_library(o);
  planning::CameraNoise camera;
  camera.sensitivity = spectral::builtin_camera(o.camera);
  const planning::AdvisorOptions options = advisor_options(o);
  planning::MonteCarloOptions mc;
  mc.draws_per_skin = std::max(1, o.mc_draws);
  const std::vector<std::string> names =
      o.plans.empty() ? std::vector<std::string>{"standard", "standard@4", "standard-blue", "multispectral", "multispectral@4"}
                      : o.plans;
  std::vector<planning::PlanDescription> plans;
  for (const std::string& name : names) plans.push_back(load_plan(name, library));  // all checked before any work

  PlanComparison compared;
  for (const auto& plan : plans) {
    compared.predictions.push_back(planning::predict_plan(plan, library, camera, options));
    if (o.mc_draws > 0)
      compared.checks.push_back(planning::monte_carlo_check(plan, library, camera, options, mc, compared.predictions.back()));
    else
      compared.checks.emplace_back();
  }
  if (o.json) print_comparison_json(o, compared);
  else print_comparison_table(o, options, compared);
  if (!o.chart.empty() && !write_comparison_chart(o, compared)) return kExitFailure;
  return kExitOk;
}

}  // namespace

void add_plan_command(CLI::App& app, int& exit_status) {
  auto* plan = app.add_subcommand("plan", "the plan advisor: compare capture plans before capturing");
  plan->require_subcommand(1);
  auto options = std::make_shared<PlanCompareOptions>();
  auto* compare = plan->add_subcommand(
      "compare", "predicted parameter σ, relit ΔE94 and capture time of plans (built-in names: standard, standard-blue, "
                 "multispectral, d65, w57, w40, w27 and each broadband +blue (the seed's broadband study), each "
                 "optionally @N frames; or plan JSON files)");
  compare->add_option("plans", options->plans, "plans (default: standard standard@4 standard-blue multispectral multispectral@4)");
  compare->add_option("--library", options->library,
                      "lab (the virtual lab's true LEDs, in the camera model's units), nominal, or an LED library JSON")
      ->capture_default_str();
  compare->add_option("--camera", options->camera, "built-in camera sensitivity")->capture_default_str();
  compare->add_option("--population", options->population, "skin | interior")->capture_default_str();
  compare->add_option("--skins", options->skins, "skins averaged over (1-100000)")->capture_default_str();
  compare->add_option("--seed", options->seed, "population seed")->capture_default_str();
  compare->add_option("--mc-draws", options->mc_draws, "Monte Carlo draws per skin (0: no check)")
      ->capture_default_str()->check(CLI::Range(0, 1000));
  compare->add_option("--threads", options->threads, "threads (1-64)")->capture_default_str();
  compare->add_option("--discrepancy", options->discrepancy,
                      "learned: the skin model's learned discrepancy on real skin added to the camera noise, as the "
                      "estimator adds it; none: camera noise alone")
      ->capture_default_str();
  compare->add_option("--chart", options->chart, "chart PNG (beside it, its CSV); empty: none")->capture_default_str();
  compare->add_flag("--json", options->json, "print JSON instead of the table");
  compare->callback([options, &exit_status] { exit_status = run_plan_compare(*options); });
}

}  // namespace chromo::cli
