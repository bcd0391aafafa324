#pragma once
// Per-pixel flag codes of the estimator's output (maps.exr "flags" channel,
// summary.json "flag_counts"). 0: the model explains the pixel. Otherwise one
// code saying why not, checked in this order (1-6 per pixel by Estimator, 7 by
// the spatial second pass of spatial_flags.hpp, 8 where the measurement has
// no white reference, 9 where the pixel is the white target itself):

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
  kNeighbourhood = 7,        // explained alone, but part of a region that deviates from the skin
                             // around it and either touches a flagged region or differs from it
                             // by more than a Cm/Ch change (spatial_flags.hpp): weak tattoo or
                             // marker rims, weak highlights (fitted parameters kept, not to be trusted)
  kNoReference = 8,          // outside the camera's footprint of the white reference (a posed camera
                             // sees the target in perspective): no albedo, parameters NaN
                             // (session/method_measurement.hpp, set after the estimate by maps/)
  kWhiteTarget = 9,          // the white reference target in the subject's frame (the virtual lab's
                             // strip): its albedo is the target's ρ in every channel within noise;
                             // not skin, parameters NaN (maps/white_target_pixels.hpp, set after
                             // the estimate by maps/)
};
inline constexpr int kPixelFlagCount = 10;

// No skin at the pixel, so no parameters (NaN): outside the white reference's
// footprint, or the white target itself. Views count it outside, not masked.
constexpr bool outside_the_skin(PixelFlag flag) {
  return flag == PixelFlag::kNoReference || flag == PixelFlag::kWhiteTarget;
}

constexpr std::string_view pixel_flag_name(PixelFlag flag) {
  constexpr std::string_view kNames[kPixelFlagCount] = {
      "explained", "non_finite", "saturated", "dark", "specular", "unexplained_absorber", "unexplained_colour",
      "neighbourhood", "no_reference", "white_target"};
  return kNames[static_cast<int>(flag)];
}

}  // namespace chromo::estimation
