// The relit layer as a step of the estimate chain and its summary.json record
// (estimate_report.hpp: estimate_discrepancy_layer, discrepancy_layer_report).
#include <nlohmann/json.hpp>

#include "chromo/maps/estimate_report.hpp"

namespace chromo::maps {

std::optional<DiscrepancyLayer> estimate_discrepancy_layer(const estimation::Estimator& estimator,
                                                           std::span<const float> measured,
                                                           std::span<const estimation::PixelEstimate> estimates,
                                                           const estimation::SkinRefit* refit, int terms) {
  const estimation::EstimatorOptions& options = estimator.options();
  if (terms <= 0 || !options.discrepancy) return std::nullopt;
  DiscrepancyLayerInput input;
  input.table = &estimator.table();
  input.set = &estimator.measurement_set();
  // The multi-pixel estimate fitted its denoised channels: the residual is against them, with their lower noise.
  input.values = refit ? std::span<const float>(refit->values) : measured;
  if (refit) input.averaged = refit->averaged;
  input.estimates = estimates;
  input.model_sigma_relative = options.model_sigma_relative;
  return discrepancy_layer(input, *options.discrepancy, terms, options.threads);
}

nlohmann::ordered_json discrepancy_layer_report(const DiscrepancyLayer* layer) {
  nlohmann::ordered_json r{{"enabled", layer != nullptr}};
  if (!layer) return r;
  r["terms"] = layer->basis.terms();
  r["pixels"] = layer->pixels;
  r["seconds"] = layer->seconds;
  r["what"] =
      "each explained pixel's posterior discrepancy (zero-mean prior, the learned Sigma_r) on the leading eigenvectors "
      "of Sigma_r: maps.exr channels discrepancy_<k>, basis in the header attribute chromo.discrepancy_basis; every "
      "relighting adds it (docs/estimation.md 'Relighting past the model')";
  return r;
}

}  // namespace chromo::maps
