#pragma once
// The four chromophore parameters of the skin model and the constants that
// MODEL.md fixes. Volume fractions are dimensionless (0-1).

#include <array>
#include <optional>
#include <string>
#include <string_view>

namespace chromo::estimation {

struct SkinParameters {
  double cm = 0.05;   // melanin volume fraction in the epidermis
  double ch = 0.03;   // hemoglobin (blood) volume fraction in the dermis
  double bm = 0.7;    // eumelanin share of melanin (βm)
  double che = 0.0;   // hemoglobin volume fraction in the epidermis
};

struct ParameterRange {
  std::string_view name;  // as MODEL.md spells it
  double min;
  double max;
  bool contains(double v) const { return v >= min && v <= max; }
};

inline constexpr ParameterRange kCmRange{"Cm", 0.001, 0.5};
inline constexpr ParameterRange kChRange{"Ch", 0.001, 0.32};
inline constexpr ParameterRange kBmRange{"βm", 0.0, 1.0};
inline constexpr ParameterRange kCheRange{"Che", 0.0, 0.1};

// Fixed by MODEL.md.
inline constexpr double kBloodOxygenation = 0.75;      // γ
inline constexpr double kEpidermisThicknessMm = 0.25;  // d
inline constexpr double kSkinRefractiveIndex = 1.4;    // η at the skin-air surface
// The 2D model frees Cm and Ch only and holds these.
inline constexpr double kModel2dBm = 0.7;
inline constexpr double kModel2dChe = 0.0;

// nullopt when every parameter is inside its range (and finite); otherwise a
// message naming the first offending parameter, its value and its range.
std::optional<std::string> range_violation(const SkinParameters& p);

}  // namespace chromo::estimation
