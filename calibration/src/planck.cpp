#include "chromo/calibration/planck.hpp"

#include <array>
#include <cmath>
#include <utility>
#include <stdexcept>
#include <string>
#include <vector>

#include "chromo/spectral/grid.hpp"

namespace chromo::calibration {

double planck_radiance_W_per_m2_sr_nm(double wavelength_nm, double temperature_K) {
  if (!(wavelength_nm > 0.0) || !(temperature_K > 0.0))
    throw std::invalid_argument("Planck's law needs a positive wavelength and temperature (got " +
                                std::to_string(wavelength_nm) + " nm, " + std::to_string(temperature_K) + " K)");
  const double lambda_m = wavelength_nm * 1e-9;
  const double per_m = kPlanckC1L_Wm2_per_sr / std::pow(lambda_m, 5) / std::expm1(kPlanckC2_mK / (lambda_m * temperature_K));
  return per_m * 1e-9;  // per metre of wavelength → per nanometre
}

spectral::Spectrum planckian_spectrum(double temperature_K) {
  if (!(temperature_K > 0.0)) planck_radiance_W_per_m2_sr_nm(560.0, temperature_K);  // throws the documented error
  // λ⁻⁵ and c2/λ on the grid once: this runs inside the CCT search.
  static const auto [inverse_fifth, c2_over_lambda] = [] {
    std::array<double, spectral::kGridSize> p{}, c{};
    for (int i = 0; i < spectral::kGridSize; ++i) {
      const double lambda_m = spectral::grid_wavelength_nm(i) * 1e-9;
      p[i] = 1.0 / (lambda_m * lambda_m * lambda_m * lambda_m * lambda_m);
      c[i] = kPlanckC2_mK / lambda_m;
    }
    return std::pair{p, c};
  }();
  spectral::Spectrum s;
  for (int i = 0; i < spectral::kGridSize; ++i) s[i] = inverse_fifth[i] / std::expm1(c2_over_lambda[i] / temperature_K);
  constexpr int kIndex560 = static_cast<int>((560.0 - spectral::kGridStartNm) / spectral::kGridStepNm);
  return s * (100.0 / s[kIndex560]);
}

Uv1960 uv_1960(const spectral::Xyz& xyz) {
  const double d = xyz.X + 15.0 * xyz.Y + 3.0 * xyz.Z;
  return {4.0 * xyz.X / d, 6.0 * xyz.Y / d};
}

namespace {

double locus_distance_squared(double temperature_K, const Uv1960& target) {
  const Uv1960 p = uv_1960(spectral::xyz_of_light(planckian_spectrum(temperature_K)));
  return (p.u - target.u) * (p.u - target.u) + (p.v - target.v) * (p.v - target.v);
}

}  // namespace

CorrelatedColourTemperature correlated_colour_temperature(const spectral::Spectrum& spd) {
  const Uv1960 target = uv_1960(spectral::xyz_of_light(spd));
  // Coarse scan in mireds (the locus is close to uniform in 1/T) over a table
  // computed once, then golden section on the bracket around the best sample.
  constexpr double kMinMired = 1e6 / 100000.0, kMaxMired = 1e6 / 1000.0, kStepMired = 5.0;
  static const std::vector<Uv1960> locus = [] {
    std::vector<Uv1960> table;
    for (double m = kMinMired; m <= kMaxMired; m += kStepMired)
      table.push_back(uv_1960(spectral::xyz_of_light(planckian_spectrum(1e6 / m))));
    return table;
  }();
  double best_mired = kMinMired, best = INFINITY;
  for (std::size_t i = 0; i < locus.size(); ++i) {
    const double d = (locus[i].u - target.u) * (locus[i].u - target.u) + (locus[i].v - target.v) * (locus[i].v - target.v);
    if (d < best) best = d, best_mired = kMinMired + kStepMired * static_cast<double>(i);
  }
  double lo = std::max(kMinMired, best_mired - kStepMired), hi = std::min(kMaxMired, best_mired + kStepMired);
  const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
  double m1 = hi - ratio * (hi - lo), m2 = lo + ratio * (hi - lo);
  double d1 = locus_distance_squared(1e6 / m1, target), d2 = locus_distance_squared(1e6 / m2, target);
  while (hi - lo > 1e-4) {  // 1e-4 mired: < 0.01 K at 6500 K
    if (d1 < d2) {
      hi = m2, m2 = m1, d2 = d1, m1 = hi - ratio * (hi - lo), d1 = locus_distance_squared(1e6 / m1, target);
    } else {
      lo = m1, m1 = m2, d1 = d2, m2 = lo + ratio * (hi - lo), d2 = locus_distance_squared(1e6 / m2, target);
    }
  }
  const double cct_K = 1e6 / (0.5 * (lo + hi));
  const Uv1960 p = uv_1960(spectral::xyz_of_light(planckian_spectrum(cct_K)));
  const double distance = std::sqrt(locus_distance_squared(cct_K, target));
  return {cct_K, target.v >= p.v ? distance : -distance};
}

}  // namespace chromo::calibration
