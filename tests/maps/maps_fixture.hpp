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

// The folder does not exist, or holds nothing.
inline bool nothing_written(const std::filesystem::path& folder) {
  return !std::filesystem::exists(folder) || std::filesystem::is_empty(folder);
}

}  // namespace chromo::maps::testing
