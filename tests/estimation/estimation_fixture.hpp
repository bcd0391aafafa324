#pragma once
// Shared by the estimation tests: the method's measurement set (D65' mixed from
// the six LEDs, blue LED as "mix − W57", Nikon D5100) and its table, built
// once per test program.

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include "chromo/estimation/forward_table.hpp"
#include "chromo/spectral/lab_illuminants.hpp"
#include "chromo/estimation/measurement.hpp"

namespace chromo::estimation::testing {

// The fast inverter caches its inverse table in ForwardTable::default_cache_dir():
// tests keep it out of $HOME, in one directory per user reused across runs
// (the key names the file, so a changed table is rebuilt, never misread).
inline const bool kTestCacheDirSet = [] {
  const std::string dir = (std::filesystem::temp_directory_path() / ("chromo_test_cache_" + std::to_string(::getuid()))).string();
  ::setenv("CHROMO_CACHE_DIR", dir.c_str(), 0);
  return true;
}();

inline MeasurementSet method_set() {
  return method_measurement_set(spectral::builtin_camera("nikon_d5100"), spectral::led_d65_metamer(),
                                spectral::led_spectrum(spectral::LedType::kBlue));
}

inline std::shared_ptr<const ForwardTable> method_table() {
  static const std::shared_ptr<const ForwardTable> table =
      std::make_shared<const ForwardTable>(ForwardTable::build(method_set(), TableGrid{}));
  return table;
}

}  // namespace chromo::estimation::testing
