// The configuration's value readers: see config_values.hpp.
#include "config_values.hpp"

#include <cmath>
#include <set>

namespace chromo::daemon::config_values {

using nlohmann::json;

std::string shown(const json& value) {
  std::string text = value.dump();
  return text.size() > 64 ? text.substr(0, 61) + "..." : text;
}

std::uint64_t read_unsigned(const json& value, std::uint64_t min, std::uint64_t max) {
  const std::string range = "[" + std::to_string(min) + ", " + std::to_string(max) + "]";
  if (!value.is_number_integer()) throw std::invalid_argument(shown(value) + " is not an integer in " + range);
  // A JSON built in C++ holds small integers as signed ones: only the value counts.
  const bool negative = !value.is_number_unsigned() && value.get<std::int64_t>() < 0;
  if (!negative) {
    const auto v = value.get<std::uint64_t>();
    if (v >= min && v <= max) return v;
  }
  throw std::invalid_argument(shown(value) + " is outside " + range);
}

std::int64_t read_signed(const json& value, std::int64_t min, std::int64_t max) {
  const std::string range = "[" + std::to_string(min) + ", " + std::to_string(max) + "]";
  if (!value.is_number_integer()) throw std::invalid_argument(shown(value) + " is not an integer in " + range);
  if (value.is_number_unsigned() && value.get<std::uint64_t>() > static_cast<std::uint64_t>(max))
    throw std::invalid_argument(shown(value) + " is outside " + range);
  const auto v = value.get<std::int64_t>();
  if (v < min || v > max) throw std::invalid_argument(shown(value) + " is outside " + range);
  return v;
}

double read_number(const json& value, double min, double max, bool min_open) {
  const std::string range = std::string(min_open ? "(" : "[") + json(min).dump() + ", " + json(max).dump() + "]";
  if (!value.is_number()) throw std::invalid_argument(shown(value) + " is not a number in " + range);
  const double v = value.get<double>();
  if (!std::isfinite(v) || v < min || v > max || (min_open && v == min))
    throw std::invalid_argument(shown(value) + " is outside " + range);
  return v;
}

std::string read_string(const json& value) {
  if (!value.is_string()) throw std::invalid_argument(shown(value) + " is not a string");
  return value.get<std::string>();
}

drivers::DriveLevels read_levels(const json& value) {
  if (!value.is_object()) throw std::invalid_argument(shown(value) + " is not an object of LED levels");
  drivers::DriveLevels levels{};
  for (const auto& [key, level] : value.items()) {
    auto type = spectral::parse_led_type(key);
    if (!type) throw std::invalid_argument(key + ": not an LED type (W57, W40, W27, R, G, B)");
    try {
      levels[static_cast<std::size_t>(spectral::led_type_index(*type))] = read_number(level, 0, 1, false);
    } catch (const std::invalid_argument& error) {
      throw std::invalid_argument(key + ": " + error.what());
    }
  }
  return levels;
}

DeviceConfig read_device(const json& device) {
  if (!device.is_object()) throw std::invalid_argument("must be a JSON object");
  static const std::set<std::string> known{"name", "kind", "backend", "address", "settings"};
  for (const auto& [key, value] : device.items())
    if (!known.count(key)) throw std::invalid_argument(key + ": unknown key (name, kind, backend, address, settings)");
  auto field = [&](const char* key, bool required) -> std::string {
    if (!device.contains(key)) {
      if (required) throw std::invalid_argument(std::string(key) + ": missing");
      return {};
    }
    try {
      return read_string(device.at(key));
    } catch (const std::invalid_argument& error) {
      throw std::invalid_argument(std::string(key) + ": " + error.what());
    }
  };
  DeviceConfig d;
  d.name = field("name", true);
  const std::string kind = field("kind", true);
  if (kind == "led_controller") d.kind = DeviceKind::kLedController;
  else if (kind == "camera") d.kind = DeviceKind::kCamera;
  else if (kind == "spectrometer") d.kind = DeviceKind::kSpectrometer;
  else throw std::invalid_argument("kind: \"" + kind + "\" is not led_controller, camera or spectrometer");
  d.backend = field("backend", true);
  d.address = field("address", false);
  if (device.contains("settings")) {
    if (!device.at("settings").is_object()) throw std::invalid_argument("settings: must be a JSON object");
    d.settings = device.at("settings");
  }
  return d;
}

}  // namespace chromo::daemon::config_values
