#include "chromo/estimation/skin_parameters.hpp"

#include <cmath>
#include <cstdio>

namespace chromo::estimation {

std::optional<std::string> range_violation(const SkinParameters& p) {
  const std::array<std::pair<ParameterRange, double>, 4> checks{
      {{kCmRange, p.cm}, {kChRange, p.ch}, {kBmRange, p.bm}, {kCheRange, p.che}}};
  for (const auto& [range, value] : checks) {
    if (!std::isfinite(value) || !range.contains(value)) {
      char buffer[160];
      std::snprintf(buffer, sizeof buffer, "%.*s = %g is outside its range %g-%g", static_cast<int>(range.name.size()),
                    range.name.data(), value, range.min, range.max);
      return std::string(buffer);
    }
  }
  return std::nullopt;
}

}  // namespace chromo::estimation
