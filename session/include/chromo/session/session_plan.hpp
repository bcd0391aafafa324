#pragma once
// SessionPlan: a named sequence of steps, each an LED state held while every
// camera takes its frames. The daemon's own form of the API's SessionPlan
// (sessions.proto); stored as JSON in the session folder (plan.json).
//
// The standard session of the method (standard_plan()): dark; then the white
// reference and the subject, each under D65', W57 alone and W57+blue. The
// blue-only response is (W57+blue) − W57, computed later from the stored frames.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/drivers/led_controller.hpp"

namespace chromo::session {

enum class Timing { kSoftware, kHardware };
enum class StepRole { kDark, kWhite, kSubject };

struct Illumination {
  enum class Kind { kDark, kWeights, kMix } kind = Kind::kDark;
  drivers::DriveLevels weights{};  // kWeights
  std::string mix;                 // kMix: "d65", "w57", "w57+blue[:R]"
};

struct Step {
  std::string name;
  StepRole role = StepRole::kSubject;
  Illumination illumination;
  std::uint32_t settle_ms = 0;
  double exposure_us = 20000;
  std::uint32_t frames_per_camera = 1;
  std::string prompt;  // non-empty: pause before the step until resumed
};

struct SessionPlan {
  std::string name;
  Timing timing = Timing::kSoftware;
  std::vector<Step> steps;

  // Names the first offending field, e.g. "steps[2].exposure_us: must be in (0, 10000000]".
  bool IsValid(std::string* error) const;
  std::uint64_t frames_per_camera_total() const;
};

struct StandardPlanOptions {
  Timing timing = Timing::kSoftware;
  double exposure_us = 20000;
  std::uint32_t frames_per_camera = 1;
  std::uint32_t settle_ms = 50;
  bool operator_prompts = false;  // pause for "place the white target" / "place the subject"
};
SessionPlan standard_plan(const StandardPlanOptions& options = {});

// Bounds shared with the API's validation.
inline constexpr std::size_t kMaxNameBytes = 64;
inline constexpr std::size_t kMaxTextBytes = 4096;
inline constexpr std::size_t kMaxSteps = 256;
inline constexpr std::uint32_t kMaxFramesPerCamera = 1000;
inline constexpr std::uint32_t kMaxSettleMs = 60000;
inline constexpr double kMaxExposureUs = 10e6;
// [A-Za-z0-9_+.-]{1,64}
bool is_valid_name(const std::string& name);
// "d65", "w57", "w57+blue" or "w57+blue:R" with R in (0, 100].
bool is_valid_mix(const std::string& mix);

nlohmann::json to_json(const SessionPlan& plan);
// Throws std::invalid_argument naming the field.
SessionPlan plan_from_json(const nlohmann::json& json);
std::string role_name(StepRole role);
std::string timing_name(Timing timing);

}  // namespace chromo::session
