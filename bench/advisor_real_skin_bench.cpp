// The plan advisor's predicted parameter σ against the σ measured on real
// skin (issue 37): does the advisor, with the learned discrepancy, predict
// what a plan delivers on measured spectra, and without it how far off is it?
//
// Folds: the 50 NIST forearm subjects in 5 folds by index (subject i in fold
// i mod 5). For each fold the discrepancy is learned from the other 40
// subjects' residuals only; the population is the fold's 10 held-out
// subjects, each at its 4D full-spectrum fit (the reference parameters).
// Per plan (the method's and the multispectral plan, 1-64 frames per
// capture; nominal LED library, the virtual lab's camera):
//   predicted σ, camera noise alone   predict_plan without a discrepancy
//   predicted σ, with the discrepancy predict_plan with the fold's discrepancy
//   measured σ                        monte_carlo_check on the held-out
//                                     spectra themselves (frames simulated
//                                     from the measured spectrum, fitted by
//                                     bounded weighted least squares weighed
//                                     by camera noise plus the discrepancy,
//                                     as the estimator weighs them): RMS of
//                                     fit − reference parameters.
// Printed per plan and fold, then the ratio predicted / measured per
// parameter as mean [min, max] over the folds, for both predictions.
//
//   advisor_real_skin_bench [--frames 1,4,16,64] [--draws 8] [--out DIR]
//
// Writes DIR/advisor_real_skin.csv and DIR/advisor_real_skin.png (σ_Cm
// against frames per capture: both predictions and the measurement, per plan).
#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "bench_cli.hpp"

#include "chart.hpp"
#include "chromo/calibration/led_library.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/estimation/spectrum_fit.hpp"
#include "chromo/planning/plan_advisor.hpp"
#include "chromo/planning/plan_description.hpp"
#include "guarded_main.hpp"

namespace chromo::bench {
namespace {

constexpr int kFolds = 5;
constexpr const char* kParameters[4] = {"Cm", "Ch", "Bm", "Che"};

std::array<double, 4> as_array(const planning::ParameterSigma& s) { return {s.cm, s.ch, s.bm, s.che}; }

struct Row {
  std::string plan;
  int frames = 1, fold = 0;
  std::array<double, 4> noise_only{}, with_discrepancy{}, measured{};
  double de_noise_only = 0, de_with_discrepancy = 0, de_measured = 0;
  double bound_share = 0;  // the measured fits with a parameter on a bound of the box
};

int run(int argc, char** argv) {
  CLI::App app{"the plan advisor's predicted σ against the σ measured on held-out real skin spectra"};
  std::vector<int> frames{1, 4, 16, 64};
  int draws = 8;
  std::string out = "bench/results";
  app.add_option("--frames", frames, "frames per capture")->delimiter(',')->check(CLI::Range(1, 256));
  app.add_option("--draws", draws, "Monte Carlo draws per held-out spectrum")->check(CLI::Range(1, 1000));
  app.add_option("--out", out, "output directory");
  CLI11_PARSE(app, argc, argv);

  const calibration::LedLibrary library = calibration::nominal_led_library();
  const planning::CameraNoise camera;
  const auto& spectra = estimation::nist_forearm_spectra();
  const auto& residuals = estimation::nist_forearm_residuals();
  std::fprintf(stderr, "fitting the reference parameters of %zu subjects...\n", spectra.size());
  std::vector<estimation::SkinParameters> references(spectra.size());
#pragma omp parallel for schedule(dynamic)
  for (std::size_t i = 0; i < spectra.size(); ++i) references[i] = estimation::fit_spectrum(spectra[i].albedo).parameters;
  // How many references sit on a bound of the box, per parameter (the measured fits are clipped there, the
  // prediction is not).
  {
    int on[4] = {};
    for (const auto& r : references) {
      const double v[4] = {r.cm, r.ch, r.bm, r.che};
      const estimation::ParameterRange* ranges[4] = {&estimation::kCmRange, &estimation::kChRange, &estimation::kBmRange,
                                                     &estimation::kCheRange};
      for (int p = 0; p < 4; ++p)
        on[p] += std::abs(v[p] - ranges[p]->min) < 1e-3 * (ranges[p]->max - ranges[p]->min) ||
                 std::abs(v[p] - ranges[p]->max) < 1e-3 * (ranges[p]->max - ranges[p]->min);
    }
    std::printf("references within 0.1%% of the box's width of a bound: Cm %d, Ch %d, Bm %d, Che %d of %zu\n", on[0], on[1],
                on[2], on[3], references.size());
  }

  std::vector<Row> rows;
  for (int fold = 0; fold < kFolds; ++fold) {
    std::vector<estimation::SpectrumResidual> train;
    planning::AdvisorOptions options;
    options.threads = 2;
    planning::MonteCarloOptions mc;
    mc.draws_per_skin = draws;
    for (std::size_t i = 0; i < spectra.size(); ++i) {
      if (static_cast<int>(i % kFolds) == fold) {
        options.population.skins.push_back(references[i]);
        mc.measured_albedo.push_back(spectra[i].albedo);
      } else {
        train.push_back(residuals[i]);
      }
    }
    const auto learned = std::make_shared<const estimation::ModelDiscrepancy>(estimation::ModelDiscrepancy::learn(train));
    for (const std::string base : {"method", "multispectral"})
      for (int n : frames) {
        const std::string name = n == 1 ? base : base + "@" + std::to_string(n);
        const planning::PlanDescription plan = planning::builtin_plan(name, library);
        Row row{base, n, fold};
        options.discrepancy = nullptr;
        const planning::PlanPrediction noise_only = planning::predict_plan(plan, library, camera, options);
        options.discrepancy = learned;
        const planning::PlanPrediction with = planning::predict_plan(plan, library, camera, options);
        const planning::MonteCarloCheck measured = planning::monte_carlo_check(plan, library, camera, options, mc, with);
        row.noise_only = as_array(noise_only.sigma), row.with_discrepancy = as_array(with.sigma);
        row.measured = as_array(measured.rms_error);
        row.de_noise_only = noise_only.delta_e94_mean, row.de_with_discrepancy = with.delta_e94_mean;
        row.de_measured = measured.delta_e94_mean;
        row.bound_share = measured.bound_share;
        rows.push_back(row);
      }
    std::fprintf(stderr, "fold %d of %d done\n", fold + 1, kFolds);
  }

  std::printf("advisor_real_skin_bench: %d folds by subject, 10 held-out NIST forearms each at their 4D fit, %d draws "
              "per spectrum; nominal LED library, the virtual lab's camera\n",
              kFolds, draws);
  std::printf("σ per parameter: predicted on camera noise alone / predicted with the fold's learned discrepancy / "
              "measured on the held-out spectra; relit ΔE94 (mean over D65, A, six LEDs) the same three\n\n");
  std::printf("%-14s %3s %4s  %-28s %-28s %-28s %-28s %-24s\n", "plan", "N", "fold", "σ Cm", "σ Ch", "σ Bm", "σ Che",
              "ΔE94");
  std::filesystem::create_directories(out);
  std::ofstream csv(std::filesystem::path(out) / "advisor_real_skin.csv");
  csv << "plan,frames,fold";
  for (const char* p : kParameters) csv << ",sigma_" << p << "_noise_only,sigma_" << p << "_with_discrepancy,sigma_" << p << "_measured";
  csv << ",de94_noise_only,de94_with_discrepancy,de94_measured\n";
  for (const Row& r : rows) {
    std::printf("%-14s %3d %4d ", r.plan.c_str(), r.frames, r.fold);
    csv << r.plan << "," << r.frames << "," << r.fold;
    for (int p = 0; p < 4; ++p) {
      std::printf(" %8.5f/%8.5f/%8.5f ", r.noise_only[p], r.with_discrepancy[p], r.measured[p]);
      csv << "," << r.noise_only[p] << "," << r.with_discrepancy[p] << "," << r.measured[p];
    }
    std::printf(" %6.3f/%6.3f/%6.3f  on a bound %4.1f%%\n", r.de_noise_only, r.de_with_discrepancy, r.de_measured,
                100 * r.bound_share);
    csv << "," << r.de_noise_only << "," << r.de_with_discrepancy << "," << r.de_measured << "\n";
  }

  std::printf("\npredicted / measured σ, mean [min, max] over %d folds:\n", kFolds);
  std::printf("%-14s %3s  %-13s %-22s %-22s %-22s %-22s %-22s\n", "plan", "N", "prediction", "Cm", "Ch", "Bm", "Che",
              "ΔE94");
  std::vector<LineSeries> series;
  for (const std::string base : {"method", "multispectral"}) {
    LineSeries noise{base + " predicted, camera noise alone", {}}, with{base + " predicted, with discrepancy", {}},
        measured{base + " measured on real skin", {}};
    for (int n : frames) {
      std::vector<const Row*> fold_rows;
      for (const Row& r : rows)
        if (r.plan == base && r.frames == n) fold_rows.push_back(&r);
      auto spread = [&](auto get) {
        double sum = 0, lo = get(*fold_rows[0]), hi = lo;
        for (const Row* r : fold_rows) sum += get(*r), lo = std::min(lo, get(*r)), hi = std::max(hi, get(*r));
        char b[64];
        std::snprintf(b, sizeof b, "%.2f [%.2f, %.2f]", sum / fold_rows.size(), lo, hi);
        return std::string(b);
      };
      for (const bool discrepancy : {false, true}) {
        std::printf("%-14s %3d  %-13s", base.c_str(), n, discrepancy ? "with disc." : "noise alone");
        for (int p = 0; p < 4; ++p)
          std::printf(" %-22s", spread([&](const Row& r) {
                                  return (discrepancy ? r.with_discrepancy[p] : r.noise_only[p]) / r.measured[p];
                                }).c_str());
        std::printf(" %-22s\n", spread([&](const Row& r) {
                                  return (discrepancy ? r.de_with_discrepancy : r.de_noise_only) / r.de_measured;
                                }).c_str());
      }
      double a = 0, b = 0, c = 0;
      for (const Row* r : fold_rows) a += r->noise_only[0], b += r->with_discrepancy[0], c += r->measured[0];
      noise.points.emplace_back(n, a / fold_rows.size());
      with.points.emplace_back(n, b / fold_rows.size());
      measured.points.emplace_back(n, c / fold_rows.size());
    }
    series.push_back(noise), series.push_back(with), series.push_back(measured);
  }
  const auto png = std::filesystem::path(out) / "advisor_real_skin.png";
  if (write_line_chart(png, "plan advisor: predicted against measured σ Cm on held-out real skin (5 folds)",
                       "frames per capture", "σ Cm (mean over folds)", series, true))
    std::printf("\nchart: %s\n", png.c_str());
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) {
  return chromo::bench::guarded_main("advisor_real_skin_bench", chromo::bench::run, argc, argv);
}
