// Why one held-out subject is flagged whole (issue 37, subject_006 in fold 0
// of real_skin_bench): is its skin outside the model's range, its spectrum a
// measurement artefact, or the flag rule too tight?
//
// For each of the 50 NIST forearms, held out in 5 folds by subject (subject i
// in fold i mod 5, as real_skin_bench): its 4D full-spectrum fit (relit ΔE94
// under D65 and A, the parameters, whether they sit on the model's box), its
// residual r = measured − fit (RMS over 430-680 nm, absolute and relative to
// the albedo, and the tilt: mean over 620-680 nm − mean over 440-520 nm), and
// the residual's Mahalanobis distance D² = (W r)ᵀ (W Σ_r Wᵀ)⁻¹ (W r) in the
// six LEDs' 18 channels and the method's 4, Σ_r the discrepancy learned from
// the other folds' 40 subjects (held out) or from the subject's own training
// set (D² in-sample, for the folds that train on it). D² is χ²(C) if the
// subject's residual were drawn like the training ones; the 0.99 quantiles
// are printed beside.
//
//   subject_outlier_bench [--out DIR]
//
// Writes DIR/subject_outlier.png (the residual spectra of the subjects whose
// held-out six-LED D² exceeds its 0.99 quantile, beside ±2√diag(Σ_r) of
// fold 0's training set, the fold holding subject_006), its .dat/.gp, and prints a table per subject.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "bench_cli.hpp"
#include <Eigen/Cholesky>

#include "chart.hpp"
#include "chromo/estimation/measurement.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/estimation/skin_parameters.hpp"
#include "chromo/estimation/spectrum_fit.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/grid.hpp"
#include "guarded_main.hpp"
#include "real_skin_camera.hpp"

namespace chromo::bench {
namespace {

constexpr int kFolds = 5;

// Mean of `s` over [lo_nm, hi_nm].
double band_mean(const spectral::Spectrum& s, double lo_nm, double hi_nm) {
  double sum = 0;
  int n = 0;
  for (int i = 0; i < spectral::kGridSize; ++i)
    if (spectral::grid_wavelength_nm(i) >= lo_nm && spectral::grid_wavelength_nm(i) <= hi_nm) sum += s[i], ++n;
  return sum / n;
}

// RMS of `r` (divided by `albedo` when given) over 430-680 nm.
double band_rms(const spectral::Spectrum& r, const spectral::Spectrum* albedo) {
  double sum = 0;
  int n = 0;
  for (int i = 0; i < spectral::kGridSize; ++i)
    if (spectral::grid_wavelength_nm(i) >= 430 && spectral::grid_wavelength_nm(i) <= 680) {
      const double v = albedo ? r[i] / (*albedo)[i] : r[i];
      sum += v * v, ++n;
    }
  return std::sqrt(sum / n);
}

// (W r)ᵀ (W Σ_r Wᵀ)⁻¹ (W r) for the plan's weights W.
double mahalanobis(const estimation::ModelDiscrepancy& d, const estimation::MeasurementSet& set,
                   const spectral::Spectrum& residual) {
  const Eigen::MatrixXd w = set.weights();
  Eigen::VectorXd r(spectral::kGridSize);
  for (int i = 0; i < spectral::kGridSize; ++i) r[i] = residual[i];
  const Eigen::VectorXd wr = w * r;
  return wr.dot(d.channel_covariance(set).ldlt().solve(wr));
}

bool on_box(const estimation::SkinParameters& p) {
  auto at = [](double v, const estimation::ParameterRange& range) {
    return v <= range.min * 1.0001 || v >= range.max * 0.9999;
  };
  return at(p.cm, estimation::kCmRange) || at(p.ch, estimation::kChRange) || at(p.bm, estimation::kBmRange) ||
         at(p.che, estimation::kCheRange);
}

int run(int argc, char** argv) {
  CLI::App app{"why a held-out real-skin subject is flagged: its fit, residual and distance from the training residuals"};
  std::string out = "bench/results";
  app.add_option("--out", out, "output directory");
  CLI11_PARSE(app, argc, argv);

  const auto& spectra = estimation::nist_forearm_spectra();
  const auto& residuals = estimation::nist_forearm_residuals();
  const spectral::CameraSensitivity camera = spectral::builtin_camera("nikon_d5100");
  const estimation::MeasurementSet six = six_led_measurement_set(camera);
  const estimation::MeasurementSet method = estimation::method_measurement_set(
      camera, spectral::led_d65_metamer(), spectral::led_spectrum(spectral::LedType::kBlue));
  std::vector<estimation::SpectrumFitResult> fits(spectra.size());
#pragma omp parallel for schedule(dynamic)
  for (std::size_t i = 0; i < spectra.size(); ++i) fits[i] = estimation::fit_spectrum(spectra[i].albedo);

  std::vector<estimation::ModelDiscrepancy> learned;  // per fold, from the other 40
  for (int fold = 0; fold < kFolds; ++fold) {
    std::vector<estimation::SpectrumResidual> train;
    for (std::size_t i = 0; i < residuals.size(); ++i)
      if (static_cast<int>(i % kFolds) != fold) train.push_back(residuals[i]);
    learned.push_back(estimation::ModelDiscrepancy::learn(train));
  }
  // χ²(C) 0.99 quantiles (C = 18, 4).
  constexpr double kChi2_18 = 34.81, kChi2_4 = 13.28;
  std::printf("subject_outlier_bench: 50 NIST forearms, 5 folds by subject; D2 of the residual in a plan's channels "
              "under the discrepancy of the other folds (held out) and, in-sample, of a fold that trains on it; "
              "chi2 0.99 quantile: 18 ch %.1f, 4 ch %.1f\n\n",
              kChi2_18, kChi2_4);
  std::printf("%-12s %4s %7s %7s %7s %7s %7s %7s %4s %8s %8s %8s %9s %9s %9s\n", "subject", "fold", "fitD65", "fitA",
              "Cm", "Ch", "Bm", "Che", "box", "rms", "rel", "tilt", "D2six", "D2six_in", "D2method");
  std::vector<double> held_out_six;
  std::vector<LineSeries> series;
  for (std::size_t i = 0; i < spectra.size(); ++i) {
    const int fold = static_cast<int>(i % kFolds);
    const auto& f = fits[i];
    const spectral::Spectrum& r = residuals[i].residual;
    const double d_six = mahalanobis(learned[fold], six, r);
    const double d_six_in = mahalanobis(learned[(fold + 1) % kFolds], six, r);
    const double d_method = mahalanobis(learned[fold], method, r);
    held_out_six.push_back(d_six);
    std::printf("%-12s %4d %7.3f %7.3f %7.4f %7.4f %7.3f %7.4f %4s %8.4f %8.3f %+8.4f %9.1f %9.1f %9.1f\n",
                spectra[i].name.c_str(), fold, f.de94_d65, f.de94_a, f.parameters.cm, f.parameters.ch, f.parameters.bm,
                f.parameters.che, on_box(f.parameters) ? "yes" : "", band_rms(r, nullptr),
                band_rms(r, &spectra[i].albedo), band_mean(r, 620, 680) - band_mean(r, 440, 520), d_six, d_six_in,
                d_method);
    if (d_six > kChi2_18) {
      std::string name = spectra[i].name;
      std::replace(name.begin(), name.end(), '_', ' ');  // gnuplot's enhanced text reads _ as a subscript
      LineSeries s{name + " (held-out D2 " + std::to_string(static_cast<int>(d_six)) + ")", {}};
      for (int k = 0; k < spectral::kGridSize; ++k)
        if (spectral::grid_wavelength_nm(k) >= 400 && spectral::grid_wavelength_nm(k) <= 720)
          s.points.emplace_back(spectral::grid_wavelength_nm(k), r[k]);
      series.push_back(std::move(s));
    }
  }
  {  // the band of fold 0's training residuals (the fold holding subject_006)
    const spectral::Spectrum sigma = learned[0].sigma();
    LineSeries hi{"+2 sd of the training residuals (fold 0)", {}}, lo{"-2 sd (fold 0)", {}};
    for (int k = 0; k < spectral::kGridSize; ++k)
      if (spectral::grid_wavelength_nm(k) >= 400 && spectral::grid_wavelength_nm(k) <= 720)
        hi.points.emplace_back(spectral::grid_wavelength_nm(k), 2 * sigma[k]),
            lo.points.emplace_back(spectral::grid_wavelength_nm(k), -2 * sigma[k]);
    series.push_back(std::move(hi));
    series.push_back(std::move(lo));
  }
  std::vector<double> sorted = held_out_six;
  std::sort(sorted.begin(), sorted.end());
  std::printf("\nheld-out six-LED D2 over 50 subjects: median %.1f, 90th percentile %.1f, max %.1f; above %.1f: %td\n",
              sorted[sorted.size() / 2], sorted[sorted.size() * 9 / 10], sorted.back(), kChi2_18,
              std::count_if(sorted.begin(), sorted.end(), [&](double v) { return v > kChi2_18; }));
  const auto png = std::filesystem::path(out) / "subject_outlier.png";
  if (!series.empty() && write_line_chart(png, "residual of the 4D full-spectrum fit: subjects far from their training set",
                                          "wavelength (nm)", "measured - fitted (albedo)", series))
    std::printf("chart: %s\n", png.c_str());
  return 0;
}

}  // namespace
}  // namespace chromo::bench

int main(int argc, char** argv) {
  return chromo::bench::guarded_main("subject_outlier_bench", chromo::bench::run, argc, argv);
}
