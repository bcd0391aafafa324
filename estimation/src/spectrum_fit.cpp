#include "chromo/estimation/spectrum_fit.hpp"

#include <sstream>

#include <ceres/ceres.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "chromo/spectral/lab_illuminants.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/delta_e.hpp"

namespace chromo::estimation {

double surface_reflectance() {
  const double r = (kSkinRefractiveIndex - 1) / (kSkinRefractiveIndex + 1);
  return r * r;
}

bool SpectrumFitOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (order != 2 && order != 4) return fail("order must be 2 or 4");
  if (!(spectral_sigma > 0) || !(lab_sigma > 0)) return fail("spectral_sigma and lab_sigma must be > 0");
  if (starts < 1) return fail("starts must be >= 1");
  return true;
}

namespace {

const SkinModel& model() {
  static const SkinModel m;
  return m;
}

spectral::Lab lab_under(const spectral::Spectrum& r, const spectral::Spectrum& illuminant) {
  return spectral::lab_from_xyz(spectral::xyz_of_reflectance(r, illuminant), spectral::white_point(illuminant));
}

// ΔE94 split into its three weighted components (reference = measured).
std::array<double, 3> delta_e94_components(const spectral::Lab& ref, const spectral::Lab& s) {
  const double c1 = std::hypot(ref.a, ref.b), c2 = std::hypot(s.a, s.b);
  const double dh = std::atan2(s.b, s.a) - std::atan2(ref.b, ref.a);
  const double big_dh = 2 * std::sqrt(c1 * c2) * std::sin(dh / 2);
  return {s.L - ref.L, (c2 - c1) / (1 + 0.045 * c1), big_dh / (1 + 0.015 * c1)};
}

// Per-wavelength weight of the spectral residual, divided by σ and normalised
// so that the mean squared weight is 1/(σ²·81) as for the flat weighting.
std::array<double, spectral::kGridSize> spectral_weights(const SpectrumFitOptions& options) {
  // The reporting illuminants' mean relative power (D65, A, six LED types, each to unit sum).
  spectral::Spectrum power = spectral::illuminant_d65() / spectral::illuminant_d65().values().sum() +
                             spectral::illuminant_a() / spectral::illuminant_a().values().sum();
  for (spectral::LedType t : spectral::kAllLedTypes) power = power + spectral::led_spectrum(t) / spectral::led_spectrum(t).values().sum();
  const spectral::Observer& o = spectral::cie1931_observer();
  std::array<double, spectral::kGridSize> w{};
  double sum_squares = 0;
  for (int i = 0; i < spectral::kGridSize; ++i) {
    const double l = spectral::grid_wavelength_nm(i);
    const double band = options.spectral_weighting == SpectralWeighting::kColourBand
                            ? std::sqrt((o.x_bar[i] + o.y_bar[i] + o.z_bar[i]) * power[i])
                            : 1.0;
    w[i] = l >= options.spectral_min_nm && l <= options.spectral_max_nm ? band : 0.0;
    sum_squares += band * band;
  }
  const double scale = std::sqrt(spectral::kGridSize / sum_squares) / (options.spectral_sigma * std::sqrt(spectral::kGridSize));
  for (double& v : w) v *= scale;
  return w;
}

struct Residual {
  const spectral::Spectrum* measured;
  spectral::Lab measured_lab;
  const SpectrumFitOptions* options;
  double specular;
  std::array<double, spectral::kGridSize> weight;
  SkinParameters to_parameters(const double* x) const {
    return options->order == 4 ? SkinParameters{x[0], x[1], x[2], x[3]}
                               : SkinParameters{x[0], x[1], kModel2dBm, kModel2dChe};
  }
  bool operator()(const double* x, double* residual) const {
    const double surface = options->free_specular ? x[options->order] : specular;
    const spectral::Spectrum a = model().albedo(to_parameters(x)) + spectral::Spectrum::constant(surface);
    for (int i = 0; i < spectral::kGridSize; ++i) {
      const double difference = a[i] - (*measured)[i];
      residual[i] = weight[i] * difference;
    }
    const auto lab = delta_e94_components(measured_lab, lab_under(a, spectral::illuminant_d65()));
    for (int k = 0; k < 3; ++k) residual[spectral::kGridSize + k] = lab[k] / options->lab_sigma;
    return true;
  }
  double cost(const double* x) const {
    double r[spectral::kGridSize + 3];
    (*this)(x, r);
    double s = 0;
    for (double v : r) s += v * v;
    return s;
  }
};

}  // namespace

SpectrumFitResult fit_spectrum(const spectral::Spectrum& measured, const SpectrumFitOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("fit options: " + error);
  if (!measured.values().allFinite()) throw std::invalid_argument("measured spectrum has non-finite values");
  // A reflectance factor: 0..1, a little beyond with noise or fluorescence.
  // Percentages or anything larger are refused, not fitted to NaN.
  if (measured.values().minCoeff() < kMinFitReflectance || measured.values().maxCoeff() > kMaxFitReflectance)
    throw std::invalid_argument("reflectance " +
                                (std::ostringstream() << (measured.values().maxCoeff() > kMaxFitReflectance
                                                              ? measured.values().maxCoeff()
                                                              : measured.values().minCoeff()))
                                    .str() +
                                " is outside [-0.1, 1.5] (a reflectance factor 0..1 is expected, not percent)");
  const double specular = options.specular_included ? surface_reflectance() : 0.0;
  Residual residual{&measured, lab_under(measured, spectral::illuminant_d65()), &options, specular,
                    spectral_weights(options)};

  // Coarse grid of starting points (log-spaced Cm, Ch).
  struct Start {
    double cost;
    std::array<double, 5> x;
  };
  std::vector<Start> starts;
  std::array<double, 5> lo{kCmRange.min, kChRange.min, kBmRange.min, kCheRange.min, 0.0};
  std::array<double, 5> hi{kCmRange.max, kChRange.max, kBmRange.max, kCheRange.max, 0.1};
  if (options.order == 2) lo[2] = 0.0, hi[2] = 0.1;
  const int bm_steps = options.order == 4 ? 3 : 1, che_steps = options.order == 4 ? 3 : 1;
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j)
      for (int k = 0; k < bm_steps; ++k)
        for (int l = 0; l < che_steps; ++l) {
          std::array<double, 5> x{0.002 * std::pow(150.0, i / 7.0), 0.002 * std::pow(100.0, j / 7.0),
                                  bm_steps > 1 ? 0.15 + 0.35 * k : kModel2dBm, che_steps > 1 ? 0.01 + 0.03 * l : 0.0,
                                  specular};
          if (options.order == 2) x[2] = specular;
          starts.push_back({residual.cost(x.data()), x});
        }
  std::sort(starts.begin(), starts.end(), [](const Start& a, const Start& b) { return a.cost < b.cost; });

  const int n = options.order + (options.free_specular ? 1 : 0);
  SpectrumFitResult best;
  best.cost = std::numeric_limits<double>::infinity();
  std::array<double, 5> best_x{};
  for (int s = 0; s < std::min<int>(options.starts, starts.size()); ++s) {
    std::array<double, 5> x = starts[s].x;
    ceres::Problem problem;
    ceres::CostFunction* cost = nullptr;
    constexpr int kResiduals = spectral::kGridSize + 3;
    switch (n) {
      case 2: cost = new ceres::NumericDiffCostFunction<Residual, ceres::CENTRAL, kResiduals, 2>(new Residual(residual)); break;
      case 3: cost = new ceres::NumericDiffCostFunction<Residual, ceres::CENTRAL, kResiduals, 3>(new Residual(residual)); break;
      case 4: cost = new ceres::NumericDiffCostFunction<Residual, ceres::CENTRAL, kResiduals, 4>(new Residual(residual)); break;
      default: cost = new ceres::NumericDiffCostFunction<Residual, ceres::CENTRAL, kResiduals, 5>(new Residual(residual));
    }
    problem.AddResidualBlock(cost, nullptr, x.data());
    for (int k = 0; k < n; ++k) {
      problem.SetParameterLowerBound(x.data(), k, lo[k]);
      problem.SetParameterUpperBound(x.data(), k, hi[k]);
    }
    ceres::Solver::Options solver;
    solver.linear_solver_type = ceres::DENSE_QR;
    solver.max_num_iterations = 200;
    solver.function_tolerance = 1e-12;
    solver.parameter_tolerance = 1e-12;
    solver.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(solver, &problem, &summary);
    if (summary.final_cost < best.cost) {
      best.cost = summary.final_cost;
      best_x = x;
      best.solver_report = summary.BriefReport();
    }
  }
  best.parameters = residual.to_parameters(best_x.data());
  best.specular = options.free_specular ? best_x[options.order] : specular;
  best.fitted = model().albedo(best.parameters) + spectral::Spectrum::constant(best.specular);
  best.rms = std::sqrt((best.fitted - measured).values().square().mean());
  auto de = [&](const spectral::Spectrum& illuminant) {
    return spectral::delta_e94(lab_under(measured, illuminant), lab_under(best.fitted, illuminant));
  };
  best.de94_d65 = de(spectral::illuminant_d65());
  best.de94_a = de(spectral::illuminant_a());
  for (int i = 0; i < spectral::kLedTypeCount; ++i) {
    best.de94_led[i] = de(spectral::led_spectrum(spectral::kAllLedTypes[i]));
    best.de94_led_mean += best.de94_led[i] / spectral::kLedTypeCount;
  }
  return best;
}

}  // namespace chromo::estimation
