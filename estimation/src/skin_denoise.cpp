#include "chromo/estimation/skin_denoise.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "chromo/estimation/estimator.hpp"  // chi_squared_quantile

namespace chromo::estimation {

DenoisedChannels denoise_skin_channels(std::span<const float> values, int width, int height, const MeasurementSet& set,
                                       std::span<const std::uint8_t> use, const SkinDenoiseOptions& options) {
  const int c = set.size();
  if (width < 1 || height < 1 || c < 2)
    throw std::invalid_argument("denoise_skin_channels: need an image of at least 1×1 pixels and 2 channels, got " +
                                std::to_string(width) + "×" + std::to_string(height) + " and " + std::to_string(c));
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  if (values.size() != pixels * c || use.size() != pixels)
    throw std::invalid_argument("denoise_skin_channels: expected " + std::to_string(pixels * c) + " values and " +
                                std::to_string(pixels) + " mask bytes, got " + std::to_string(values.size()) + " and " +
                                std::to_string(use.size()));
  if (options.radius_px < 1 || options.radius_px > 15)
    throw std::invalid_argument("denoise_skin_channels: radius_px must be 1-15, got " + std::to_string(options.radius_px));
  if (!(options.agreement_quantile > 0 && options.agreement_quantile < 1))
    throw std::invalid_argument("denoise_skin_channels: agreement_quantile must be in (0, 1)");
  const double threshold = chi_squared_quantile(options.agreement_quantile, c - 1);

  // Per pixel: brightness, shape and the shape's noise variance; usable only
  // with a finite, positive brightness.
  std::vector<double> brightness(pixels, 0), shape(pixels * c, 0), shape_variance(pixels * c, 0);
  std::vector<std::uint8_t> usable(pixels, 0);
  for (std::size_t i = 0; i < pixels; ++i) {
    if (!use[i]) continue;
    double b = 0;
    bool finite = true;
    for (int k = 0; k < c; ++k) b += values[i * c + k], finite &= std::isfinite(values[i * c + k]);
    if (!finite || !(b > 0)) continue;
    usable[i] = 1;
    brightness[i] = b;
    for (int k = 0; k < c; ++k) {
      shape[i * c + k] = values[i * c + k] / b;
      shape_variance[i * c + k] = set.channels[k].noise.variance(values[i * c + k]) / (b * b);
    }
  }
  DenoisedChannels out{std::vector<float>(values.begin(), values.end()), std::vector<std::uint16_t>(pixels, 0)};
  const int r = options.radius_px;
#pragma omp parallel for schedule(dynamic, 8)
  for (int y = 0; y < height; ++y) {
    std::vector<double> sum(c);
    for (int x = 0; x < width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * width + x;
      if (!usable[i]) continue;
      std::fill(sum.begin(), sum.end(), 0.0);
      int joined = 0;
      for (int yy = std::max(0, y - r); yy <= std::min(height - 1, y + r); ++yy)
        for (int xx = std::max(0, x - r); xx <= std::min(width - 1, x + r); ++xx) {
          const std::size_t j = static_cast<std::size_t>(yy) * width + xx;
          if (!usable[j]) continue;
          double d2 = 0;
          for (int k = 0; k < c; ++k) {
            const double d = shape[i * c + k] - shape[j * c + k];
            d2 += d * d / std::max(shape_variance[i * c + k] + shape_variance[j * c + k], 1e-30);
          }
          if (j != i && d2 > threshold) continue;
          for (int k = 0; k < c; ++k) sum[k] += shape[j * c + k];
          ++joined;
        }
      for (int k = 0; k < c; ++k) out.values[i * c + k] = static_cast<float>(brightness[i] * sum[k] / joined);
      out.joined[i] = static_cast<std::uint16_t>(joined);
    }
  }
  return out;
}

}  // namespace chromo::estimation
