#pragma once
// Per-pixel flag codes of the estimator's output (maps.exr "flags" channel,
// summary.json "flag_counts"). 0: the model explains the pixel. Otherwise one
// code saying why not, checked in this order:

#include <cstdint>
#include <string_view>

namespace chromo::estimation {

enum class PixelFlag : std::uint8_t {
  kExplained = 0,
  kNonFinite = 1,     // a channel is NaN or infinite (parameters set to 0)
  kSaturated = 2,     // a channel at or above its saturation albedo (parameters 0)
  kDark = 3,          // every channel below dark_albedo: shadow, hair, no signal (parameters 0)
  kSpecular = 4,      // unexplained as is, explained after removing a white surface
                      // reflection: parameters are those of the skin underneath
  kUnexplainedAbsorber = 5,  // no parameters explain it and it is darker than the best fit in
                             // every channel: tattoo ink, dark veins, dirt (best-fit parameters kept)
  kUnexplainedColour = 6,    // no parameters explain it otherwise: marker pen, paint, dye
};
inline constexpr int kPixelFlagCount = 7;

constexpr std::string_view pixel_flag_name(PixelFlag flag) {
  constexpr std::string_view kNames[kPixelFlagCount] = {
      "explained", "non_finite", "saturated", "dark", "specular", "unexplained_absorber", "unexplained_colour"};
  return kNames[static_cast<int>(flag)];
}

}  // namespace chromo::estimation
