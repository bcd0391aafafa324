// The six LED types one at a time through the Nikon-like camera, with the
// camera noise of a well-exposed capture (160,000 e⁻ at full scale, 12 e⁻
// read): the 18-channel set the discrepancy tests learn and flag on.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "chromo/estimation/measurement.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::estimation::test {

inline MeasurementSet six_led_noisy_set() {
  std::vector<std::pair<std::string, spectral::Spectrum>> leds;
  for (auto type : spectral::kAllLedTypes) leds.emplace_back(std::string(spectral::led_type_name(type)), spectral::led_spectrum(type));
  MeasurementSet set = simulators::capture_measurement_set(spectral::builtin_camera("nikon_d5100"), leds);
  simulators::CameraNoiseModel noise;
  noise.electrons_at_full_scale = 160000, noise.read_noise_electrons = 12;
  simulators::set_exposure_noise(set, noise);
  return set;
}

}  // namespace chromo::estimation::test
