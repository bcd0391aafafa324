#include "chromo/planning/plan_advisor.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "fit_bounded.hpp"
#include "plan_model.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/colorimetry.hpp"
#include "chromo/spectral/delta_e.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::planning {

namespace {

using estimation::SkinParameters;
using Vec4 = Eigen::Vector4d;

Vec4 as_vector(const SkinParameters& p) { return {p.cm, p.ch, p.bm, p.che}; }
SkinParameters as_parameters(const Vec4& v) { return {v[0], v[1], v[2], v[3]}; }

const estimation::SkinModel& skin_model() {
  static const estimation::SkinModel model;
  return model;
}

// Central-difference steps per parameter: relative for the volume fractions
// Cm and Ch (their effect is close to logarithmic), absolute for βm and Che.
Vec4 steps(const Vec4& p) {
  return {std::max(1e-6, 1e-3 * std::abs(p[0])), std::max(1e-6, 1e-3 * std::abs(p[1])), 1e-4, 1e-5};
}

struct Reference {
  std::string name;
  spectral::Spectrum spectrum;
  spectral::Xyz white;
};

Eigen::Vector3d lab_of(const spectral::Spectrum& albedo, const Reference& r) {
  const spectral::Lab lab = spectral::lab_from_xyz(spectral::xyz_of_reflectance(albedo, r.spectrum), r.white);
  return {lab.L, lab.a, lab.b};
}
spectral::Lab to_lab(const Eigen::Vector3d& v) { return {v[0], v[1], v[2]}; }

std::vector<Reference> references_of(const AdvisorOptions& options) {
  std::vector<Reference> out;
  for (const ReferenceIlluminant& r :
       options.references.empty() ? default_reference_illuminants() : options.references)
    out.push_back({r.name, r.spectrum, spectral::white_point(r.spectrum)});
  return out;
}

// Fixed standard-normal samples in antithetic pairs (3 per row).
Eigen::Matrix3Xd normal_samples(int count) {
  std::mt19937_64 rng(20261202);
  std::normal_distribution<double> normal;
  Eigen::Matrix3Xd z(3, count);
  for (int i = 0; i + 1 < count; i += 2) {
    for (int r = 0; r < 3; ++r) z(r, i) = normal(rng);
    z.col(i + 1) = -z.col(i);
  }
  return z;
}

// A symmetric square root of a covariance (eigenvalues below 0 from rounding are 0).
template <typename Matrix>
Matrix covariance_root(const Matrix& covariance) {
  Eigen::SelfAdjointEigenSolver<Matrix> eigen(covariance);
  const auto root = eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt().eval();
  return eigen.eigenvectors() * root.asDiagonal() * eigen.eigenvectors().transpose();
}

// The prior information of the parameter box: 12 / width² per parameter.
Eigen::Matrix4d box_information() {
  Eigen::Matrix4d prior = Eigen::Matrix4d::Zero();
  const estimation::ParameterRange ranges[4] = {estimation::kCmRange, estimation::kChRange, estimation::kBmRange,
                                                estimation::kCheRange};
  for (int j = 0; j < 4; ++j) prior(j, j) = 12.0 / ((ranges[j].max - ranges[j].min) * (ranges[j].max - ranges[j].min));
  return prior;
}

void check_inputs(const PlanDescription& plan, const calibration::LedLibrary& library, const CameraNoise& camera,
                  const AdvisorOptions* options) {
  std::string error;
  if (!plan.IsValid(&error)) throw std::invalid_argument("plan: " + error);
  if (const std::string bad = calibration::validate(library); !bad.empty())
    throw std::invalid_argument("library: " + bad);
  if (!camera.IsValid(&error)) throw std::invalid_argument("camera: " + error);
  if (options != nullptr && !options->IsValid(&error)) throw std::invalid_argument("options: " + error);
}

// Σ_disc in the model's channels (the estimator's, from the plan's measurement
// set), or an empty matrix without a discrepancy.
Eigen::MatrixXd discrepancy_covariance(const PlanModel& model, const AdvisorOptions& options) {
  if (!options.discrepancy) return Eigen::MatrixXd();
  return options.discrepancy->channel_covariance(model.measurement_set());
}

// The channels' covariance at an albedo: the camera's, plus Σ_disc when given.
Eigen::MatrixXd channel_covariance(const PlanModel& model, const spectral::Spectrum& albedo,
                                   const Eigen::MatrixXd& discrepancy) {
  Eigen::MatrixXd cov = model.covariance(albedo);
  if (discrepancy.size() > 0) cov += discrepancy;
  return cov;
}

struct SkinResult {
  Vec4 variance = Vec4::Zero();
  std::vector<double> delta_e;  // per reference
};

}  // namespace

bool CameraNoise::IsValid(std::string* error) const {
  auto fail = [&](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (!(full_well_e >= 100 && full_well_e <= 1e7)) return fail("full_well_e: must be in [100, 1e7]");
  if (!(read_noise_e >= 0 && read_noise_e <= 1000)) return fail("read_noise_e: must be in [0, 1000]");
  if (adc_bits < 8 || adc_bits > 16) return fail("adc_bits: must be 8-16");
  if (!(black_level_dn >= 0 && black_level_dn < 0.5 * ((1 << adc_bits) - 1)))
    return fail("black_level_dn: must be in [0, half the ADC range)");
  if (!(quantum_scale_e_per_us > 0 && quantum_scale_e_per_us <= 1e6)) return fail("quantum_scale_e_per_us: must be in (0, 1e6]");
  if (!(readout_ms >= 0 && readout_ms <= 10000)) return fail("readout_ms: must be in [0, 10000]");
  if (!(white_reflectance > 0.1 && white_reflectance <= 1)) return fail("white_reflectance: must be in (0.1, 1]");
  for (int c = 0; c < 3 && !sensitivity.name.empty(); ++c)
    if (!sensitivity.rgb[c].values().allFinite() || sensitivity.rgb[c].values().maxCoeff() <= 0)
      return fail("sensitivity: every channel must be finite and positive somewhere");
  return true;
}

bool SkinPopulation::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  const estimation::ParameterRange ranges[4] = {estimation::kCmRange, estimation::kChRange, estimation::kBmRange,
                                                estimation::kCheRange};
  const char* names[4] = {"cm", "ch", "bm", "che"};
  if (!skins.empty()) {
    if (skins.size() > 100000) return fail("population.skins: at most 100000");
    for (std::size_t s = 0; s < skins.size(); ++s) {
      const Vec4 p = as_vector(skins[s]);
      for (int j = 0; j < 4; ++j)
        if (!(p[j] >= ranges[j].min && p[j] <= ranges[j].max))
          return fail("population.skins[" + std::to_string(s) + "]." + names[j] + ": outside MODEL.md's range " +
                      std::string(ranges[j].name));
    }
    return true;
  }
  if (count < 1 || count > 100000) return fail("population.count: must be 1-100000");
  const Vec4 lo = as_vector(low), hi = as_vector(high);
  for (int j = 0; j < 4; ++j) {
    if (!(lo[j] >= ranges[j].min && hi[j] <= ranges[j].max && lo[j] <= hi[j]))
      return fail(std::string("population.") + names[j] + ": low ≤ high within MODEL.md's range " +
                  std::string(ranges[j].name));
  }
  return true;
}

SkinPopulation interior_population() {
  SkinPopulation p;
  p.low = {0.01, 0.01, 0.2, 0.01};
  p.high = {0.2, 0.15, 0.8, 0.08};
  return p;
}

std::vector<SkinParameters> draw_population(const SkinPopulation& population) {
  if (std::string error; !population.IsValid(&error)) throw std::invalid_argument(error);
  if (!population.skins.empty()) return population.skins;
  std::mt19937_64 rng(population.seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto log_uniform = [&](double lo, double hi) { return lo * std::pow(hi / lo, u(rng)); };
  std::vector<SkinParameters> skins(population.count);
  for (SkinParameters& s : skins) {
    s.cm = log_uniform(population.low.cm, population.high.cm);
    s.ch = log_uniform(population.low.ch, population.high.ch);
    s.bm = population.low.bm + (population.high.bm - population.low.bm) * u(rng);
    s.che = population.low.che + (population.high.che - population.low.che) * u(rng);
  }
  return skins;
}

std::vector<ReferenceIlluminant> default_reference_illuminants() {
  std::vector<ReferenceIlluminant> out{{"D65", spectral::illuminant_d65()}, {"A", spectral::illuminant_a()}};
  for (spectral::LedType type : spectral::kAllLedTypes)
    out.push_back({std::string(spectral::led_type_name(type)), spectral::led_spectrum(type)});
  return out;
}

bool AdvisorOptions::IsValid(std::string* error) const {
  if (!population.IsValid(error)) return false;
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (delta_e_samples < 16 || delta_e_samples > 65536 || delta_e_samples % 2)
    return fail("delta_e_samples: must be even, 16-65536");
  if (threads < 1 || threads > 64) return fail("threads: must be 1-64");
  for (std::size_t r = 0; r < references.size(); ++r)
    if (!references[r].spectrum.values().allFinite() || spectral::xyz_of_light(references[r].spectrum).Y <= 0)
      return fail("references[" + std::to_string(r) + "]: needs a finite spectrum with light in it");
  return true;
}

bool MonteCarloOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (draws_per_skin < 1 || draws_per_skin > 1000) return fail("draws_per_skin: must be 1-1000");
  if (max_iterations < 1 || max_iterations > 1000) return fail("max_iterations: must be 1-1000");
  for (const spectral::Spectrum& a : measured_albedo)
    if (!a.values().allFinite() || a.values().minCoeff() < 0 || a.values().maxCoeff() > 1)
      return fail("measured_albedo: every spectrum must be finite and within [0, 1]");
  return true;
}

CaptureTime capture_time(const PlanDescription& plan, const calibration::LedLibrary& library,
                         const CameraNoise& camera) {
  check_inputs(plan, library, camera, nullptr);
  const PlanModel model(plan, library, camera);
  CaptureTime time;
  const double readout_s = camera.readout_ms / 1000;
  double longest_exposure_s = 0;
  for (std::size_t k = 0; k < plan.captures.size(); ++k) {
    const PlannedCapture& c = plan.captures[k];
    CaptureTime::PerCapture t;
    t.name = c.name;
    t.exposure_us = model.exposure_us(static_cast<int>(k));
    const double exposure_s = t.exposure_us / 1e6;
    longest_exposure_s = std::max(longest_exposure_s, exposure_s);
    t.subject_s = c.settle_ms / 1000.0 + c.frames * (exposure_s + readout_s);
    t.white_s = c.settle_ms / 1000.0 + c.white_frames * (exposure_s + readout_s);
    time.subject_s += t.subject_s;
    time.reference_s += t.white_s;
    time.captures.push_back(t);
  }
  // From the first subject exposure (after the first settle) to the end of the last (before its readout).
  time.subject_s -= plan.captures.front().settle_ms / 1000.0 + readout_s;
  time.reference_s += plan.dark_frames * (longest_exposure_s + readout_s);
  return time;
}

ChannelStatistics channel_statistics(const PlanDescription& plan, const calibration::LedLibrary& library,
                                     const CameraNoise& camera, const SkinParameters& skin) {
  check_inputs(plan, library, camera, nullptr);
  const PlanModel model(plan, library, camera);
  const spectral::Spectrum albedo = skin_model().albedo(skin);
  const Eigen::VectorXd v = model.values(albedo);
  const Eigen::MatrixXd cov = model.covariance(albedo);
  ChannelStatistics out;
  out.value.assign(v.data(), v.data() + v.size());
  out.covariance.resize(cov.size());
  for (int i = 0; i < cov.rows(); ++i)
    for (int j = 0; j < cov.cols(); ++j) out.covariance[i * cov.cols() + j] = cov(i, j);
  return out;
}

ChannelStatistics simulated_channel_statistics(const PlanDescription& plan, const calibration::LedLibrary& library,
                                               const CameraNoise& camera, const SkinParameters& skin, int draws,
                                               std::uint64_t seed) {
  check_inputs(plan, library, camera, nullptr);
  if (draws < 2 || draws > 1000000) throw std::invalid_argument("draws: must be 2-1000000");
  const PlanModel model(plan, library, camera);
  const spectral::Spectrum albedo = skin_model().albedo(skin);
  std::mt19937_64 rng(seed);
  const int n = model.channel_count();
  Eigen::MatrixXd samples(n, draws);
  for (int d = 0; d < draws; ++d) samples.col(d) = model.simulate(albedo, rng);
  const Eigen::VectorXd mean = samples.rowwise().mean();
  const Eigen::MatrixXd centred = samples.colwise() - mean;
  const Eigen::MatrixXd cov = centred * centred.transpose() / (draws - 1);
  ChannelStatistics out;
  out.value.assign(mean.data(), mean.data() + n);
  out.covariance.resize(static_cast<std::size_t>(n) * n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) out.covariance[i * n + j] = cov(i, j);
  return out;
}

namespace {

// table − exact model per skin (rows) and channel, for a built model.
Eigen::MatrixXd table_error(const PlanModel& model, const std::vector<SkinParameters>& skins, int threads) {
  const estimation::ForwardTable table = estimation::ForwardTable::build(model.measurement_set(), {}, threads);
  Eigen::MatrixXd error(static_cast<Eigen::Index>(skins.size()), model.channel_count());
  std::vector<double> interpolated(model.channel_count());
  for (std::size_t s = 0; s < skins.size(); ++s) {
    table.predict(table.to_grid(skins[s]), interpolated.data());
    const Eigen::VectorXd exact = model.values(skin_model().albedo(skins[s]));
    for (int c = 0; c < model.channel_count(); ++c) error(static_cast<Eigen::Index>(s), c) = interpolated[c] - exact[c];
  }
  return error;
}

}  // namespace

std::vector<double> table_interpolation_error(const PlanDescription& plan, const calibration::LedLibrary& library,
                                              const CameraNoise& camera, const std::vector<SkinParameters>& skins,
                                              int threads) {
  check_inputs(plan, library, camera, nullptr);
  if (threads < 1 || threads > 64) throw std::invalid_argument("threads: must be 1-64");
  for (std::size_t s = 0; s < skins.size(); ++s) {
    SkinPopulation one;
    one.skins = {skins[s]};
    if (std::string error; !one.IsValid(&error))
      throw std::invalid_argument("skins[" + std::to_string(s) + "]: " + error);
  }
  const Eigen::MatrixXd e = table_error(PlanModel(plan, library, camera), skins, threads);
  std::vector<double> out(static_cast<std::size_t>(e.size()));
  for (Eigen::Index s = 0; s < e.rows(); ++s)
    for (Eigen::Index c = 0; c < e.cols(); ++c) out[static_cast<std::size_t>(s * e.cols() + c)] = e(s, c);
  return out;
}

PlanPrediction predict_plan(const PlanDescription& plan, const calibration::LedLibrary& library,
                            const CameraNoise& camera, const AdvisorOptions& options) {
  check_inputs(plan, library, camera, &options);
  const PlanModel model(plan, library, camera);
  const std::vector<Reference> refs = references_of(options);
  const std::vector<SkinParameters> skins = draw_population(options.population);
  const Eigen::MatrixXd delta_v = options.table_bias ? table_error(model, skins, options.threads) : Eigen::MatrixXd();
  const Eigen::Matrix3Xd z = normal_samples(options.delta_e_samples);
  const Eigen::Matrix4d prior = options.box_prior ? box_information() : Eigen::Matrix4d::Zero();
  const Eigen::MatrixXd discrepancy = discrepancy_covariance(model, options);
  std::vector<SkinResult> results(skins.size());

#pragma omp parallel for num_threads(options.threads) schedule(dynamic)
  for (std::size_t s = 0; s < skins.size(); ++s) {
    const Vec4 p = as_vector(skins[s]);
    const Vec4 h = steps(p);
    const spectral::Spectrum albedo = skin_model().albedo(skins[s]);
    Eigen::MatrixXd jacobian(model.channel_count(), 4);
    std::vector<Eigen::Matrix<double, 3, 4>> lab_jacobian(refs.size());
    for (int j = 0; j < 4; ++j) {
      Vec4 up = p, down = p;
      up[j] += h[j], down[j] -= h[j];
      const spectral::Spectrum a_up = skin_model().albedo(as_parameters(up));
      const spectral::Spectrum a_down = skin_model().albedo(as_parameters(down));
      jacobian.col(j) = (model.values(a_up) - model.values(a_down)) / (2 * h[j]);
      for (std::size_t r = 0; r < refs.size(); ++r)
        lab_jacobian[r].col(j) = (lab_of(a_up, refs[r]) - lab_of(a_down, refs[r])) / (2 * h[j]);
    }
    const Eigen::MatrixXd cov = channel_covariance(model, albedo, discrepancy);
    const Eigen::LDLT<Eigen::MatrixXd> noise(cov);
    const Eigen::Matrix4d information = jacobian.transpose() * noise.solve(jacobian) + prior;
    const Eigen::Matrix4d p_cov = information.ldlt().solve(Eigen::Matrix4d::Identity());
    SkinResult& out = results[s];
    out.variance = p_cov.diagonal();
    // The table bias: the fit of table(p + δp) = exact(p) to first order,
    // weighted as the noise: δp = −P·Jᵀ·Σ⁻¹·δv.
    Vec4 bias = Vec4::Zero();
    if (options.table_bias) {
      const Eigen::VectorXd dv = delta_v.row(static_cast<Eigen::Index>(s)).transpose();
      bias = -p_cov * (jacobian.transpose() * noise.solve(dv));
    }
    for (std::size_t r = 0; r < refs.size(); ++r) {
      const Eigen::Vector3d lab = lab_of(albedo, refs[r]);
      const Eigen::Matrix3d lab_cov = lab_jacobian[r] * p_cov * lab_jacobian[r].transpose();
      const Eigen::Matrix3Xd e = (covariance_root<Eigen::Matrix3d>(lab_cov) * z).colwise() + lab_jacobian[r] * bias;
      double sum = 0;
      for (int i = 0; i < e.cols(); ++i) sum += spectral::delta_e94(to_lab(lab), to_lab(lab + e.col(i)));
      out.delta_e.push_back(sum / e.cols());
    }
  }

  PlanPrediction prediction;
  prediction.plan = plan.name;
  for (const PlannedChannel& c : plan.effective_channels()) prediction.channels.push_back(c.name());
  prediction.time = capture_time(plan, library, camera);
  prediction.skins = static_cast<int>(skins.size());
  Vec4 variance = Vec4::Zero();
  prediction.delta_e94.assign(refs.size(), 0.0);
  for (const SkinResult& r : results) {
    variance += r.variance / results.size();
    for (std::size_t i = 0; i < refs.size(); ++i) prediction.delta_e94[i] += r.delta_e[i] / results.size();
  }
  prediction.sigma = {std::sqrt(variance[0]), std::sqrt(variance[1]), std::sqrt(variance[2]), std::sqrt(variance[3])};
  for (const Reference& r : refs) prediction.illuminants.push_back(r.name);
  for (double d : prediction.delta_e94) prediction.delta_e94_mean += d / refs.size();
  return prediction;
}

MonteCarloCheck monte_carlo_check(const PlanDescription& plan, const calibration::LedLibrary& library,
                                  const CameraNoise& camera, const AdvisorOptions& options,
                                  const MonteCarloOptions& mc, const PlanPrediction& prediction) {
  check_inputs(plan, library, camera, &options);
  if (std::string error; !mc.IsValid(&error)) throw std::invalid_argument("monte_carlo: " + error);
  const PlanModel model(plan, library, camera);
  const std::vector<Reference> refs = references_of(options);
  const std::vector<SkinParameters> skins = draw_population(options.population);
  if (!mc.measured_albedo.empty() && mc.measured_albedo.size() != skins.size())
    throw std::invalid_argument("monte_carlo.measured_albedo: " + std::to_string(mc.measured_albedo.size()) +
                                " spectra for " + std::to_string(skins.size()) + " skins");
  const Eigen::MatrixXd discrepancy = discrepancy_covariance(model, options);
  // Its square root, for the draws added to model skin (measured skin carries its own).
  const Eigen::MatrixXd discrepancy_root =
      discrepancy.size() > 0 && mc.measured_albedo.empty()
          ? covariance_root(discrepancy)
          : Eigen::MatrixXd();
  const std::size_t fits = skins.size() * mc.draws_per_skin;
  struct Fit {
    Vec4 error = Vec4::Zero();
    std::vector<double> delta_e;
    bool on_bound = false, failed = false;
  };
  std::vector<Fit> out(fits);

#pragma omp parallel for num_threads(options.threads) schedule(dynamic)
  for (std::size_t f = 0; f < fits; ++f) {
    const std::size_t s = f / mc.draws_per_skin;
    const SkinParameters& truth = skins[s];
    const spectral::Spectrum albedo = mc.measured_albedo.empty() ? skin_model().albedo(truth) : mc.measured_albedo[s];
    std::mt19937_64 rng(mc.seed * 0x9E3779B97F4A7C15ull + f);
    Eigen::VectorXd observed = model.simulate(albedo, rng);
    if (discrepancy_root.size() > 0) {
      std::normal_distribution<double> normal;
      Eigen::VectorXd z(observed.size());
      for (Eigen::Index c = 0; c < z.size(); ++c) z[c] = normal(rng);
      observed += discrepancy_root * z;
    }
    const Eigen::MatrixXd cov = channel_covariance(model, albedo, discrepancy);
    const BoundedFit fit = fit_bounded(model, observed, cov, truth, mc.max_iterations, skin_model());
    Fit& r = out[f];
    r.failed = !fit.usable;
    r.on_bound = fit.on_bound;
    r.error = as_vector(fit.parameters) - as_vector(truth);
    const spectral::Spectrum fitted = skin_model().albedo(fit.parameters);
    for (const Reference& ref : refs)
      r.delta_e.push_back(spectral::delta_e94(to_lab(lab_of(albedo, ref)), to_lab(lab_of(fitted, ref))));
  }

  MonteCarloCheck check;
  check.delta_e94.assign(refs.size(), 0.0);
  Vec4 squared = Vec4::Zero();
  for (const Fit& r : out) {
    if (r.failed) {
      ++check.failed_fits;
      continue;
    }
    ++check.fits;
    squared += r.error.cwiseAbs2();
    if (r.on_bound) check.bound_share += 1;
    for (std::size_t i = 0; i < refs.size(); ++i) check.delta_e94[i] += r.delta_e[i];
  }
  if (check.fits > 0) {
    squared /= check.fits;
    check.bound_share /= check.fits;
    for (double& d : check.delta_e94) d /= check.fits;
  }
  check.rms_error = {std::sqrt(squared[0]), std::sqrt(squared[1]), std::sqrt(squared[2]), std::sqrt(squared[3])};
  for (double d : check.delta_e94) check.delta_e94_mean += d / refs.size();
  check.ratio = check.delta_e94_mean > 0 ? prediction.delta_e94_mean / check.delta_e94_mean : 0;
  return check;
}

}  // namespace chromo::planning
