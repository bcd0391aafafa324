#pragma once
// Helpers of the maps tests: uniform or two-patch parameter maps written as
// maps.exr, fresh temporary folders, and "nothing was written" checks.

#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <string>

#include "../support/fresh_directory.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/maps/profile_table.hpp"
#include "chromo/simulators/scene/rendered_session.hpp"

namespace chromo::maps::testing {

using chromo::testing::fresh_directory;

inline ParameterMaps uniform_maps(int width, int height, float cm, float ch, float bm, float che) {
  const std::size_t n = static_cast<std::size_t>(width) * height;
  return {width, height, std::vector<float>(n, cm), std::vector<float>(n, ch), std::vector<float>(n, bm),
          std::vector<float>(n, che), std::vector<float>(n, 0.0f)};
}

inline void write_maps(const std::filesystem::path& path, const ParameterMaps& m) {
  files::write_exr(path, {m.width, m.height, {"Cm", "Ch", "Bm", "Che", "flags"}, {m.cm, m.ch, m.bm, m.che, m.flags}});
}

// A tiny noisy rendered lab session: 128×96 sensor sites on a window of the
// 5-MP scene with enough texture for the registration.
inline simulators::RenderedSessionOptions tiny_lab_session_options() {
  simulators::RenderedSessionOptions o;
  o.sensor_width = 128, o.sensor_height = 96;
  o.scene_width = 2592, o.scene_height = 1944;
  o.window_x = 640, o.window_y = 1680;
  o.noise_free = false;
  return o;
}

// The folder does not exist, or holds nothing.
inline bool nothing_written(const std::filesystem::path& folder) {
  return !std::filesystem::exists(folder) || std::filesystem::is_empty(folder);
}

}  // namespace chromo::maps::testing
