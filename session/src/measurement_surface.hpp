#pragma once
// The polarised surface correction of a measurement whose captures hold a
// parallel one (method_measurement.hpp, Captures::parallel, Measurement::
// surface and surface_correction): the surface maps from the parallel
// capture (D65' parallel) against the first, cross one (D65'), and the
// surface light they keep taken out of the cross captures' albedo. Internal to session/; pure functions.

#include <array>
#include <cstdint>
#include <vector>

#include "measurement_references.hpp"

namespace chromo::session::measurement {

// Measurement::surface (G), surface_red, surface_blue and
// surface_sigma from D65' parallel against the cross D65', pixel by pixel on
// the same grid: not registered. The parallel capture is taken right after
// the cross one (the plan puts it there), and ECC between the two is driven
// by the very highlights that differ between them (on the rendered lab
// session it found 6-7 px of motion where there was none), so a warp would
// do more harm than the subject's motion between two consecutive captures.
// Returns, per channel, where the parallel capture is saturated (its S is a
// lower bound there).
std::array<std::vector<std::uint8_t>, 3> add_surface_map(Measurement& m, const Captures& captures,
                                                         const References& references, const Normalised& cross);

// The cross captures' albedo (every capture: D65', and W57 and W57+blue on its grid) less
// the surface light they keep above the sheen's: c_cross,k,c·(S_c − F_c)
// where S_G stands out (SurfaceCorrection). Where the parallel capture is saturated
// in a channel its S_c is a lower bound: that channel takes S_G instead (the
// surface reflection is flat in wavelength to about 1% for η = 1.4).
void remove_surface_light(Measurement& m, const Captures& captures,
                          const std::array<std::vector<std::uint8_t>, 3>& parallel_saturated,
                          std::vector<Normalised>& cross_captures);

}  // namespace chromo::session::measurement
