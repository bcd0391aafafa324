#pragma once
// How the benches tell the estimator what noise its data carry. Noise-free
// frames can be estimated two ways: with the camera's noise declared (what
// the daemon does, since it cannot know a frame is noise-free) or declared
// noise-free (the truth about the data: read σ 1e-6, no shot or white-reference noise). The
// model order follows the declared noise (estimator.hpp, step 3), so the
// benches report both.
#include "chromo/estimation/measurement.hpp"

namespace chromo::bench {

inline estimation::MeasurementSet declared_noise_free(estimation::MeasurementSet set) {
  for (estimation::MeasurementChannel& c : set.channels) c.noise.read_sigma = 1e-6, c.noise.shot_coefficient = 0, c.noise.white_coefficient = 0;
  return set;
}

}  // namespace chromo::bench
