#pragma once
// The configuration's value readers (config.cpp's key table uses them): the
// JSON type and range of one value. Each throws std::invalid_argument with
// what is wrong; the caller names the key. Pure functions.

#include <cstdint>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "chromo/daemon/config.hpp"

namespace chromo::daemon::config_values {

// A value as an error message shows it (at most 64 characters).
std::string shown(const nlohmann::json& value);
std::uint64_t read_unsigned(const nlohmann::json& value, std::uint64_t min, std::uint64_t max);
std::int64_t read_signed(const nlohmann::json& value, std::int64_t min, std::int64_t max);
// In [min, max], or (min, max] when min_open; finite.
double read_number(const nlohmann::json& value, double min, double max, bool min_open);
std::string read_string(const nlohmann::json& value);

// What a key holding other keys throws: its message starts with the path
// below the key (".method: ...", "[0].kind: ..."), joined to the key's name.
struct NestedError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

// An object of LED levels {"W57": 0.5, ...}, each in [0, 1].
drivers::DriveLevels read_levels(const nlohmann::json& value);
// One entry of devices: name, kind, backend, address, settings (unknown keys refused).
DeviceConfig read_device(const nlohmann::json& device);

}  // namespace chromo::daemon::config_values
