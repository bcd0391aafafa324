#pragma once
// A skin's systematic shortfall taken as a local BIAS, not as noise (issue 37,
// docs/estimation.md "A subject's shortfall as a local bias").
//
// Real skin outside the model's learned range (NIST subject_006) leaves the
// same channel residual r = measured − W·model albedo(fit) at every pixel of
// the subject: the per-pixel χ² under the learned discrepancy then flags most
// of its skin (codes 5/6), and the spatial pass grows those flags over the
// rest. Ink, marker, hair and highlights are departures from the skin around
// them. This rule judges a flagged pixel against its neighbourhood's skin:
//
//  1. Samples: fitted pixels (flag 0, 5 or 6; not specular, saturated, dark,
//     non-finite or outside the skin) on a lattice of sample_step_px whose own
//     χ² is at most max_bias_factor × their flag threshold (a pixel further
//     from the model than any skin bias may be does not vote: ink, marker).
//  2. Reference b per tile of tile_px: the per-channel median of the samples'
//     residuals in the window_px square around the tile (at least
//     min_samples of them, else b = 0: nothing is absorbed).
//  3. Cap: the bias's own χ², bᵀ Σ_p⁻¹ b (Σ_p the pixel's covariance: camera
//     noise and the learned discrepancy, as the estimator's χ²), at most
//     max_bias_factor × the flag threshold; a larger b is shrunk onto the cap
//     (a frame mostly covered by ink: its median is ink, too far to absorb).
//  4. A pixel flagged 5 or 6 whose (r − b)ᵀ Σ_p⁻¹ (r − b) is within its flag
//     threshold becomes explained (parameters, order and χ² kept: χ² stays
//     the data's). No pixel is flagged by this rule; specular, saturated,
//     dark pixels are left alone.
//
// Off by default (LocalBiasOptions::enabled); the spatial pass runs it first
// when on (NeighbourhoodOptions::local_bias, skin_refit.hpp's spatial_pass).
//
// Thread rules: a pure function over caller-owned buffers, one thread.

#include <cstddef>
#include <span>
#include <string>

#include "chromo/estimation/estimator.hpp"

namespace chromo::estimation {

struct LocalBiasOptions {
  bool enabled = false;
  int window_px = 40;            // the reference's window (square side), larger than an ink disc where possible
  int tile_px = 8;               // the reference is computed once per tile
  int sample_step_px = 2;        // samples on this lattice
  int min_samples = 16;          // fewer samples in a window: no reference there (b = 0)
  double max_bias_factor = 1;    // the cap on b's χ² and on a voting sample's χ², × the flag threshold (subject_006: 0.63-0.73)
  bool IsValid(std::string* error) const;
};

struct LocalBiasSummary {
  std::size_t cleared = 0;        // pixels flagged 5/6 that the rule made explained
  std::size_t capped = 0;         // flagged pixels whose reference was shrunk onto the cap
  std::size_t tiles = 0;          // tiles with a reference (enough samples)
  // Over the flagged pixels with a reference: the median of the bias's χ² over
  // the flag threshold, before the cap (what a cap must absorb; 0: none).
  double median_bias_ratio = 0;
  double seconds = 0;             // wall
};

// measured: width·height·channels (the estimator's input, pixel-major);
// estimates: the per-pixel pass's output, updated in place (flags 5/6 → 0);
// summary's flag counts follow. Throws std::invalid_argument naming the
// problem (sizes, options out of range) and changes nothing then.
LocalBiasSummary clear_local_bias(const Estimator& estimator, std::span<const float> measured, int width, int height,
                                  std::span<PixelEstimate> estimates, EstimateSummary& summary,
                                  const LocalBiasOptions& options);

}  // namespace chromo::estimation
