#pragma once
// Estimator: measurement images → per-pixel (Cm, Ch, βm, Che), residual,
// model order and flag. The API the daemon's pipeline and the offline CLI call.
//
// Input layout: pixel-major float albedo, channels() values per pixel in the
// order of the MeasurementSet (for the method's set: R, G, B under D65', then
// the blue-only B). Registration of the captures happens before (registration.hpp).
//
// Per pixel:
//  1. NaN/inf → kNonFinite; any channel ≥ its saturation_albedo → kSaturated;
//     every channel < dark_albedo → kDark. Parameters 0, order 0.
//  2. The pixel's channel covariance Σ = diag(camera noise (measurement.hpp)
//     + (model_sigma_relative·a_c)²) + Σ_disc, Σ_disc the model's
//     learned discrepancy on real skin in the plan's channels
//     (EstimatorOptions::discrepancy, model_discrepancy.hpp; none: the first
//     term alone). The fits weigh channel c by 1/√Σ_cc; every χ² below is
//     rᵀ Σ⁻¹ r with the whole Σ (identical to the weighted sum without a
//     discrepancy).
//  3. Model order. model = k4d or k2d: that order. kAuto: fit both and
//     compare what they look like (AppearanceTable: CIELAB under the six LED
//     types and D65): D = mean over those illuminants of ΔE*ab between the
//     2D and the 4D fit (linearised at the 4D fit's colour); U = the 4D
//     fit's own appearance uncertainty from the camera noise (its parameter
//     covariance (Jᵀ V⁻¹ J + P)⁻¹, J the table's Jacobian at the 4D fit, V
//     the camera noise variance alone (not the model-error term of the
//     weights), P the parameter box as a uniform prior, mapped to Lab by the
//     appearance Jacobian: RMS ΔE*ab, averaged over the illuminants).
//     Order 2 when D ≤ order_appearance_factor · U (default k = 1), else 4: 4D
//     only where βm and Che change the predicted appearance by more than
//     their uncertainty. Noise-free data declared so (U ≈ 0) get order 4
//     wherever the fits differ, so the 2D choice never costs accuracy where
//     the data determine 4D; data declared noisy while they are not (the lab's
//     noise-free frames carry the camera's noise figure) get 2D within k·U.
//     A pixel whose 2D fit fails the flag test while its 4D fit passes keeps
//     order 4; a pixel whose χ²₄ is ten times the 2D flag threshold is
//     unexplained with either order: no 2D fit, order 4. An Estimator built
//     for k2d or k4d holds no appearance table: estimate_pixel(…, kAuto) on
//     it throws std::logic_error. order_rule = kLikelihoodRatio replaces the
//     appearance rule by the likelihood-ratio test (EstimatorOptions).
//  4b. With a prior (EstimatorOptions::prior, parameter_prior.hpp) and at
//     most prior_max_channels channels, an explained order-4 pixel takes the
//     maximum a posteriori fit instead (χ² + the prior's penalty, from the
//     chosen fit and from the prior's mean: prior_fit.hpp); its flag, order
//     and χ² stay the data's (the prior chooses among the parameters that
//     explain the pixel, it does not decide whether any do), its σ maps take
//     the prior's information in place of the box's.
//  4. Explained? The chosen fit's χ² is compared with the (1 −
//     flag_significance) quantile of χ² with max(C − free parameters, 1)
//     degrees of freedom (with as many channels as parameters a pixel inside
//     the gamut fits exactly and χ² measures its distance outside the gamut
//     along one direction). Default 0.001: ≤ 0.1% of skin pixels flagged by noise.
//  5. If not explained: subtract a white surface reflection s (s scanned in
//     eight steps up to the smallest channel, each step's 4D fit continued
//     from the previous one by a few LM iterations on the table) and refit; if
//     some s ≥ min_specular explains it → kSpecular with those parameters. Otherwise
//     kUnexplainedAbsorber when the pixel is darker than the best fit in every
//     channel, else kUnexplainedColour; the best-fit parameters are kept.
//  Limits (measured in bench/, docs/estimation.md): a specular reflection that
//  leaves the pixel looking like paler skin, or ink over dark skin that looks
//  like more melanin, IS explained by some parameters and cannot be told from
//  skin one pixel at a time; those pixels pass unflagged.
//
// Thread rules: an Estimator is immutable after construction. estimate_tile()
// may be called concurrently from any number of threads on disjoint outputs
// (the daemon runs one tile per core as frames arrive). estimate() splits an
// image into tiles over options.threads threads itself. Its Progress
// (files/progress.hpp) is reported under a lock (never concurrently) after
// each tile, with the fraction of pixels done and "estimating maps", and
// cancelled() is polled under the same lock before each tile: a cancelled run
// returns with summary.cancelled and the pixels of tiles not started left
// untouched.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>

#include "chromo/estimation/appearance.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/files/progress.hpp"
#include <optional>
#include <string_view>

#include "chromo/estimation/inverter.hpp"
#include "chromo/estimation/measurement.hpp"
#include "chromo/estimation/subspace_inverter.hpp"
#include "chromo/estimation/pixel_flags.hpp"
#include <Eigen/Core>
#include <limits>

namespace chromo::estimation {

class ModelDiscrepancy;
class ParameterPrior;
namespace detail {
class PixelCovariance;
struct GridPrior;
}

// kSubspace: SubspaceInverter (subspace_inverter.hpp), whose cost barely
// grows with the channel count.
enum class InverterMethod { kExhaustive, kFast, k2d, kSubspace };
enum class ModelChoice { kAuto, k2d, k4d };
std::string_view method_name(InverterMethod method);
std::string_view model_name(ModelChoice model);
// The inverses of method_name / model_name ("exhaustive", "fast", "2d", "subspace";
// "auto", "2d", "4d"); std::nullopt for any other name.
std::optional<InverterMethod> parse_method_name(std::string_view name);
std::optional<ModelChoice> parse_model_name(std::string_view name);

struct PixelEstimate {
  SkinParameters parameters{0, 0, 0, 0};
  float residual = 0;   // RMS of predicted − measured over the channels, albedo units
  float chi2 = 0;       // noise-weighted residual of the chosen fit
  // χ²₂ − χ²₄ when the auto model fitted both orders (the likelihood-ratio
  // statistic; spatial_flags.hpp pools it over regions), else 0. The order
  // itself follows the appearance rule (step 3).
  float order_statistic = 0;
  std::uint8_t order = 0;   // 2 or 4; 0 for pixels flagged before fitting
  PixelFlag flag = PixelFlag::kExplained;
  // 1σ of Cm, Ch, βm, Che (parameter units) from the 4D parameter covariance
  // (Jᵀ Σ⁻¹ J + P)⁻¹ at the fit (J the table's Jacobian, Σ step 2's whole
  // covariance: camera noise and the learned discrepancy, P the parameter
  // box as a uniform prior); NaN where nothing was fitted or
  // EstimatorOptions::uncertainty is off. ch_che_correlation: the correlation
  // of Ch and Che in that covariance (near ±1: the data cannot separate them).
  float sigma[4] = {kNoSigma, kNoSigma, kNoSigma, kNoSigma};
  float ch_che_correlation = kNoSigma;
  static constexpr float kNoSigma = std::numeric_limits<float>::quiet_NaN();
};

// The auto model's fit at the order a pixel did not take (estimate()'s
// optional output), kept so that the spatial pass's pooled order switches a
// pixel to it (Estimator::estimate_from_fit) instead of fitting it again: the
// same inverter call on the same values, so the same estimate bit for bit.
// order 0: none (the pixel was not fitted at both orders).
struct OtherOrderFit {
  Fit fit;
  double chi2 = 0;  // the fit's χ² as PixelEstimate::chi2 weighs it (with the discrepancy)
  std::uint8_t order = 0;
};

// Cells known before the fit not to be skin (the white target): where
// `where` is nonzero the cell gets `flag` (one outside_the_skin()), NaN
// parameters and residual, and no fit; empty: every cell is fitted.
struct CellsNotFitted {
  std::span<const std::uint8_t> where;
  PixelFlag flag = PixelFlag::kWhiteTarget;
};

struct EstimatorOptions {
  InverterMethod method = InverterMethod::kFast;
  ModelChoice model = ModelChoice::kAuto;
  // The auto model's order rule (step 3): order 2 where the 2D fit's
  // appearance is within this factor k × the 4D fit's appearance uncertainty
  // (tuned on the lab's seed 5, docs/estimation.md).
  double order_appearance_factor = 1.0;
  // Which rule step 3 applies. kLikelihoodRatio: order 4 only when χ²₂ − χ²₄
  // exceeds the (1 − order_significance) quantile of χ² with min(C, 4) − 2
  // degrees of freedom (the rule before the appearance rule; no appearance
  // table is built). The spatial pass's pooled order (spatial_flags.hpp)
  // decides every explained pixel's order by that same test pooled over a
  // window, so maps::prepare_tables and `chromo estimate` choose it whenever
  // order pooling is on: the appearance rule's cost (≈ 1.2-2× per cell) is
  // then not paid for an order the pooling replaces.
  enum class OrderRule { kAppearance, kLikelihoodRatio };
  OrderRule order_rule = OrderRule::kAppearance;
  // The spatial pass's pooled likelihood-ratio test (spatial_flags.hpp).
  double order_significance = 0.01;
  double flag_significance = 0.001;
  double dark_albedo = 0.01;
  double min_specular = 0.01;     // smallest white surface reflection called specular
  // Model error added to the camera noise in quadrature: the table's
  // interpolation error and float storage (σ = model_sigma_relative · albedo);
  // without it a noise-free pixel would fail the χ² test on interpolation error alone.
  double model_sigma_relative = 0.003;
  // The skin model's learned discrepancy on real skin (model_discrepancy.hpp),
  // added to the noise wherever a residual is weighed (step 2); null: none
  // (the statistic of scenes rendered by the model itself). chromod and
  // `chromo estimate` pass ModelDiscrepancy::standard() by default.
  std::shared_ptr<const ModelDiscrepancy> discrepancy;
  // A prior over the parameters learned from real skin (step 4b,
  // parameter_prior.hpp), used on plans of at most prior_max_channels
  // channels (1-128); null: none (the maximum-likelihood fit).
  std::shared_ptr<const ParameterPrior> prior;
  int prior_max_channels = 4;
  // Per-pixel σ of the parameters (PixelEstimate::sigma).
  bool uncertainty = true;
  int threads = 0;                // estimate(): 0 = all cores
  int tile_pixels = 16384;        // estimate(): pixels per tile
  // Where the fast method's inverse table is cached (empty: ForwardTable::default_cache_dir()).
  std::filesystem::path cache_dir;
  // The fast inverter's stopping and acceptance settings (inverter.hpp).
  FastInverterOptions fast;
  // The subspace inverter's settings (subspace_inverter.hpp; its fallback
  // χ² is capped at the 4D flag threshold as the fast inverter's acceptance).
  SubspaceInverterOptions subspace;
  // The fast method inverts plans of more than four channels with the
  // subspace inverter (the fast inverter's pre-solved path exists for four
  // channels only; beyond them it searched in the full channel space). Chosen
  // on bench/inverter_speed_bench: within the accuracy rule on every plan,
  // scene and noise, docs/estimation.md "The subspace inverter". false:
  // today's fast inverter for every plan.
  bool subspace_beyond_four_channels = true;
  bool IsValid(std::string* error) const;
};

struct EstimateSummary {
  std::size_t pixels = 0;
  std::size_t processed = 0;      // < pixels when cancelled
  bool cancelled = false;
  double seconds = 0;
  std::size_t flag_counts[kPixelFlagCount] = {};
  std::size_t order2 = 0, order4 = 0;
  void merge(const EstimateSummary& other);
};

// Inverse χ² CDF (quantile) for k degrees of freedom, p in (0, 1).
double chi_squared_quantile(double p, int degrees_of_freedom);

class Estimator {
 public:
  // Throws std::invalid_argument for invalid options or a table whose channel
  // count differs from the set's.
  Estimator(std::shared_ptr<const ForwardTable> table, MeasurementSet set, EstimatorOptions options);

  int channels() const { return set_.size(); }
  const EstimatorOptions& options() const { return options_; }

  // A copy of this estimator whose learned discrepancy is Σ_disc × scale
  // (discrepancy_scale.hpp: one frame's skin outside the learned range),
  // sharing the tables and the inverter (no table is loaded or built; the
  // subspace inverter keeps its whitening reference, each fit weighs the
  // pixel with its own Σ). scale must be finite and > 0
  // (std::invalid_argument); 1 gives the same numbers as this estimator.
  Estimator with_discrepancy_scale(double scale) const;
  // The same with another learned discrepancy (null: none), times scale:
  // the bench's leave-one-subject-out statistics reuse one estimator.
  Estimator with_discrepancy(std::shared_ptr<const ModelDiscrepancy> discrepancy, double scale = 1) const;
  // A copy whose channel discrepancy is this one's plus `covariance` (C × C,
  // symmetric positive semi-definite: one frame's own term,
  // discrepancy_scale.hpp), sharing the tables and the inverter as above.
  // A wrong size or a non-finite value: std::invalid_argument.
  Estimator with_added_discrepancy(const Eigen::MatrixXd& covariance) const;
  // Σ_disc × discrepancy_scale() in the set's channels (C × C); empty without a discrepancy.
  const Eigen::MatrixXd& discrepancy_covariance() const { return discrepancy_; }
  double discrepancy_scale() const { return discrepancy_scale_; }
  const Inverter& inverter() const { return *inverter_; }
  const ForwardTable& table() const { return *table_; }
  const MeasurementSet& measurement_set() const { return set_; }

  // One pixel (channels() values), with the options' model or a given one.
  PixelEstimate estimate_pixel(const float* measured) const { return estimate_pixel(measured, options_.model); }
  PixelEstimate estimate_pixel(const float* measured, ModelChoice model) const {
    return estimate_pixel(measured, model, nullptr);
  }
  // The same; with model kAuto and `other` given, *other is set to the fit
  // of the order not taken (order 0 where there is none).
  PixelEstimate estimate_pixel(const float* measured, ModelChoice model, OtherOrderFit* other) const;
  // estimate_pixel(measured, other.order == 4 ? k4d : k2d) bit for bit, from
  // a fit estimate_pixel stored for these same measured values (other.order
  // 2 or 4, else std::invalid_argument); no inversion.
  PixelEstimate estimate_from_fit(const float* measured, const OtherOrderFit& other) const;
  // measured.size() == out.size() · channels(), not_fitted.where empty or
  // out.size() long, other empty or out.size() long (each pixel's
  // OtherOrderFit); std::invalid_argument otherwise.
  EstimateSummary estimate_tile(std::span<const float> measured, std::span<PixelEstimate> out,
                                CellsNotFitted not_fitted = {}, std::span<OtherOrderFit> other = {}) const;
  // The whole image on options().threads threads, tile by tile.
  EstimateSummary estimate(std::span<const float> measured, std::span<PixelEstimate> out,
                           const files::Progress& progress = {}, CellsNotFitted not_fitted = {},
                           std::span<OtherOrderFit> other = {}) const;

  // Predicted measurement of parameters through the table (for residual maps).
  void predict(const SkinParameters& p, double* out) const;
  // 1/σ_c of a channel at an albedo (camera noise and model error), as the fits use it.
  double weight(int channel, double albedo) const;
  // χ² above which a fit with `free_parameters` (2 or 4) free leaves a pixel unexplained.
  double flag_threshold(int free_parameters) const { return flag_threshold_[free_parameters == 2 ? 2 : 4]; }

 private:
  std::shared_ptr<const ForwardTable> table_;
  MeasurementSet set_;
  EstimatorOptions options_;
  std::shared_ptr<const Inverter> inverter_;  // shared by the copies with_discrepancy_scale() makes
  std::shared_ptr<const AppearanceTable> appearance_;  // the auto model's appearance rule; null otherwise
  double order_threshold_ = 0;                          // kLikelihoodRatio: the χ²₂ − χ²₄ quantile
  // The pixel's Σ (step 2) and the 4D parameter covariance at its fit (PixelEstimate::sigma).
  double fit_variance(int channel, double albedo) const;
  // The subspace inverter's reference σ per channel: the fit's σ (noise, model
  // error, the discrepancy's diagonal) at the channel's mean table value.
  std::vector<double> reference_sigma() const;
  // jacobian_at_x: the table's Jacobian at x when the caller has it (else it is interpolated here).
  // prior: the parameter prior's information replaces the box's (step 4b).
  void set_uncertainty(const detail::PixelCovariance& covariance, const GridPoint& x, PixelEstimate& out,
                       const double* jacobian_at_x = nullptr, const detail::GridPrior* prior = nullptr) const;
  // The specular test (step 5 above): the best 4D fit of measured − s over the
  // scanned s, continued from `start`; chi2 = ∞ when no s reaches min_specular.
  static constexpr int kSpecularSteps = 8;
  // kAuto: no 2D fit when χ²₄ exceeds this × the 2D flag threshold (unexplained either way).
  static constexpr double kHopelessChi2Factor = 10;
  static constexpr int kSpecularContinuationIterations = 4;
  // chi2: the χ² of a fit of (measured − s) as the flag test computes it.
  Fit specular_fit(const double* measured, const double* weight, const GridPoint& start,
                   const std::function<double(const Fit&, double s)>& chi2) const;
  // Steps 1-2 of a pixel: its flag before fitting (non-finite, saturated,
  // dark; returned) or its values, fit variances and fit weights 1/√Σ_cc of
  // its Σ (std::nullopt).
  std::optional<PixelEstimate> screen_pixel(const float* m, double* measured, double* variance, double* weight) const;
  // χ² of a fit of measured − s: the inverter's own weighted sum without a
  // discrepancy, rᵀ Σ⁻¹ r with one.
  double fit_chi2(const Fit& f, double s, const double* measured, const detail::PixelCovariance& covariance) const;
  // Steps 4-5 from the chosen fit: parameters, residual, σ, and for a pixel
  // the fit leaves unexplained the specular test from specular_start.
  void finish_pixel(const double* measured, const double* weight, const detail::PixelCovariance& covariance,
                    const Fit& chosen, double chosen_chi2, int order, const GridPoint& specular_start,
                    PixelEstimate& out) const;
  // Step 3's rule (EstimatorOptions::order_rule): may the pixel take the 2D fit?
  bool two_d_suffices(const ChannelBuffer<double>& measured, const Fit& fit4, double chi2_4, const Fit& fit2,
                      double chi2_2) const;
  double flag_threshold_[5] = {};  // by free parameters (index 2 and 4)
  Eigen::MatrixXd discrepancy_;    // Σ_disc × discrepancy_scale_ in the set's channels; empty without a discrepancy
  double discrepancy_scale_ = 1;
  std::shared_ptr<const detail::GridPrior> grid_prior_;  // step 4b's prior in grid units; null: none
};

std::unique_ptr<Inverter> make_inverter(InverterMethod method, std::shared_ptr<const ForwardTable> table,
                                        const std::filesystem::path& cache_dir = {},
                                        const FastInverterOptions& fast_options = {});

}  // namespace chromo::estimation
