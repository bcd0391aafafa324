#pragma once
// A multi-pixel estimate of skin's channel values: the camera noise of one
// pixel averaged with its neighbours where the flags call both skin and
// their colours agree within the noise (docs/estimation.md, "Relighting past
// the model").
//
// Each pixel's channels m_i (albedo units) are split into a brightness
// b_i = Σ_c m_ic and a shape s_i = m_i / b_i. Within a (2·radius+1)² window,
// a neighbour j joins pixel i when both are in `use` and their shapes agree:
//   D²_ij = Σ_c (s_ic − s_jc)² / (v_ic + v_jc) ≤ the χ²_{C−1} quantile at
//   `agreement_quantile` (v_ic = σ²_c(m_ic) / b_i², the shape's noise).
// The denoised value is b_i times the mean shape of the joined pixels: the
// brightness stays the pixel's own (a multiplicative texture is kept
// exactly), the colour is averaged only over pixels that look alike (a
// border of another material, a freckle beyond the noise, is not crossed).
// A sigma filter (Lee 1983) on the chromaticity.
//
// Thread rules: a pure function, reentrant.

#include <cstdint>
#include <span>
#include <vector>

#include "chromo/estimation/measurement.hpp"

namespace chromo::estimation {

struct SkinDenoiseOptions {
  int radius_px = 5;                  // window (2r+1)², 1-15 (5: real_skin_bench, against 3)
  double agreement_quantile = 0.9;    // of χ²_{C−1}: a neighbour whose shape differs more is not averaged (0.9: against 0.99)
};

struct DenoisedChannels {
  std::vector<float> values;           // pixels × channels; pixels outside `use` as given
  std::vector<std::uint16_t> joined;   // per pixel the count of pixels averaged (1: itself only; 0 outside `use`)
};

// values: width × height pixels × set.size() channels, pixel-major; use:
// one byte per pixel, non-zero where the pixel is skin to denoise (e.g. the
// estimator's kExplained). Throws std::invalid_argument naming the problem
// (sizes, options out of range).
DenoisedChannels denoise_skin_channels(std::span<const float> values, int width, int height, const MeasurementSet& set,
                                       std::span<const std::uint8_t> use, const SkinDenoiseOptions& options = {});

}  // namespace chromo::estimation
