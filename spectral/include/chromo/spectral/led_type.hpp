#pragma once
// The six LED types of the sphere. Shared vocabulary of calibration, drivers,
// simulators and the daemon; lives here because every one of them may depend
// on spectral/ (DESIGN.md).

#include <array>
#include <optional>
#include <string_view>

namespace chromo::spectral {

enum class LedType { kW57 = 0, kW40 = 1, kW27 = 2, kRed = 3, kGreen = 4, kBlue = 5 };
inline constexpr int kLedTypeCount = 6;
inline constexpr std::array<LedType, kLedTypeCount> kAllLedTypes{LedType::kW57, LedType::kW40, LedType::kW27,
                                                                 LedType::kRed, LedType::kGreen, LedType::kBlue};

// "W57", "W40", "W27", "R", "G", "B": the names used in files, JSON and the CLI.
constexpr std::string_view led_type_name(LedType type) {
  constexpr std::array<std::string_view, kLedTypeCount> kNames{"W57", "W40", "W27", "R", "G", "B"};
  return kNames[static_cast<int>(type)];
}

constexpr int led_type_index(LedType type) { return static_cast<int>(type); }

// Inverse of led_type_name (exact, case-sensitive); nullopt for anything else.
constexpr std::optional<LedType> parse_led_type(std::string_view name) {
  for (LedType type : kAllLedTypes)
    if (led_type_name(type) == name) return type;
  return std::nullopt;
}

}  // namespace chromo::spectral
