#pragma once
// The plan advisor: from the LED library, the camera's sensitivity and its
// noise model, what a capture plan (plan_description.hpp) will deliver —
// each parameter's uncertainty, the relit ΔE94 of the reconstructed skin
// under reference illuminants, and the capture time — before anyone captures.
// Nothing in it is fitted to a bench: every number follows from the physics
// below and the inputs.
//
// Forward model. For capture k with illuminant E_k = Σ_t drive_t·s_t(λ)
// (s_t the library's spectrum per unit drive) and camera channel c, the
// un-normalised response to albedo a is R_kc(a) = Σ S_c·E_k·a·Δλ (MODEL.md).
// The exposure puts the white's brightest channel at white_fill of the full
// well: K_k = white_fill·full_well / max_c(ρ_white·R_kc(1)) electrons per unit
// response, so the subject gives S = K_k·R_kc(a) electrons and the white
// W = K_k·ρ·R_kc(1). A channel (capture k, optionally minus capture m) is
//   v = ρ·Σ_j c_j (S_j − D)/K_j / Σ_j c_j (W_j − D)/K_j,  c = +1 (k), −1 (m)
// which is the estimator's white-normalised albedo: v = w·a with the weights
// of the illuminant Σ c_j E_j (measurement.hpp's "mix − W57" channel).
//
// Noise. Every raw quantity is a mean over frames of electrons: variance per
// frame = signal (shot) + read_noise² + step²/12 (quantisation, step =
// full_well/(2^bits − 1) electrons per DN), divided by the frames averaged;
// the subject S (frames), the white W (white_frames) and the one dark D
// (dark_frames, no signal). The channels' covariance Σ is the first-order
// propagation of these independent variances through the formula above (so a
// difference channel and a channel sharing a capture are correlated exactly).
//
// Fisher information. J = ∂v/∂p (central differences of the skin model,
// p = Cm, Ch, βm, Che in their own units), F = Jᵀ Σ⁻¹ J. The parameter box
// (MODEL.md's ranges) is added as prior information of a uniform
// distribution's variance, width²/12 per parameter, so a parameter the plan
// cannot see gets the box's spread instead of infinity. Covariance P = F⁻¹
// (Cramér-Rao, plus that prior). σ per parameter: √P_jj, RMS over the skin
// population.
//
// The model's discrepancy (AdvisorOptions::discrepancy). On real skin the
// skin model's best fit stays off the measured spectrum by a residual r(λ)
// the estimator counts as noise: Σ_disc = W Σ_r Wᵀ in the plan's channels
// (estimation::ModelDiscrepancy::channel_covariance of the plan's measurement
// set, the covariance the estimator's χ² adds). With it, Σ above is the
// camera's covariance plus Σ_disc everywhere the advisor weighs the
// channels: the Fisher information (so σ no longer falls as 1/√frames below
// the discrepancy's floor: more channels lower it, more frames do not), the
// table bias, and the Monte Carlo check's weights.
//
// Relit colour. For each reference illuminant, L = ∂Lab/∂p (central
// differences of the albedo's CIELAB under that illuminant, MODEL.md's
// colour rules) and Σ_Lab = L P Lᵀ. The predicted ΔE94 is the expectation of
// ΔE94(Lab, Lab + e) over e ~ N(0, Σ_Lab), computed by averaging over a fixed
// set of standard-normal samples (antithetic pairs, seeded) mapped through
// the Cholesky factor: the exact ΔE94 formula of the project, no
// approximation constant. Mean over the skin population, per illuminant, and
// the mean over the illuminants.
//
// Monte Carlo check (monte_carlo_check): the same skins, frames simulated as
// the camera makes them (Gaussian shot noise, read noise, rounding to DN
// with a black level, clipping at full scale), averaged, dark-subtracted and
// white-normalised by the exact formula; then a bounded weighted least
// squares (Ceres, MODEL.md's box as bounds, Σ⁻¹ as the weight, started at the
// truth: it measures the noise, not a search) and the relit ΔE94 of the fit
// against the truth. Where a true parameter lies near a bound the estimate
// is clipped there and the Cramér-Rao prediction is no longer what a bounded
// estimator does: the check reports the share of fits that ended on a bound
// and the prediction's ratio on the population the caller chose.
//
// Capture time (capture_time): exposure_us = K_k·Σ S_G Δλ / quantum_scale
// (the virtual lab camera's electrons per µs per unit response); a capture
// takes settle_ms + frames·(exposure + readout); the subject time runs from
// the first subject exposure to the end of the last (the first settle not
// included); white references and the dark are reported apart.
//
// Thread rules: pure functions; predict_plan and monte_carlo_check use up to
// options.threads threads.

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "chromo/calibration/led_library.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/estimation/skin_parameters.hpp"
#include "chromo/planning/plan_description.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::planning {

// The camera as the advisor sees it. Defaults: the virtual lab's camera
// (simulators/camera/camera_model.hpp: nikon_d5100 sensitivities, 20,000 e⁻
// full well, 6 e⁻ read noise, 12-bit, 2.0 e⁻/µs per unit response, black
// level 16 DN; a test checks they agree) and a frame readout of 43 ms (the
// 23 frames/s measured for a 4-MP stream on loopback, NOTES.md).
struct CameraNoise {
  spectral::CameraSensitivity sensitivity;  // empty name: nikon_d5100
  double full_well_e = 20000;
  double read_noise_e = 6;
  int adc_bits = 12;
  double black_level_dn = 16;
  double quantum_scale_e_per_us = 2.0;
  double readout_ms = 43;
  double white_reflectance = 0.99;  // ρ of the white target

  bool IsValid(std::string* error) const;
  double electrons_per_dn() const { return full_well_e / ((1 << adc_bits) - 1); }
};

// The skin the prediction is averaged over: `count` skins drawn (seeded)
// with Cm and Ch log-uniform and βm, Che uniform within [low, high].
// Default: MODEL.md's ranges narrowed to skin (Cm 0.002-0.4, Ch 0.002-0.3,
// βm 0-1, Che 0-0.1): βm and Che reach their bounds, where the Cramér-Rao
// bound stops describing a bounded fit. interior_population(): a box clear of
// every bound (Cm 0.01-0.2, Ch 0.01-0.15, βm 0.2-0.8, Che 0.01-0.08).
struct SkinPopulation {
  estimation::SkinParameters low{0.002, 0.002, 0.0, 0.0};
  estimation::SkinParameters high{0.4, 0.3, 1.0, 0.1};
  int count = 64;
  std::uint64_t seed = 1;
  // Given skins (e.g. a sample of a scene's truth): when not empty, the
  // population is exactly these (each within MODEL.md's ranges; at most
  // 100000) and low, high, count and seed are not used.
  std::vector<estimation::SkinParameters> skins;
  bool IsValid(std::string* error) const;
};
SkinPopulation interior_population();
std::vector<estimation::SkinParameters> draw_population(const SkinPopulation& population);

struct ReferenceIlluminant {
  std::string name;
  spectral::Spectrum spectrum;
};
// D65, A and the six LED types (spectral::led_spectrum), in that order.
std::vector<ReferenceIlluminant> default_reference_illuminants();

struct AdvisorOptions {
  SkinPopulation population;
  std::vector<ReferenceIlluminant> references;  // empty: default_reference_illuminants()
  int delta_e_samples = 256;    // standard-normal samples per ΔE94 expectation (even, 16-65536)
  // Add the parameter box's information (12/width² per parameter) to the
  // Fisher information. Off: the plain Cramér-Rao bound (a parameter the plan
  // cannot see then has an unbounded σ).
  bool box_prior = true;
  // The estimator's table error (docs/plan-advisor.md, "The table's floor"):
  // the estimator fits the plan's forward table (estimation::ForwardTable,
  // default grid, multilinear), not the exact model, so a noise-free
  // measurement is fitted with the bias δp = −P·Jᵀ·Σ⁻¹·δv, δv the table's
  // interpolation error at the skin (table − exact model, computed, not
  // fitted). On: each skin's relit error is ΔE94 of (Lab + L·δp + e) and not
  // of (Lab + e). Costs one table build per prediction (seconds).
  bool table_bias = false;
  // The skin model's learned discrepancy on real skin (model_discrepancy.hpp;
  // "The model's discrepancy" above): its channel covariance is added to the
  // camera noise. Null: the camera noise alone (skin rendered by the model
  // itself). `chromo plan compare` and the API pass ModelDiscrepancy::standard()
  // by default, as the estimator does.
  std::shared_ptr<const estimation::ModelDiscrepancy> discrepancy;
  int threads = 1;              // 1-64
  bool IsValid(std::string* error) const;
};

struct ParameterSigma {
  double cm = 0, ch = 0, bm = 0, che = 0;  // RMS over the population, parameter units
};

struct CaptureTime {
  struct PerCapture {
    std::string name;
    double exposure_us = 0;
    double subject_s = 0;  // settle + frames·(exposure + readout)
    double white_s = 0;    // settle + white_frames·(exposure + readout)
  };
  std::vector<PerCapture> captures;
  double subject_s = 0;    // first subject exposure to the end of the last
  double reference_s = 0;  // white references (each with its settle) and the dark
};

struct PlanPrediction {
  std::string plan;
  std::vector<std::string> channels;
  CaptureTime time;
  ParameterSigma sigma;
  std::vector<std::string> illuminants;   // reference names
  std::vector<double> delta_e94;          // predicted mean relit ΔE94 per reference
  double delta_e94_mean = 0;              // mean over the references
  int skins = 0;
};

struct MonteCarloOptions {
  int draws_per_skin = 4;    // 1-1000
  std::uint64_t seed = 7;
  int max_iterations = 50;   // Ceres iterations per fit
  // Measured skin (real spectra): when not empty, one albedo spectrum per
  // skin of the population (same order and count; finite, in [0, 1]), and
  // each skin is that spectrum's reference parameters (its full-spectrum
  // fit). The frames are simulated from the spectrum, not from the model's
  // albedo of the skin, so the fits carry the model's real discrepancy, and
  // the relit error is against the spectrum. Empty: the model's albedo of
  // each skin, plus, when AdvisorOptions::discrepancy is set, a draw from
  // N(0, Σ_disc) per measurement (the discrepancy as the prediction assumes it).
  std::vector<spectral::Spectrum> measured_albedo;
  bool IsValid(std::string* error) const;
};

struct MonteCarloCheck {
  ParameterSigma rms_error;              // RMS(fit − truth) over fits
  std::vector<double> delta_e94;         // mean relit ΔE94 of the fits, per reference
  double delta_e94_mean = 0;
  double bound_share = 0;                // fits with a parameter on a bound (within 1e-9 of its range)
  int fits = 0, failed_fits = 0;         // failed: Ceres reported no usable solution
  double ratio = 0;                      // predicted delta_e94_mean / this delta_e94_mean
};

CaptureTime capture_time(const PlanDescription& plan, const calibration::LedLibrary& library,
                         const CameraNoise& camera);

// Throws std::invalid_argument naming the field for a bad plan, library,
// camera or options (nothing computed).
PlanPrediction predict_plan(const PlanDescription& plan, const calibration::LedLibrary& library,
                            const CameraNoise& camera, const AdvisorOptions& options = {});

// Runs the check on the prediction's population and references and fills
// `ratio` from `prediction` (same plan, library, camera and options).
MonteCarloCheck monte_carlo_check(const PlanDescription& plan, const calibration::LedLibrary& library,
                                  const CameraNoise& camera, const AdvisorOptions& options,
                                  const MonteCarloOptions& mc, const PlanPrediction& prediction);

// The channels' covariance (n × n, albedo units²) and noise-free values for one
// skin: the noise model above, for tests.
struct ChannelStatistics {
  std::vector<double> value;
  std::vector<double> covariance;  // row-major n × n
};
// The forward table's interpolation error at each skin: table − exact model
// per channel (skins × channels, row-major), the δv of the table bias; the
// table is the estimator's (estimation::ForwardTable, default grid) for this
// plan's channels. Zero at the table's nodes up to its float storage.
std::vector<double> table_interpolation_error(const PlanDescription& plan, const calibration::LedLibrary& library,
                                              const CameraNoise& camera,
                                              const std::vector<estimation::SkinParameters>& skins, int threads = 1);

ChannelStatistics channel_statistics(const PlanDescription& plan, const calibration::LedLibrary& library,
                                     const CameraNoise& camera, const estimation::SkinParameters& skin);
// The same from `draws` simulated measurements (the Monte Carlo check's
// frames): the empirical mean and covariance, to check the model against.
ChannelStatistics simulated_channel_statistics(const PlanDescription& plan, const calibration::LedLibrary& library,
                                               const CameraNoise& camera, const estimation::SkinParameters& skin,
                                               int draws, std::uint64_t seed);

}  // namespace chromo::planning
