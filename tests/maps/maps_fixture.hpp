#pragma once
// Helpers of the maps tests: uniform or two-patch parameter maps written as
// maps.exr, fresh temporary folders, and "nothing was written" checks.

#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <string>

#include "chromo/estimation/image_files.hpp"
#include "chromo/estimation/profile_table.hpp"

namespace chromo::estimation::testing {

inline std::filesystem::path fresh_directory(const std::string& name) {
  auto path = std::filesystem::temp_directory_path() /
              ("chromo-maps-" + name + "-" + std::to_string(::getpid()) + "-" + std::to_string(std::random_device{}()));
  std::filesystem::remove_all(path);
  std::filesystem::create_directories(path);
  return path;
}

inline ParameterMaps uniform_maps(int width, int height, float cm, float ch, float bm, float che) {
  const std::size_t n = static_cast<std::size_t>(width) * height;
  return {width, height, std::vector<float>(n, cm), std::vector<float>(n, ch), std::vector<float>(n, bm),
          std::vector<float>(n, che), std::vector<float>(n, 0.0f)};
}

inline void write_maps(const std::filesystem::path& path, const ParameterMaps& m) {
  write_exr(path, {m.width, m.height, {"Cm", "Ch", "Bm", "Che", "flags"}, {m.cm, m.ch, m.bm, m.che, m.flags}});
}

// The folder does not exist, or holds nothing.
inline bool nothing_written(const std::filesystem::path& folder) {
  return !std::filesystem::exists(folder) || std::filesystem::is_empty(folder);
}

}  // namespace chromo::estimation::testing
