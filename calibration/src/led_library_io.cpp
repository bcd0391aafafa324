#include "chromo/calibration/led_library_io.hpp"

#include <cctype>
#include <cmath>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "chromo/files/durable_file.hpp"
#include "chromo/files/bounded_read.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::calibration {
namespace {

using nlohmann::json;
using spectral::DataError;

// Field access that names what is wrong: "source: leds[1].ladder[0].drive_level: expected a number".
class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    throw DataError(source_ + ": " + path + ": " + what);
  }
  const json& field(const json& object, const std::string& path, const char* key) const {
    if (!object.is_object()) fail(path, "expected an object");
    const auto it = object.find(key);
    if (it == object.end()) fail(join(path, key), "missing");
    return *it;
  }
  static std::string join(const std::string& path, const char* key) { return path.empty() ? key : path + "." + key; }

  double number(const json& value, const std::string& path) const {
    if (!value.is_number()) fail(path, "expected a number, got " + value.dump());
    const double v = value.get<double>();
    if (!std::isfinite(v)) fail(path, "not a finite number");
    return v;
  }
  std::optional<double> optional_number(const json& object, const std::string& path, const char* key) const {
    const auto it = object.find(key);
    if (it == object.end() || it->is_null()) return std::nullopt;
    return number(*it, join(path, key));
  }
  std::string string(const json& value, const std::string& path) const {
    if (!value.is_string()) fail(path, "expected a string, got " + value.dump());
    return value.get<std::string>();
  }
  std::string optional_string(const json& object, const std::string& path, const char* key) const {
    const auto it = object.find(key);
    return it == object.end() || it->is_null() ? std::string() : string(*it, join(path, key));
  }
  spectral::Spectrum spectrum(const json& value, const std::string& path) const {
    if (!value.is_array() || value.size() != spectral::kGridSize)
      fail(path, "expected " + std::to_string(spectral::kGridSize) + " numbers (380-780 nm, 5 nm), got " +
                     (value.is_array() ? std::to_string(value.size()) + " values" : value.dump()));
    spectral::Spectrum s;
    for (int i = 0; i < spectral::kGridSize; ++i) s[i] = number(value[i], path + "[" + std::to_string(i) + "]");
    return s;
  }

 private:
  std::string source_;
};

json optional_to_json(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

LedLibrary from_json(const json& root, const Reader& in) {
  LedLibrary lib;
  if (in.string(in.field(root, "", "format"), "format") != kLedLibraryFormat)
    in.fail("format", "expected \"" + std::string(kLedLibraryFormat) + "\"");
  const double version = in.number(in.field(root, "", "format_version"), "format_version");
  if (version != kLedLibraryFormatVersion)
    in.fail("format_version", "unsupported version " + in.field(root, "", "format_version").dump() +
                                  " (this build reads version " + std::to_string(kLedLibraryFormatVersion) + ")");
  lib.source = in.string(in.field(root, "", "source"), "source");
  if (lib.source != "measured" && lib.source != "nominal") in.fail("source", "expected \"measured\" or \"nominal\"");
  lib.created_utc = in.string(in.field(root, "", "created_utc"), "created_utc");

  const json& wavelengths = in.field(root, "", "wavelength_nm");
  const spectral::Spectrum grid = in.spectrum(wavelengths, "wavelength_nm");
  for (int i = 0; i < spectral::kGridSize; ++i)
    if (grid[i] != spectral::grid_wavelength_nm(i))
      in.fail("wavelength_nm[" + std::to_string(i) + "]", "expected " + std::to_string(spectral::grid_wavelength_nm(i)) +
                                                             " (the project grid, 380-780 nm at 5 nm)");

  const json& instrument = in.field(root, "", "instrument");
  lib.instrument.spectrometer_model = in.string(in.field(instrument, "instrument", "spectrometer_model"), "instrument.spectrometer_model");
  lib.instrument.spectrometer_serial = in.string(in.field(instrument, "instrument", "spectrometer_serial"), "instrument.spectrometer_serial");
  if (const auto it = instrument.find("response_calibration"); it != instrument.end() && !it->is_null()) {
    const std::string path = "instrument.response_calibration";
    ResponseCalibrationRecord rc;
    rc.reference_lamp = in.string(in.field(*it, path, "reference_lamp"), path + ".reference_lamp");
    rc.lamp_temperature_K = in.number(in.field(*it, path, "lamp_temperature_K"), path + ".lamp_temperature_K");
    if (!(rc.lamp_temperature_K > 0)) in.fail(path + ".lamp_temperature_K", "must be positive");
    rc.calibrated_utc = in.string(in.field(*it, path, "calibrated_utc"), path + ".calibrated_utc");
    rc.correction = in.spectrum(in.field(*it, path, "correction"), path + ".correction");
    if (rc.correction.values().abs().maxCoeff() > kMaxLibrarySpectrumValue)
      in.fail(path + ".correction", "a value beyond the 1e12 cap on |value|");
    lib.instrument.response_calibration = rc;
  }
  const json& conditions = in.field(root, "", "conditions");
  lib.conditions.ambient_temperature_C = in.optional_number(conditions, "conditions", "ambient_temperature_C");
  lib.conditions.warm_up_s = in.optional_number(conditions, "conditions", "warm_up_s");
  lib.conditions.notes = in.optional_string(conditions, "conditions", "notes");

  const json& leds = in.field(root, "", "leds");
  if (!leds.is_array() || leds.size() != spectral::kLedTypeCount)
    in.fail("leds", "expected an array of " + std::to_string(spectral::kLedTypeCount) + " records (W57,W40,W27,R,G,B)");
  std::array<bool, spectral::kLedTypeCount> seen{};
  for (std::size_t k = 0; k < leds.size(); ++k) {
    const std::string path = "leds[" + std::to_string(k) + "]";
    const std::string type_name = in.string(in.field(leds[k], path, "type"), path + ".type");
    const auto type = spectral::parse_led_type(type_name);
    if (!type) in.fail(path + ".type", "unknown LED type '" + type_name + "' (expected W57, W40, W27, R, G or B)");
    if (seen[spectral::led_type_index(*type)]) in.fail(path + ".type", "LED type " + type_name + " appears twice");
    seen[spectral::led_type_index(*type)] = true;
    LedRecord& led = lib.led(*type);
    led.type = *type;
    led.description = in.optional_string(leds[k], path, "description");
    led.max_drive_level = in.number(in.field(leds[k], path, "max_drive_level"), path + ".max_drive_level");
    const json& ladder = in.field(leds[k], path, "ladder");
    if (!ladder.is_array() || ladder.empty()) in.fail(path + ".ladder", "expected a non-empty array");
    for (std::size_t r = 0; r < ladder.size(); ++r) {
      const std::string rung = path + ".ladder[" + std::to_string(r) + "]";
      LedSpectrumSample s;
      s.drive_level = in.number(in.field(ladder[r], rung, "drive_level"), rung + ".drive_level");
      s.led_temperature_C = in.optional_number(ladder[r], rung, "led_temperature_C");
      s.integration_time_us = in.optional_number(ladder[r], rung, "integration_time_us");
      const json& dark = in.field(ladder[r], rung, "dark_subtracted");
      if (!dark.is_boolean()) in.fail(rung + ".dark_subtracted", "expected true or false");
      s.dark_subtracted = dark.get<bool>();
      s.spectrum = in.spectrum(in.field(ladder[r], rung, "spectrum"), rung + ".spectrum");
      led.ladder.push_back(s);
    }
    if (const auto it = leds[k].find("thermal"); it != leds[k].end() && !it->is_null()) {
      const std::string at = path + ".thermal";
      auto value = [&](const char* key) { return in.number(in.field(*it, at, key), Reader::join(at, key)); };
      led.thermal = LedThermalRecord{value("drive_level"), value("cold_C"), value("warm_C"), value("flux_change_per_K"),
                                     value("centroid_shift_nm_per_K")};
    }
  }
  if (const std::string error = validate(lib); !error.empty()) in.fail("leds", error);
  return lib;
}

}  // namespace

LedLibrary parse_led_library(std::string_view json_text, const std::string& source) {
  json root;
  try {
    root = json::parse(json_text);
  } catch (const json::exception& e) {  // parse_error, and out_of_range for numbers such as 1e999
    throw DataError(source + ": not valid JSON (" + e.what() + ")");
  }
  return from_json(root, Reader(source));
}

LedLibrary load_led_library(const std::filesystem::path& path) {
  std::string text;
  try {
    text = files::read_text_file(path, "LED library");
  } catch (const files::InputFileError& e) {
    throw DataError(e.what());
  }
  return parse_led_library(text, path.string());
}

std::string led_library_to_json(const LedLibrary& library) {
  nlohmann::ordered_json root;
  root["format"] = kLedLibraryFormat;
  root["format_version"] = kLedLibraryFormatVersion;
  root["source"] = library.source;
  root["created_utc"] = library.created_utc;
  std::vector<double> grid;
  for (int i = 0; i < spectral::kGridSize; ++i) grid.push_back(spectral::grid_wavelength_nm(i));
  root["wavelength_nm"] = grid;
  nlohmann::ordered_json instrument;
  instrument["spectrometer_model"] = library.instrument.spectrometer_model;
  instrument["spectrometer_serial"] = library.instrument.spectrometer_serial;
  if (const auto& rc = library.instrument.response_calibration) {
    instrument["response_calibration"] = {{"reference_lamp", rc->reference_lamp},
                                          {"lamp_temperature_K", rc->lamp_temperature_K},
                                          {"calibrated_utc", rc->calibrated_utc},
                                          {"correction", rc->correction.to_vector()}};
  } else {
    instrument["response_calibration"] = nullptr;
  }
  root["instrument"] = instrument;
  root["conditions"] = {{"ambient_temperature_C", optional_to_json(library.conditions.ambient_temperature_C)},
                        {"warm_up_s", optional_to_json(library.conditions.warm_up_s)},
                        {"notes", library.conditions.notes}};
  nlohmann::ordered_json leds = nlohmann::ordered_json::array();
  for (const LedRecord& led : library.leds) {
    nlohmann::ordered_json record;
    record["type"] = spectral::led_type_name(led.type);
    record["description"] = led.description;
    record["max_drive_level"] = led.max_drive_level;
    nlohmann::ordered_json ladder = nlohmann::ordered_json::array();
    for (const LedSpectrumSample& s : led.ladder) {
      nlohmann::ordered_json rung;
      rung["drive_level"] = s.drive_level;
      rung["led_temperature_C"] = optional_to_json(s.led_temperature_C);
      rung["integration_time_us"] = optional_to_json(s.integration_time_us);
      rung["dark_subtracted"] = s.dark_subtracted;
      rung["spectrum"] = s.spectrum.to_vector();
      ladder.push_back(rung);
    }
    record["ladder"] = ladder;
    if (const auto& t = led.thermal)
      record["thermal"] = {{"drive_level", t->drive_level},
                           {"cold_C", t->cold_C},
                           {"warm_C", t->warm_C},
                           {"flux_change_per_K", t->flux_change_per_K},
                           {"centroid_shift_nm_per_K", t->centroid_shift_nm_per_K}};
    leds.push_back(record);
  }
  root["leds"] = leds;
  return root.dump(1) + "\n";
}

void save_led_library(const LedLibrary& library, const std::filesystem::path& path) {
  if (const std::string error = validate(library); !error.empty())
    throw DataError("refusing to save an invalid LED library to " + path.string() + ": " + error);
  try {
    files::write_file_durably(path, led_library_to_json(library), nullptr);
  } catch (const std::exception& e) {
    throw DataError(path.string() + ": cannot write LED library (" + e.what() + ")");
  }
}

std::filesystem::path led_library_directory() {
  if (const char* home = std::getenv("CHROMO_HOME"); home && *home) return std::filesystem::path(home) / "leds";
  if (const char* xdg = std::getenv("XDG_DATA_HOME"); xdg && *xdg)
    return std::filesystem::path(xdg) / "chromosphere" / "leds";
  const char* home = std::getenv("HOME");
  return std::filesystem::path(home ? home : ".") / ".local" / "share" / "chromosphere" / "leds";
}

std::filesystem::path latest_led_library_path() {
  const std::filesystem::path directory = led_library_directory();
  std::error_code error;
  if (!std::filesystem::is_directory(directory, error)) return {};
  std::filesystem::path latest;
  for (const auto& entry : std::filesystem::directory_iterator(directory, error)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("led-library-", 0) == 0 && name.size() > 5 && name.substr(name.size() - 5) == ".json" &&
        (latest.empty() || name > latest.filename().string()))
      latest = entry.path();
  }
  return latest;
}

std::string led_library_file_name(const LedLibrary& library) {
  std::string stamp;
  for (char c : library.created_utc)
    if (std::isalnum(static_cast<unsigned char>(c))) stamp += c;
  return "led-library-" + stamp + ".json";
}

}  // namespace chromo::calibration
