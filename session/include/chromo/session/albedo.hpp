#pragma once
// Albedo: the one definition, used by the measurement builders
// (method_measurement.hpp: the estimator's input) and by derived data
// (derived_data.hpp: derived/albedo-*.exr). A pixel's reflectance against the
// white reference target, in the white's units scaled by its known
// reflectance ρ_white:
//
//   albedo = ρ_white / g · (subject − dark) / (white − dark),   g = t_subject / t_white
//
// with every value in units of the camera's full scale (0-1, dark level
// included); g takes a subject at another exposure than its white onto the
// white's (a camera linear in exposure above the dark: method_measurement.hpp
// "Exposure per capture"). Where white − dark ≤ kMinWhiteSignal there is no
// reference: the albedo is NaN. Computed in double, rounded once to float.
// Thread rules: pure functions.

#include <algorithm>
#include <cmath>
#include <limits>

namespace chromo::session {

// The least white − dark (share of full scale) a pixel's albedo is taken against.
inline constexpr float kMinWhiteSignal = 1e-3f;

// g = t_subject / t_white: the subject's exposure over its white's; 1 when
// either is unknown (≤ 0) or both are one exposure (within 1e-6, relative).
inline double subject_exposure_gain(double white_exposure_us, double subject_exposure_us) {
  const double w = white_exposure_us, s = subject_exposure_us;
  if (!(w > 0 && s > 0) || std::abs(w - s) <= 1e-6 * std::max(w, s)) return 1.0;
  return s / w;
}

// One pixel's albedo: rho_over_gain = ρ_white / g, white_signal = white − dark.
inline float albedo(float subject, float dark, float white_signal, double rho_over_gain) {
  return white_signal > kMinWhiteSignal ? static_cast<float>(rho_over_gain * (subject - dark) / white_signal)
                                        : std::numeric_limits<float>::quiet_NaN();
}

}  // namespace chromo::session
