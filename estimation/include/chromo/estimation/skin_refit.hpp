#pragma once
// The multi-pixel estimate as a step of the estimate chain (docs/estimation.md
// "Relighting past the model"): after the per-pixel pass and the
// neighbourhood flags, the channels of the pixels still explained (flag 0)
// are denoised (skin_denoise.hpp) and those pixels fitted again; flags stay
// what the per-pixel data gave. `chromo estimate --skin-denoise on` and
// chromod's estimation.skin_denoise run it (spatial_pass()).
//
// Thread rules: a pure function over its arguments; the re-fit runs on the
// estimator's threads.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/skin_denoise.hpp"
#include "chromo/estimation/spatial_flags.hpp"

namespace chromo::estimation {

struct SkinRefit {
  // The channel values the chain goes on with (the spatial pass re-fits from
  // them): the denoised values where a pixel was re-fitted, the measured ones elsewhere.
  std::vector<float> values;
  // Per pixel the pixels averaged into `values` (1 where not re-fitted): their
  // noise is the channel's over this (the relit layer's posterior discrepancy
  // weighs the residual with it, maps/discrepancy_layer.hpp).
  std::vector<std::uint16_t> averaged;
  std::size_t refitted = 0;  // pixels whose estimate was replaced by the fit of their denoised channels
  double mean_joined = 0;    // pixels averaged per re-fitted pixel (1: none agreed with it)
  double seconds = 0;        // the denoising and the re-fit, wall
};

// measured: width × height pixels × estimator.channels(), pixel-major;
// estimates and summary: the per-pixel pass's over them. Every pixel with
// flag kExplained whose denoised channels are again explained gets the new
// fit (parameters, order, χ², σ); its flag stays kExplained; every other pixel
// is left as it was (a re-fit that would flag keeps the first fit).
// summary's order counts follow the replaced orders. other: empty, or the
// per-pixel pass's OtherOrderFit per pixel, replaced with the re-fit's where
// the estimate is (so that it stays the fit of the values the chain goes on
// with). Throws std::invalid_argument naming the problem (sizes, options out of range).
SkinRefit refit_denoised_skin(const Estimator& estimator, std::span<const float> measured, int width, int height,
                              std::span<PixelEstimate> estimates, EstimateSummary& summary,
                              const SkinDenoiseOptions& options = {}, std::span<OtherOrderFit> other = {});

struct SpatialPass {
  NeighbourhoodSummary neighbourhood;
  std::optional<LocalBiasSummary> local_bias;  // neighbourhood.local_bias.enabled: the local-bias rule ran first
  std::optional<SkinRefit> skin_refit;  // skin_denoise given: the multi-pixel estimate
  double neighbourhood_seconds = 0;     // the neighbourhood flags and the order pooling, wall
};

// The estimate chain after the per-pixel pass. With
// neighbourhood.local_bias.enabled, clear_local_bias() first (flags 5/6 of a
// skin's systematic shortfall cleared; local_bias.hpp). skin_denoise empty: exactly
// refine_with_neighbourhood(measured) when either of its parts is on (the
// per-pixel maps). Given: the neighbourhood flags on the measured channels,
// then refit_denoised_skin(), then the order pooling on the channels it
// returns (values kept in skin_refit). other: empty, or the per-pixel pass's
// OtherOrderFit per pixel (Estimator::estimate's), which the order pooling
// switches to instead of fitting again (same maps bit for bit; updated by the
// multi-pixel estimate's re-fit). Throws as the two functions do.
SpatialPass spatial_pass(const Estimator& estimator, std::span<const float> measured, int width, int height,
                         std::span<PixelEstimate> estimates, EstimateSummary& summary,
                         const NeighbourhoodOptions& neighbourhood,
                         const std::optional<SkinDenoiseOptions>& skin_denoise, std::span<OtherOrderFit> other = {});

}  // namespace chromo::estimation
