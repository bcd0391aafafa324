// A ΔE statistics block as the reports and the API's JSON write it.
#pragma once

#include <nlohmann/json.hpp>

#include "chromo/maps/estimate_report.hpp"
#include "chromo/maps/reconstruction.hpp"

namespace chromo::maps {

inline nlohmann::ordered_json delta_e_stats_json(const DeltaEStats& s) {
  return {{"mean", s.mean}, {"median", s.median}, {"p95", s.p95}, {"max", s.max}, {"pixels", s.pixels}};
}

// One relit comparison: its statistics, and with a photograph of known noise
// that noise's statistics ("photograph_noise") and "beyond_noise_rms".
inline nlohmann::ordered_json relit_comparison_json(const RelitComparison& r) {
  nlohmann::ordered_json j = delta_e_stats_json(r.delta_e94);
  if (r.photograph_noise) {
    j["photograph_noise"] = delta_e_stats_json(*r.photograph_noise);
    j["beyond_noise_rms"] = r.beyond_noise_rms;
  }
  if (r.block_means) j["block_means"] = delta_e_stats_json(*r.block_means);
  return j;
}

}  // namespace chromo::maps
