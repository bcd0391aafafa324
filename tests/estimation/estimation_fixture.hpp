#pragma once
// Shared by the estimation tests: the method's measurement set (D65' mixed from
// the six LEDs, blue LED as "mix − W57", Nikon D5100) and its table, loaded
// from the tests' table cache (built once per cache).

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

// The method set's table from the tests' cache directory (above): built by
// the first test process of a fresh cache, loaded by every other one (ctest
// runs each test in a process of its own, and the build was ~0.3 s of each
// small test's ~0.6-1 s). A table of another model, grid or set has another
// key and is rebuilt, never misread (ForwardTable::cache_key).
inline std::shared_ptr<const ForwardTable> method_table() {
  static const std::shared_ptr<const ForwardTable> table =
      ForwardTable::load_or_build(method_set(), TableGrid{}, ForwardTable::default_cache_dir());
  return table;
}

// The same table built in this process, never loaded: for the tests of the
// table's own values (forward_table_test.cpp), which a cached file would hide.
inline std::shared_ptr<const ForwardTable> built_method_table() {
  static const std::shared_ptr<const ForwardTable> table =
      std::make_shared<const ForwardTable>(ForwardTable::build(method_set(), TableGrid{}));
  return table;
}

}  // namespace chromo::estimation::testing
