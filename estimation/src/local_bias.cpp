// A skin's systematic shortfall as a local bias (local_bias.hpp).
#include "chromo/estimation/local_bias.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "pixel_covariance.hpp"

namespace chromo::estimation {

bool LocalBiasOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (tile_px < 1 || tile_px > 256) return fail("local_bias.tile_px must be 1-256");
  if (window_px < tile_px || window_px > 4096) return fail("local_bias.window_px must be tile_px-4096");
  if (sample_step_px < 1 || sample_step_px > 64) return fail("local_bias.sample_step_px must be 1-64");
  if (min_samples < 1) return fail("local_bias.min_samples must be >= 1");
  if (!(max_bias_factor >= 0 && max_bias_factor <= 1000)) return fail("local_bias.max_bias_factor must be 0-1000");
  return true;
}

namespace {

bool fitted(PixelFlag f) {
  return f == PixelFlag::kExplained || f == PixelFlag::kUnexplainedAbsorber || f == PixelFlag::kUnexplainedColour;
}
bool unexplained(PixelFlag f) { return f == PixelFlag::kUnexplainedAbsorber || f == PixelFlag::kUnexplainedColour; }

// The pixel's covariance as the estimator's χ² builds it (estimator.hpp step 2).
detail::PixelCovariance covariance_at(const Estimator& estimator, const float* m, std::vector<double>& variance) {
  for (int c = 0; c < estimator.channels(); ++c) {
    const double w = estimator.weight(c, m[c]);
    variance[c] = 1 / (w * w);
  }
  return detail::PixelCovariance(variance.data(), estimator.discrepancy_covariance(), estimator.channels());
}

// r = measured − predicted at the pixel's fit.
void residual_at(const Estimator& estimator, const float* m, const PixelEstimate& e, std::vector<double>& r) {
  estimator.predict(e.parameters, r.data());
  for (int c = 0; c < estimator.channels(); ++c) r[c] = m[c] - r[c];
}

// Per tile, the per-channel median residual of the voting samples in the window around it (empty: too few).
struct References {
  int cols = 0, rows = 0;
  std::vector<std::vector<double>> bias;  // per tile, channels values or empty
};

References tile_references(const Estimator& estimator, std::span<const float> measured, int width, int height,
                           std::span<const PixelEstimate> estimates, const LocalBiasOptions& o) {
  const int channels = estimator.channels();
  References refs;
  refs.cols = (width + o.tile_px - 1) / o.tile_px, refs.rows = (height + o.tile_px - 1) / o.tile_px;
  // The voting samples' residuals, grouped by tile.
  std::vector<std::vector<float>> samples(static_cast<std::size_t>(refs.cols) * refs.rows);
  std::vector<double> r(channels);
  for (int y = 0; y < height; y += o.sample_step_px)
    for (int x = 0; x < width; x += o.sample_step_px) {
      const std::size_t p = static_cast<std::size_t>(y) * width + x;
      const PixelEstimate& e = estimates[p];
      if (!fitted(e.flag) || !(e.chi2 <= o.max_bias_factor * estimator.flag_threshold(e.order))) continue;
      residual_at(estimator, &measured[p * channels], e, r);
      auto& s = samples[static_cast<std::size_t>(y / o.tile_px) * refs.cols + x / o.tile_px];
      for (double v : r) s.push_back(static_cast<float>(v));
    }
  const int radius = std::max(0, static_cast<int>(std::lround((static_cast<double>(o.window_px) / o.tile_px - 1) / 2)));
  refs.bias.resize(samples.size());
  std::vector<float> window, channel;
  for (int ty = 0; ty < refs.rows; ++ty)
    for (int tx = 0; tx < refs.cols; ++tx) {
      window.clear();
      for (int y = std::max(0, ty - radius); y <= std::min(refs.rows - 1, ty + radius); ++y)
        for (int x = std::max(0, tx - radius); x <= std::min(refs.cols - 1, tx + radius); ++x) {
          const auto& s = samples[static_cast<std::size_t>(y) * refs.cols + x];
          window.insert(window.end(), s.begin(), s.end());
        }
      const std::size_t n = window.size() / channels;
      if (n < static_cast<std::size_t>(o.min_samples)) continue;
      std::vector<double>& b = refs.bias[static_cast<std::size_t>(ty) * refs.cols + tx];
      b.resize(channels);
      channel.resize(n);
      for (int c = 0; c < channels; ++c) {
        for (std::size_t i = 0; i < n; ++i) channel[i] = window[i * channels + c];
        std::nth_element(channel.begin(), channel.begin() + n / 2, channel.end());
        b[c] = channel[n / 2];
      }
    }
  return refs;
}

}  // namespace

LocalBiasSummary clear_local_bias(const Estimator& estimator, std::span<const float> measured, int width, int height,
                                  std::span<PixelEstimate> estimates, EstimateSummary& summary,
                                  const LocalBiasOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("local bias options: " + error);
  const int channels = estimator.channels();
  if (width < 1 || height < 1 || estimates.size() != static_cast<std::size_t>(width) * height ||
      measured.size() != estimates.size() * static_cast<std::size_t>(channels))
    throw std::invalid_argument("local bias: " + std::to_string(width) + "x" + std::to_string(height) + " pixels, " +
                                std::to_string(estimates.size()) + " estimates, " + std::to_string(measured.size()) +
                                " measured values for " + std::to_string(channels) + " channels");
  LocalBiasSummary out;
  const References refs = tile_references(estimator, measured, width, height, estimates, options);
  for (const auto& b : refs.bias) out.tiles += !b.empty();
  std::vector<double> r(channels), variance(channels), shifted(channels), ratios;
  for (std::size_t p = 0; p < estimates.size(); ++p) {
    PixelEstimate& e = estimates[p];
    if (!unexplained(e.flag)) continue;
    const int y = static_cast<int>(p / width), x = static_cast<int>(p % width);
    const std::vector<double>& b = refs.bias[static_cast<std::size_t>(y / options.tile_px) * refs.cols + x / options.tile_px];
    if (b.empty()) continue;
    const float* m = &measured[p * channels];
    const detail::PixelCovariance cov = covariance_at(estimator, m, variance);
    const double threshold = estimator.flag_threshold(e.order);
    const double bias_chi2 = cov.chi2(b.data());
    ratios.push_back(bias_chi2 / threshold);
    const double cap = options.max_bias_factor * threshold;
    const double shrink = bias_chi2 > cap ? std::sqrt(cap / bias_chi2) : 1.0;
    out.capped += shrink < 1;
    residual_at(estimator, m, e, r);
    for (int c = 0; c < channels; ++c) shifted[c] = r[c] - shrink * b[c];
    if (!(cov.chi2(shifted.data()) <= threshold)) continue;
    --summary.flag_counts[static_cast<int>(e.flag)];
    ++summary.flag_counts[static_cast<int>(PixelFlag::kExplained)];
    e.flag = PixelFlag::kExplained;
    ++out.cleared;
  }
  if (!ratios.empty()) {
    std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
    out.median_bias_ratio = ratios[ratios.size() / 2];
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace chromo::estimation
