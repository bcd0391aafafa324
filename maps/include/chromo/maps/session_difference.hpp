#pragma once
// Two sessions of one subject compared (issue 42, before/after: flushing, a
// treatment, a season): the after session's maps registered onto the
// before's (session/registration.hpp: ECC on Cm, the skin's own texture;
// no warp when the motion is within its noise), then per pixel
//
//   difference = after − before,  σ = √(σ_before² + σ_after²),  z = difference / σ
//
// from each session's sigma_<channel> map (the estimator's 1σ), and the
// pixels where |z| exceeds the threshold: what changed beyond the noise.
// Only pixels that are skin in both sessions (finite value and σ, flag
// explained or specular) are compared; the others are NaN.
// Thread rules: free functions, reentrant.

#include <cstdint>
#include <string>
#include <vector>

#include "chromo/files/float_image.hpp"
#include "chromo/session/registration.hpp"

namespace chromo::maps {

struct SessionDifferenceOptions {
  std::string channel = "Ch";
  double threshold_sigma = 3;  // |z| above it: a change
  bool register_sessions = true;
};

struct SessionDifference {
  int width = 0, height = 0;
  std::vector<float> difference, sigma, z;  // width × height; NaN where not compared
  std::vector<std::uint8_t> significant;    // 1 where |z| > threshold
  session::RegistrationResult registration; // after → before (identity when not registered)
  double motion_px = 0;                     // the registration's largest corner displacement
  bool warped = false;                      // the after maps were warped onto the before's grid
  std::int64_t compared_pixels = 0, significant_pixels = 0;
  files::FloatImage after_registered;       // the after maps on the before's grid (every channel)
};

// std::invalid_argument naming "before"/"after" when the maps differ in size
// or lack the channel, its sigma_ or the flags; session::RegistrationError
// when registration fails.
SessionDifference session_difference(const files::FloatImage& before, const files::FloatImage& after,
                                     const SessionDifferenceOptions& options = {});

// The difference as maps: difference, sigma_difference, z and significant.
files::FloatImage difference_maps(const SessionDifference& d);

}  // namespace chromo::maps
