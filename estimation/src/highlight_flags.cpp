#include "chromo/estimation/highlight_flags.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace chromo::estimation {

HighlightFlags flag_highlights(std::span<const float> surface, std::span<const float> sigma, int width, int height,
                               const HighlightFlagOptions& options) {
  const std::size_t n = static_cast<std::size_t>(std::max(width, 0)) * static_cast<std::size_t>(std::max(height, 0));
  if (width <= 0 || height <= 0 || surface.size() != n || sigma.size() != n)
    throw std::invalid_argument("flag_highlights: surface and sigma must both hold width × height values");
  if (!(options.pixel_sigmas > 0 && options.window_sigmas > 0 && options.sheen_cap > 0))
    throw std::invalid_argument("flag_highlights: pixel_sigmas, window_sigmas and sheen_cap must be positive");
  HighlightFlags out;
  out.flag.assign(n, 0);
  std::vector<float> finite;
  for (std::size_t i = 0; i < n; ++i)
    if (std::isfinite(surface[i]) && std::isfinite(sigma[i]) && sigma[i] > 0) finite.push_back(surface[i]);
  if (finite.empty()) return out;
  const auto middle = finite.begin() + static_cast<std::ptrdiff_t>(finite.size() / 2);
  std::nth_element(finite.begin(), middle, finite.end());
  out.sheen_reference = std::min<double>(*middle, options.sheen_cap);
  auto usable = [&](std::size_t i) { return std::isfinite(surface[i]) && std::isfinite(sigma[i]) && sigma[i] > 0; };
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * width + x;
      if (!usable(i) || surface[i] - out.sheen_reference < options.pixel_sigmas * sigma[i]) continue;
      double excess = 0, variance = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int nx = x + dx, ny = y + dy;
          if (nx < 0 || ny < 0 || nx >= width || ny >= height) continue;
          const std::size_t j = static_cast<std::size_t>(ny) * width + nx;
          if (!usable(j)) continue;
          excess += surface[j] - out.sheen_reference;
          variance += static_cast<double>(sigma[j]) * sigma[j];
        }
      if (excess >= options.window_sigmas * std::sqrt(variance)) out.flag[i] = 1, ++out.flagged;
    }
  return out;
}

}  // namespace chromo::estimation
