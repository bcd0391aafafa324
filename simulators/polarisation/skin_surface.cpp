#include "chromo/simulators/polarisation/skin_surface.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace chromo::simulators {

double fresnel_reflectance_unpolarised(double eta, double theta_rad) {
  if (!(eta > 0)) throw std::invalid_argument("fresnel_reflectance_unpolarised: eta must be positive");
  if (!(std::abs(theta_rad) < std::numbers::pi / 2))
    throw std::invalid_argument("fresnel_reflectance_unpolarised: incidence " + std::to_string(theta_rad) +
                                " rad is not below pi/2");
  const double cos_i = std::cos(theta_rad);
  const double sin_t = std::sin(theta_rad) / eta;
  const double cos_t = std::sqrt(1.0 - sin_t * sin_t);
  const double rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  const double rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

}  // namespace chromo::simulators
