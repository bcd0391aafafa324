#pragma once
// Subsurface spread in the benches' real-skin scenes, per wavelength: light
// entering skin leaves it around the entry point, wider in the red than in
// the blue, so a photograph's albedo at a pixel is the skin's own albedo
// blurred with a kernel that grows with wavelength. The real-skin scene is a
// strip of patches (SyntheticOptions::patch_pixels pixels each of one
// measured spectrum times a ±3% texture factor s_i); this blurs s_i, per
// wavelength, with a Gaussian of σ(λ) pixels, within each patch (normalised
// at its ends), so pixel i's albedo becomes S(λ)·s̃_i(λ).
//
// σ(λ): the virtual lab's default (simulators::SubsurfaceSpread, 0.5 px at
// ≤ 450 nm rising linearly to 3 px at ≥ 700 nm; the lab's skin scene applies
// the same spread in 2D with SkinSceneOptions::subsurface). A documented
// assumption of the virtual lab, not a measured point spread function
// (docs/estimation.md).

#include <algorithm>
#include <cmath>
#include <span>
#include <vector>

#include "chromo/simulators/scene/scene.hpp"
#include "chromo/spectral/grid.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::bench {

inline double spread_sigma_px(double wavelength_nm) { return simulators::SubsurfaceSpread{}.sigma_px(wavelength_nm); }

// texture: s_i of every pixel; patch_pixels: pixels per patch (patches are
// consecutive). Returns s̃_i(λ), one GridArray per pixel; with spread off,
// s_i at every wavelength.
inline std::vector<spectral::GridArray> spread_texture(std::span<const float> texture, int patch_pixels, bool spread) {
  std::vector<spectral::GridArray> out(texture.size());
  if (!spread) {
    for (std::size_t i = 0; i < texture.size(); ++i) out[i] = spectral::GridArray::Constant(texture[i]);
    return out;
  }
  for (int l = 0; l < spectral::kGridSize; ++l) {
    const double sigma = spread_sigma_px(spectral::grid_wavelength_nm(l));
    const int radius = static_cast<int>(std::ceil(3 * sigma));
    std::vector<double> kernel(2 * radius + 1);
    for (int k = -radius; k <= radius; ++k) kernel[k + radius] = std::exp(-0.5 * k * k / (sigma * sigma));
    for (std::size_t i = 0; i < texture.size(); ++i) {
      const std::size_t start = i / patch_pixels * patch_pixels;
      const std::size_t end = std::min(texture.size(), start + patch_pixels);
      double sum = 0, weight = 0;
      for (int k = -radius; k <= radius; ++k) {
        const std::ptrdiff_t j = static_cast<std::ptrdiff_t>(i) + k;
        if (j < static_cast<std::ptrdiff_t>(start) || j >= static_cast<std::ptrdiff_t>(end)) continue;
        sum += kernel[k + radius] * texture[j], weight += kernel[k + radius];
      }
      out[i][l] = sum / weight;
    }
  }
  return out;
}

}  // namespace chromo::bench
