// The number of LED types, under the short name the calibration sources use.
#pragma once

#include "chromo/spectral/led_type.hpp"

namespace chromo::calibration {
inline constexpr int kLeds = spectral::kLedTypeCount;
}  // namespace chromo::calibration
