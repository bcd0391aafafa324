// A ΔE statistics block as the reports and the API's JSON write it.
#pragma once

#include <nlohmann/json.hpp>

#include "chromo/maps/reconstruction.hpp"

namespace chromo::maps {

inline nlohmann::ordered_json delta_e_stats_json(const DeltaEStats& s) {
  return {{"mean", s.mean}, {"median", s.median}, {"p95", s.p95}, {"max", s.max}, {"pixels", s.pixels}};
}

}  // namespace chromo::maps
