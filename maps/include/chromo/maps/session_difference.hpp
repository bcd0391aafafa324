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
#include "chromo/maps/region_statistics.hpp"
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

// A region's change against its noise (what a per-pixel test cannot see: a
// Ch × 1.5 flush is a quarter of one pixel's noise on the virtual lab).
// Over the region's compared pixels: the median of the differences and its
// σ, 1.2533 · 1.4826 · MAD / √n (the median's σ for normal scatter, the
// scatter taken robustly from the median absolute deviation), and z =
// median / σ. The median, not the mean: an estimated Ch is heavy-tailed
// (many pixels at the model's bound, a few far above, split from Che
// differently from one noise draw to the next), and on the virtual lab two
// draws' region means differ by as much as the flush itself while their
// medians agree (docs/maps.md "Two sessions"). The σ maps' own σ of the mean
// √(Σσ²)/n and the mean difference are given for information: Ch's σ maps
// include the Ch-Che ambiguity and are several times the observed scatter.
struct RegionDifference {
  std::int64_t pixels = 0;          // compared (skin in both sessions)
  double median_difference = 0;     // NaN when no pixel was compared
  double sigma_of_median = 0;       // robust, from the differences' MAD
  double z = 0;                     // median_difference / sigma_of_median
  bool significant = false;         // |z| > threshold
  double mean_difference = 0;       // information
  double sigma_of_mean = 0;         // from the σ maps (information)
};
// std::invalid_argument when the rectangle is not inside the maps.
RegionDifference region_difference(const SessionDifference& d, const PixelRectangle& region, double threshold_sigma);

// The difference as maps: difference, sigma_difference, z and significant.
files::FloatImage difference_maps(const SessionDifference& d);

}  // namespace chromo::maps
