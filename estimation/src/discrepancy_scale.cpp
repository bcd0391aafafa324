#include "chromo/estimation/discrepancy_scale.hpp"

#include <omp.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "chromo/estimation/channel_buffer.hpp"

namespace chromo::estimation {

bool DiscrepancyScaleOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* message) {
    if (error) *error = message;
    return false;
  };
  if (!(quantile > 0 && quantile < 1)) return fail("quantile must be in (0, 1)");
  if (!(max_weight >= 0) || !std::isfinite(max_weight)) return fail("max_weight must be finite and >= 0");
  if (sample_pixels < 1) return fail("sample_pixels must be >= 1");
  if (min_pixels < 1) return fail("min_pixels must be >= 1");
  if (!(warn_above >= 1) || !std::isfinite(warn_above)) return fail("warn_above must be finite and >= 1");
  return true;
}

std::string DiscrepancyScale::warning() const {
  if (!warn) return "";
  char text[96];
  std::snprintf(text, sizeof text, "skin outside the model's learned range (scale %.3g)", scale);
  return text;
}

namespace {

// One sampled pixel: its residual after the fit and the Cholesky factor of
// its Σ_i (camera noise and model error, plus the learned Σ_disc).
struct SampledPixel {
  Eigen::VectorXd residual;
  Eigen::LLT<Eigen::MatrixXd> sigma;
  double chi2 = 0;     // r_iᵀ Σ_i⁻¹ r_i
  double cross = 0;    // r̄ᵀ Σ_i⁻¹ r_i
  double own = 0;      // r̄ᵀ Σ_i⁻¹ r̄
  double chi2_with(double k) const { return chi2 - k * cross * cross / (1 + k * own); }
};

SampledPixel sample_pixel(const Estimator& estimator, const float* measured, const PixelEstimate& fit) {
  const int c_count = estimator.channels();
  ChannelBuffer<double> predicted(c_count);
  estimator.predict(fit.parameters, predicted.data());
  SampledPixel p;
  p.residual.resize(c_count);
  Eigen::MatrixXd sigma = estimator.discrepancy_covariance();
  for (int c = 0; c < c_count; ++c) {
    p.residual(c) = measured[c] - predicted[c];
    const double w = estimator.weight(c, measured[c]);
    sigma(c, c) += 1 / (w * w);
  }
  p.sigma.compute(sigma);
  p.chi2 = p.residual.dot(p.sigma.solve(p.residual));
  return p;
}

double quantile_of(std::vector<double> values, double q) {
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(values.size() - 1) + 0.5);
  std::nth_element(values.begin(), at, values.end());
  return *at;
}

double quantile_with(const std::vector<SampledPixel>& pixels, double k, double q) {
  std::vector<double> values(pixels.size());
  for (std::size_t i = 0; i < pixels.size(); ++i) values[i] = pixels[i].chi2_with(k);
  return quantile_of(std::move(values), q);
}

// The sampled pixels the estimator fitted (non-finite, saturated, dark and not-fitted ones left out).
std::vector<SampledPixel> fitted_sample(const Estimator& estimator, std::span<const float> measured,
                                        const CellsNotFitted& not_fitted, int sample_pixels) {
  const std::size_t c_count = static_cast<std::size_t>(estimator.channels()), pixels = measured.size() / c_count;
  const std::size_t stride = std::max<std::size_t>(1, pixels / static_cast<std::size_t>(sample_pixels));
  std::vector<std::size_t> sampled;
  for (std::size_t i = stride / 2; i < pixels && sampled.size() < static_cast<std::size_t>(sample_pixels); i += stride)
    if (not_fitted.where.empty() || !not_fitted.where[i]) sampled.push_back(i);
  std::vector<SampledPixel> fitted(sampled.size());
  std::vector<std::uint8_t> used(sampled.size(), 0);
  const int threads = estimator.options().threads > 0 ? estimator.options().threads : omp_get_num_procs();
#pragma omp parallel for num_threads(threads) schedule(dynamic, 64)
  for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(sampled.size()); ++k) {
    const float* m = measured.data() + sampled[static_cast<std::size_t>(k)] * c_count;
    const PixelEstimate fit = estimator.estimate_pixel(m);
    if (fit.order == 0) continue;  // nothing fitted
    fitted[static_cast<std::size_t>(k)] = sample_pixel(estimator, m, fit);
    used[static_cast<std::size_t>(k)] = 1;
  }
  std::vector<SampledPixel> out;
  for (std::size_t k = 0; k < sampled.size(); ++k)
    if (used[k]) out.push_back(std::move(fitted[k]));
  return out;
}

void check_arguments(const Estimator& estimator, std::span<const float> measured, const CellsNotFitted& not_fitted,
                     const DiscrepancyScaleOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("discrepancy scale: " + error);
  const std::size_t c_count = static_cast<std::size_t>(estimator.channels());
  if (measured.size() % c_count != 0)
    throw std::invalid_argument("discrepancy scale: " + std::to_string(measured.size()) + " values are not whole pixels of " +
                                std::to_string(c_count) + " channels");
  if (!not_fitted.where.empty() && not_fitted.where.size() != measured.size() / c_count)
    throw std::invalid_argument("discrepancy scale: " + std::to_string(not_fitted.where.size()) + " cells not to fit for " +
                                std::to_string(measured.size() / c_count) + " pixels");
}

}  // namespace

DiscrepancyScale estimate_discrepancy_scale(const Estimator& estimator, std::span<const float> measured,
                                            CellsNotFitted not_fitted, const DiscrepancyScaleOptions& options) {
  check_arguments(estimator, measured, not_fitted, options);
  DiscrepancyScale out;
  out.max_weight = options.max_weight;
  const double q = options.quantile;
  out.expected_quantile = chi_squared_quantile(q, std::max(estimator.channels() - 4, 1));
  if (estimator.discrepancy_covariance().size() == 0 || measured.empty()) return out;
  std::vector<SampledPixel> pixels = fitted_sample(estimator, measured, not_fitted, options.sample_pixels);
  out.pixels = pixels.size();
  if (pixels.size() < static_cast<std::size_t>(options.min_pixels)) return out;
  out.quantile_chi2 = out.quantile_chi2_after = quantile_with(pixels, 0, q);
  out.scale = std::max(1.0, out.quantile_chi2 / out.expected_quantile);
  out.warn = out.scale > options.warn_above;
  if (out.quantile_chi2 <= out.expected_quantile) return out;
  // r̄: the mean residual of the reference pixels (at or below the quantile: the frame's skin).
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(estimator.channels());
  for (const SampledPixel& p : pixels)
    if (p.chi2 <= out.quantile_chi2) mean += p.residual, ++out.reference_pixels;
  mean /= static_cast<double>(out.reference_pixels);
  std::vector<double> own;
  for (SampledPixel& p : pixels) {
    const Eigen::VectorXd solved = p.sigma.solve(mean);
    p.cross = solved.dot(p.residual), p.own = solved.dot(mean);
    if (p.chi2 <= out.quantile_chi2) own.push_back(p.own);
  }
  out.distance2 = quantile_of(own, 0.5);
  // The quantile of χ²(k) decreases with k: bisection over [0, 2 max_weight].
  double lo = 0, hi = 2 * options.max_weight;
  if (quantile_with(pixels, hi, q) > out.expected_quantile) {
    out.unbounded = hi;
  } else {
    for (int i = 0; i < 50; ++i) {
      const double mid = 0.5 * (lo + hi);
      (quantile_with(pixels, mid, q) > out.expected_quantile ? lo : hi) = mid;
    }
    out.unbounded = hi;
  }
  out.weight = std::min(out.unbounded, options.max_weight);
  out.quantile_chi2_after = quantile_with(pixels, out.weight, q);
  if (out.weight > 0) out.residual = mean;
  return out;
}

FrameEstimator frame_estimator(const Estimator& base, std::span<const float> measured, CellsNotFitted not_fitted,
                               const DiscrepancyScaleOptions& options) {
  DiscrepancyScale scale = estimate_discrepancy_scale(base, measured, not_fitted, options);
  if (scale.weight <= 0) return {base, std::move(scale)};
  const Eigen::MatrixXd term = scale.weight * scale.residual * scale.residual.transpose();
  return {base.with_added_discrepancy(term), std::move(scale)};
}

}  // namespace chromo::estimation
