#include "chromo/session/surface_factors.hpp"

#include <cmath>
#include <stdexcept>

#include "chromo/spectral/grid.hpp"
#include "chromo/spectral/resample.hpp"

namespace chromo::session {

SurfaceFactors surface_factors_of_extinction(const spectral::Spectrum& extinction_ratio, std::string source) {
  SurfaceFactors out;
  out.source = std::move(source);
  for (int i = 0; i < spectral::kGridSize; ++i) {
    const double er = extinction_ratio[i];
    if (!(std::isfinite(er) && er >= 1))
      throw std::invalid_argument("surface factors: the films' extinction ratio at " +
                                  std::to_string(spectral::grid_wavelength_nm(i)) + " nm is " + std::to_string(er) +
                                  " (k1/k2 must be finite and at least 1)");
    const double sum_squared = (1 + er) * (1 + er);
    out.cross[i] = 4 * er / sum_squared;
    out.parallel[i] = 2 * (1 + er * er) / sum_squared;
  }
  return out;
}

SurfaceFactors surface_factors_of_extinction_file(const std::filesystem::path& path) {
  try {
    return surface_factors_of_extinction(spectral::read_spectrum_file(path, "extinction_ratio"),
                                         "the films' datasheet curve " + path.string());
  } catch (const std::exception& error) {  // DataError (file) or invalid_argument (a ratio)
    throw std::invalid_argument(path.string() + ": " + error.what());
  }
}

double channel_surface_factor(const spectral::Spectrum& factor, const spectral::CameraSensitivity& camera,
                              const spectral::Spectrum& illuminant, int channel) {
  if (channel < 0 || channel > 2)
    throw std::invalid_argument("channel_surface_factor: channel " + std::to_string(channel) + " is not R, G or B");
  const spectral::GridArray weight = camera.rgb[static_cast<std::size_t>(channel)].values() * illuminant.values();
  const double total = weight.sum();
  if (!(total > 0))
    throw std::invalid_argument("channel_surface_factor: camera " + camera.name + " sees nothing of the illuminant in channel " +
                                std::to_string(channel));
  return (weight * factor.values()).sum() / total;
}

}  // namespace chromo::session
