#include "chromo/calibration/mix_target.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>

#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::calibration {
namespace {

double parse_positive(std::string_view text, std::string_view spec, const char* what) {
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value) || !(value > 0))
    throw spectral::DataError("target '" + std::string(spec) + "': " + what + " '" + std::string(text) +
                              "' is not a positive number");
  return value;
}

}  // namespace

MixTarget d65_target() { return {"d65", spectral::illuminant_d65()}; }

MixTarget daylight_target(double cct_K) {
  char name[32];
  std::snprintf(name, sizeof name, "cct:%g", cct_K);
  return {name, spectral::daylight_illuminant(cct_K)};
}

MixTarget w57_plus_blue_target(const LedLibrary& library, const spectral::CameraSensitivity& camera,
                               double blue_to_w57_ratio) {
  if (!(blue_to_w57_ratio >= 0.0 && std::isfinite(blue_to_w57_ratio)))
    throw spectral::DataError("w57+blue: the blue ratio must be a non-negative number");
  const spectral::Spectrum w57 = library.led(LedType::kW57).spectrum_per_unit_drive();
  const spectral::Spectrum blue = library.led(LedType::kBlue).spectrum_per_unit_drive();
  const double camera_b_w57 = (camera.rgb[2].values() * w57.values()).sum();
  const double camera_b_blue = (camera.rgb[2].values() * blue.values()).sum();
  char name[40];
  std::snprintf(name, sizeof name, "w57+blue:%g", blue_to_w57_ratio);
  return {name, w57 + blue * (blue_to_w57_ratio * camera_b_w57 / camera_b_blue)};
}

MixTarget file_target(const std::string& path) { return {path, spectral::read_spectrum_file(path)}; }

MixTarget parse_mix_target(std::string_view spec, const LedLibrary& library, const spectral::CameraSensitivity& camera) {
  std::string lower(spec);
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  if (lower == "d65") return d65_target();
  if (lower == "w57+blue") return w57_plus_blue_target(library, camera, 1.0);
  if (lower.rfind("w57+blue:", 0) == 0)
    return w57_plus_blue_target(library, camera, parse_positive(std::string_view(spec).substr(9), spec, "blue ratio R"));
  if (lower.rfind("cct:", 0) == 0) return daylight_target(parse_positive(std::string_view(spec).substr(4), spec, "CCT"));
  if (lower.size() > 4 && lower.substr(lower.size() - 4) == ".csv") return file_target(std::string(spec));
  throw spectral::DataError("unknown target '" + std::string(spec) +
                            "' (expected d65, w57+blue[:R], cct:K or a .csv file with wavelength_nm,value)");
}

}  // namespace chromo::calibration
