#pragma once
// What the real-skin benches (real_skin_bench, seed_study_bench) share: the
// camera's noise (four frames of a 40,000 e⁻ sensor per capture, 12 e⁻
// read, times a scale), the six LEDs one at a time as a measurement set, and
// a plan's forward table on the default grid, and a plan as these benches
// hold it.

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/measurement.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::bench {

inline simulators::CameraNoiseModel real_skin_camera_noise(double scale) {
  simulators::CameraNoiseModel n;
  n.electrons_at_full_scale = 4 * 40000.0;
  n.read_noise_electrons = 12;
  n.noise_scale = scale;
  return n;
}

// R, G, B under each LED type alone (18 channels).
inline estimation::MeasurementSet six_led_measurement_set(const spectral::CameraSensitivity& camera) {
  std::vector<std::pair<std::string, spectral::Spectrum>> leds;
  for (auto type : spectral::kAllLedTypes) leds.emplace_back(std::string(spectral::led_type_name(type)), spectral::led_spectrum(type));
  return simulators::capture_measurement_set(camera, leds);
}

// A plan's measurement set and forward table (and, where a bench times them,
// the seconds the forward and the subspace tables took to build).
struct RealSkinPlan {
  std::string name;
  estimation::MeasurementSet set;
  std::shared_ptr<const estimation::ForwardTable> table;
  double table_build_s = 0, subspace_build_s = 0;
};

inline std::shared_ptr<const estimation::ForwardTable> default_table(const estimation::MeasurementSet& set) {
  return std::make_shared<const estimation::ForwardTable>(estimation::ForwardTable::build(set, estimation::TableGrid{}, 2));
}

}  // namespace chromo::bench
