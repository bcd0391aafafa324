#pragma once
// Reading and writing LED libraries (docs/formats/led-library.md). Every
// malformed input raises spectral::DataError naming the source and the JSON
// path of the field at fault ("leds[2].ladder[0].spectrum: expected 81
// numbers, got 80"); nothing is guessed or defaulted silently.

#include <filesystem>
#include <string>
#include <string_view>

#include "chromo/calibration/led_library.hpp"

namespace chromo::calibration {

inline constexpr std::string_view kLedLibraryFormat = "chromosphere-led-library";
inline constexpr int kLedLibraryFormatVersion = 1;

LedLibrary parse_led_library(std::string_view json_text, const std::string& source);
LedLibrary load_led_library(const std::filesystem::path& path);
std::string led_library_to_json(const LedLibrary& library);
// Writes to a temporary file beside `path` and renames it into place, so a
// crash never leaves a half-written library. Validates first (DataError).
void save_led_library(const LedLibrary& library, const std::filesystem::path& path);

// Where libraries live: $CHROMO_HOME/leds when CHROMO_HOME is set, else
// $XDG_DATA_HOME/chromosphere/leds, else ~/.local/share/chromosphere/leds.
std::filesystem::path led_library_directory();
// The newest library there: the greatest file name matching
// led-library-*.json (names carry a UTC timestamp, led-library-20261122T160000Z.json,
// so that is the latest). Empty path when there is none.
std::filesystem::path latest_led_library_path();
// The file name a library created at `created_utc` gets in that directory.
std::string led_library_file_name(const LedLibrary& library);

}  // namespace chromo::calibration
