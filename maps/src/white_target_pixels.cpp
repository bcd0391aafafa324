// The white target in a subject's frame (white_target_pixels.hpp).
#include "chromo/maps/white_target_pixels.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace chromo::maps {

std::vector<std::uint8_t> white_target_pixels(std::span<const float> measured, const estimation::MeasurementSet& set,
                                              double white_reflectance) {
  const std::size_t channels = set.channels.size();
  if (channels == 0 || measured.size() % channels != 0)
    throw std::invalid_argument("white_target_pixels: " + std::to_string(measured.size()) + " values are not whole pixels of " +
                                std::to_string(channels) + " channels");
  if (!(white_reflectance > 0 && white_reflectance <= 1.5))
    throw std::invalid_argument("white_target_pixels: white reflectance " + std::to_string(white_reflectance) +
                                " is not in (0, 1.5]");
  std::vector<double> allowed(channels);  // |albedo − ρ| within this, per channel
  for (std::size_t c = 0; c < channels; ++c)
    allowed[c] = 4 * std::sqrt(set.channels[c].noise.variance(white_reflectance)) + 0.03 * white_reflectance;
  std::vector<std::uint8_t> white(measured.size() / channels, 0);
  for (std::size_t i = 0; i < white.size(); ++i) {
    bool all = true;
    for (std::size_t c = 0; c < channels && all; ++c) {
      const double albedo = measured[i * channels + c];
      all = std::isfinite(albedo) && std::abs(albedo - white_reflectance) <= allowed[c];
    }
    white[i] = all ? 1 : 0;
  }
  return white;
}

}  // namespace chromo::maps
