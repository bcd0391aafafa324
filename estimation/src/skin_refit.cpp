#include "chromo/estimation/skin_refit.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

namespace chromo::estimation {

SkinRefit refit_denoised_skin(const Estimator& estimator, std::span<const float> measured, int width, int height,
                              std::span<PixelEstimate> estimates, EstimateSummary& summary,
                              const SkinDenoiseOptions& options, std::span<OtherOrderFit> other) {
  const auto start = std::chrono::steady_clock::now();
  const std::size_t pixels = static_cast<std::size_t>(std::max(width, 0)) * static_cast<std::size_t>(std::max(height, 0));
  if (estimates.size() != pixels)
    throw std::invalid_argument("refit_denoised_skin: expected " + std::to_string(pixels) + " estimates, got " +
                                std::to_string(estimates.size()));
  if (!other.empty() && other.size() != pixels)
    throw std::invalid_argument("refit_denoised_skin: expected " + std::to_string(pixels) + " other-order fits, got " +
                                std::to_string(other.size()));
  std::vector<std::uint8_t> explained(pixels), not_refitted(pixels);
  for (std::size_t i = 0; i < pixels; ++i) {
    explained[i] = estimates[i].flag == PixelFlag::kExplained;
    not_refitted[i] = !explained[i];
  }
  DenoisedChannels denoised =
      denoise_skin_channels(measured, width, height, estimator.measurement_set(), explained, options);
  std::vector<PixelEstimate> refit(pixels);
  std::vector<OtherOrderFit> refit_other(other.empty() ? 0 : pixels);
  // Only the explained pixels are fitted again; the others' results are not used.
  estimator.estimate(denoised.values, refit, {}, {not_refitted, PixelFlag::kWhiteTarget}, refit_other);
  SkinRefit out;
  out.averaged.assign(pixels, 1);
  const int channels = estimator.channels();
  std::size_t joined = 0;
  for (std::size_t i = 0; i < pixels; ++i) {
    if (!explained[i]) continue;
    if (refit[i].flag != PixelFlag::kExplained) {
      // The first fit stands, and so do the channels the chain goes on with.
      std::copy_n(measured.begin() + i * channels, channels, denoised.values.begin() + i * channels);
      continue;
    }
    if (estimates[i].order == 2) --summary.order2;
    if (estimates[i].order == 4) --summary.order4;
    if (refit[i].order == 2) ++summary.order2;
    if (refit[i].order == 4) ++summary.order4;
    estimates[i] = refit[i];
    if (!other.empty()) other[i] = refit_other[i];
    ++out.refitted;
    joined += denoised.joined[i];
    out.averaged[i] = std::max<std::uint16_t>(denoised.joined[i], 1);
  }
  out.values = std::move(denoised.values);
  out.mean_joined = out.refitted ? static_cast<double>(joined) / static_cast<double>(out.refitted) : 0.0;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

SpatialPass spatial_pass(const Estimator& estimator, std::span<const float> measured, int width, int height,
                         std::span<PixelEstimate> estimates, EstimateSummary& summary,
                         const NeighbourhoodOptions& neighbourhood,
                         const std::optional<SkinDenoiseOptions>& skin_denoise, std::span<OtherOrderFit> other) {
  SpatialPass out;
  if (neighbourhood.local_bias.enabled) {
    std::string error;
    if (!neighbourhood.IsValid(&error)) throw std::invalid_argument("neighbourhood options: " + error);
    out.local_bias = clear_local_bias(estimator, measured, width, height, estimates, summary, neighbourhood.local_bias);
  }
  auto timed_refine = [&](std::span<const float> values, const NeighbourhoodOptions& parts) {
    const auto start = std::chrono::steady_clock::now();
    const NeighbourhoodSummary s =
        refine_with_neighbourhood(estimator, values, width, height, estimates, summary, parts, other);
    out.neighbourhood_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return s;
  };
  if (!skin_denoise) {
    if (neighbourhood.flags || neighbourhood.pool_order) out.neighbourhood = timed_refine(measured, neighbourhood);
    return out;
  }
  NeighbourhoodOptions flags_only = neighbourhood, pool_only = neighbourhood;
  flags_only.pool_order = false;
  pool_only.flags = false;
  if (flags_only.flags) out.neighbourhood = timed_refine(measured, flags_only);
  out.skin_refit = refit_denoised_skin(estimator, measured, width, height, estimates, summary, *skin_denoise, other);
  if (pool_only.pool_order) {
    const NeighbourhoodSummary pooled = timed_refine(out.skin_refit->values, pool_only);
    out.neighbourhood.order_to_2 = pooled.order_to_2, out.neighbourhood.order_to_4 = pooled.order_to_4;
  }
  return out;
}

}  // namespace chromo::estimation
