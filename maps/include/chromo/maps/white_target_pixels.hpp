#pragma once
// The white reference target seen in a subject's frame (the virtual lab's
// strip along the right edge; a reference patch left in the field): its
// albedo is the target's own reflectance ρ in every channel, which no skin
// reaches (skin's blue albedo stays below ~0.5). Such pixels are not skin:
// maps/ flags them white_target with no parameters (pixel_flags.hpp).

#include <cstdint>
#include <span>
#include <vector>

#include "chromo/estimation/measurement.hpp"

namespace chromo::maps {

// 1 where every channel of the pixel is within 4σ (the channel's noise at ρ)
// plus 3% of ρ of `white_reflectance`, else 0. `measured` holds one albedo
// per channel of `set` per pixel (pixel-major); a NaN channel is never white.
// Throws std::invalid_argument when measured's size is not a multiple of the
// set's channels or white_reflectance is not in (0, 1.5].
std::vector<std::uint8_t> white_target_pixels(std::span<const float> measured, const estimation::MeasurementSet& set,
                                              double white_reflectance);

}  // namespace chromo::maps
