#include "chromo/planning/plan_description.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>

#include "chromo/calibration/session_mix.hpp"

namespace chromo::planning {

namespace {

constexpr const char* kCameraChannelNames[3] = {"R", "G", "B"};

bool valid_capture_name(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '+' || c == '.' || c == '\'' || c == '-'))
      return false;
  return true;
}

// The broadband capture of a study plan ("w57", "w40+blue", "d65+blue", ...):
// D65' and W57 as the session mixes solve them, W40 and W27 alone at full
// drive; nullopt for any other name.
std::optional<PlannedCapture> broadband_of_study_plan(const std::string& name, const calibration::LedLibrary& library) {
  const std::string base = name.ends_with("+blue") ? name.substr(0, name.size() - 5) : name;
  if (base == "d65") {
    const auto weights = calibration::solve_session_mix(library, "d65", "camera", false).weights;
    PlannedCapture c{"D65'", {}};
    for (int t = 0; t < spectral::kLedTypeCount; ++t) c.drive[t] = weights[t];
    return c;
  }
  if (base == "w57") {
    const auto weights = calibration::solve_session_mix(library, "w57", "camera", false).weights;
    PlannedCapture c{"W57", {}};
    for (int t = 0; t < spectral::kLedTypeCount; ++t) c.drive[t] = weights[t];
    return c;
  }
  for (const spectral::LedType type : {spectral::LedType::kW40, spectral::LedType::kW27})
    if (base == (type == spectral::LedType::kW40 ? "w40" : "w27")) {
      PlannedCapture c{std::string(spectral::led_type_name(type)), {}};
      c.drive[spectral::led_type_index(type)] = 1.0;
      return c;
    }
  return std::nullopt;
}

}  // namespace

std::string PlannedChannel::name() const {
  const std::string channel = camera_channel >= 0 && camera_channel < 3 ? kCameraChannelNames[camera_channel] : "?";
  return (minus.empty() ? capture : capture + "-" + minus) + "." + channel;
}

int PlanDescription::capture_index(const std::string& name) const {
  for (std::size_t k = 0; k < captures.size(); ++k)
    if (captures[k].name == name) return static_cast<int>(k);
  return -1;
}

std::vector<PlannedChannel> PlanDescription::effective_channels() const {
  if (!channels.empty()) return channels;
  std::vector<PlannedChannel> all;
  for (const PlannedCapture& capture : captures)
    for (int c = 0; c < 3; ++c) all.push_back({capture.name, c, ""});
  return all;
}

bool PlanDescription::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (name.empty() || name.size() > 64) return fail("name: must be 1-64 characters");
  if (captures.empty() || captures.size() > kMaxPlannedCaptures)
    return fail("captures: must hold 1-" + std::to_string(kMaxPlannedCaptures) + " captures");
  std::set<std::string> names;
  for (std::size_t k = 0; k < captures.size(); ++k) {
    const PlannedCapture& c = captures[k];
    const std::string at = "captures[" + std::to_string(k) + "].";
    if (!valid_capture_name(c.name)) return fail(at + "name: must be 1-64 of [A-Za-z0-9_+.'-]");
    if (!names.insert(c.name).second) return fail(at + "name: '" + c.name + "' is used twice");
    double total = 0;
    for (int t = 0; t < spectral::kLedTypeCount; ++t) {
      if (!(c.drive[t] >= 0 && c.drive[t] <= 1))
        return fail(at + "drive." + std::string(spectral::led_type_name(spectral::kAllLedTypes[t])) + ": must be in [0, 1]");
      total += c.drive[t];
    }
    if (total <= 0) return fail(at + "drive: at least one LED type must be on");
    if (!(c.white_fill > 0 && c.white_fill <= 1)) return fail(at + "white_fill: must be in (0, 1]");
    if (c.frames < 1 || c.frames > kMaxPlannedFrames) return fail(at + "frames: must be 1-1000");
    if (c.white_frames < 1 || c.white_frames > kMaxPlannedFrames) return fail(at + "white_frames: must be 1-1000");
    if (c.settle_ms < 0 || c.settle_ms > 60000) return fail(at + "settle_ms: must be 0-60000");
  }
  if (dark_frames < 1 || dark_frames > kMaxPlannedFrames) return fail("dark_frames: must be 1-1000");
  if (channels.size() > kMaxPlannedChannels)
    return fail("channels: at most " + std::to_string(kMaxPlannedChannels) + " channels");
  if (channels.empty() && captures.size() * 3 > kMaxPlannedChannels)
    return fail("channels: every capture's R, G, B would be more than " + std::to_string(kMaxPlannedChannels));
  std::set<std::string> channel_names;
  for (std::size_t i = 0; i < channels.size(); ++i) {
    const PlannedChannel& ch = channels[i];
    const std::string at = "channels[" + std::to_string(i) + "].";
    if (capture_index(ch.capture) < 0) return fail(at + "capture: no capture named '" + ch.capture + "'");
    if (ch.camera_channel < 0 || ch.camera_channel > 2) return fail(at + "camera_channel: must be R, G or B (0-2)");
    if (!ch.minus.empty()) {
      if (capture_index(ch.minus) < 0) return fail(at + "minus: no capture named '" + ch.minus + "'");
      if (ch.minus == ch.capture) return fail(at + "minus: a capture minus itself is no channel");
    }
    if (!channel_names.insert(ch.name()).second) return fail(at + "'" + ch.name() + "' is listed twice");
  }
  return true;
}

namespace {
const std::map<std::string, std::string> kOldPlanNames = {{"method", "standard"}, {"method-blue", "standard-blue"}};
}  // namespace

std::vector<std::string> builtin_plan_names() {
  return {"standard", "standard-blue", "multispectral", "d65",      "w57",      "w40",
          "w27",      "d65+blue",      "w57+blue",      "w40+blue", "w27+blue"};
}

PlanDescription builtin_plan(const std::string& full_name, const calibration::LedLibrary& library) {
  std::string name = full_name;
  int frames = 1;
  if (const auto at = full_name.find('@'); at != std::string::npos) {
    name = full_name.substr(0, at);
    const std::string count = full_name.substr(at + 1);
    std::size_t used = 0;
    try {
      frames = std::stoi(count, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != count.size() || count.empty() || frames < 1 || frames > kMaxPlannedFrames)
      throw std::invalid_argument("plan '" + full_name + "': the frames after '@' must be 1-1000");
  }
  auto mix = [&](const char* target) {
    const auto weights = calibration::solve_session_mix(library, target, "camera", false).weights;
    std::array<double, spectral::kLedTypeCount> drive{};
    for (int t = 0; t < spectral::kLedTypeCount; ++t) drive[t] = weights[t];
    return drive;
  };
  auto alone = [](spectral::LedType type) {
    std::array<double, spectral::kLedTypeCount> drive{};
    drive[spectral::led_type_index(type)] = 1.0;
    return drive;
  };
  // The names `chromo plan compare` used before the standard plan had one
  // name everywhere (issue 36), still read: a study's or a script's.
  if (const auto old = kOldPlanNames.find(name); old != kOldPlanNames.end()) name = old->second;
  PlanDescription plan;
  plan.name = name + full_name.substr(std::min(full_name.find('@'), full_name.size()));  // the "@N" as given
  if (name == "standard") {
    plan.captures = {{"D65'", mix("d65")}, {"W57", mix("w57")}, {"W57+blue", mix("w57+blue")}};
    plan.channels = {{"D65'", 0, ""}, {"D65'", 1, ""}, {"D65'", 2, ""}, {"W57+blue", 2, "W57"}};
  } else if (name == "standard-blue") {
    plan.captures = {{"D65'", mix("d65")}, {"blue", alone(spectral::LedType::kBlue)}};
    plan.channels = {{"D65'", 0, ""}, {"D65'", 1, ""}, {"D65'", 2, ""}, {"blue", 2, ""}};
  } else if (name == "multispectral") {
    for (spectral::LedType type : spectral::kAllLedTypes)
      plan.captures.push_back({std::string(spectral::led_type_name(type)), alone(type)});
  } else if (name == "d65") {
    plan.captures = {{"D65'", mix("d65")}};
  } else if (const auto broadband = broadband_of_study_plan(name, library); broadband) {
    // The seed's broadband study: a broadband alone (R, G, B), or with the
    // blue capture (broadband + blue, channels R, G, B and (broadband+blue − broadband).B).
    plan.captures = {{broadband->name, broadband->drive}};
    if (name.ends_with("+blue")) {
      PlannedCapture with_blue{broadband->name + "+blue", broadband->drive};
      double& blue = with_blue.drive[spectral::led_type_index(spectral::LedType::kBlue)];
      blue = std::min(1.0, blue + mix("w57+blue")[spectral::led_type_index(spectral::LedType::kBlue)]);
      plan.captures.push_back(with_blue);
      plan.channels = {{broadband->name, 0, ""}, {broadband->name, 1, ""}, {broadband->name, 2, ""},
                       {with_blue.name, 2, broadband->name}};
    }
  } else {
    std::string known;
    for (const std::string& n : builtin_plan_names()) known += (known.empty() ? "" : ", ") + n;
    throw std::invalid_argument("plan '" + full_name + "': not a built-in plan (" + known + ", each optionally @N frames)");
  }
  for (PlannedCapture& c : plan.captures) c.frames = frames, c.white_frames = frames;
  return plan;
}

namespace {

template <typename T>
T number(const nlohmann::json& json, const char* key, const std::string& at, T fallback) {
  if (!json.contains(key)) return fallback;
  const nlohmann::json& v = json.at(key);
  if (!v.is_number()) throw std::invalid_argument(at + key + ": must be a number");
  const double d = v.get<double>();
  if (!std::isfinite(d)) throw std::invalid_argument(at + key + ": must be finite");
  if constexpr (std::is_integral_v<T>) {
    if (d != std::floor(d) || std::abs(d) > 1e9) throw std::invalid_argument(at + key + ": must be a whole number");
    return static_cast<T>(d);
  } else {
    return d;
  }
}

std::string text(const nlohmann::json& json, const char* key, const std::string& at, bool required) {
  if (!json.contains(key)) {
    if (required) throw std::invalid_argument(at + key + ": required");
    return {};
  }
  if (!json.at(key).is_string()) throw std::invalid_argument(at + key + ": must be a string");
  return json.at(key).get<std::string>();
}

}  // namespace

PlanDescription plan_from_json(const nlohmann::json& json) {
  if (!json.is_object()) throw std::invalid_argument("plan: must be a JSON object");
  PlanDescription plan;
  plan.name = text(json, "name", "", true);
  plan.dark_frames = number<int>(json, "dark_frames", "", 1);
  if (!json.contains("captures") || !json.at("captures").is_array())
    throw std::invalid_argument("captures: required, an array");
  const auto& captures = json.at("captures");
  if (captures.size() > kMaxPlannedCaptures)
    throw std::invalid_argument("captures: at most " + std::to_string(kMaxPlannedCaptures));
  for (std::size_t k = 0; k < captures.size(); ++k) {
    const auto& c = captures[k];
    const std::string at = "captures[" + std::to_string(k) + "].";
    if (!c.is_object()) throw std::invalid_argument(at.substr(0, at.size() - 1) + ": must be an object");
    PlannedCapture capture;
    capture.name = text(c, "name", at, true);
    if (!c.contains("drive") || !c.at("drive").is_object())
      throw std::invalid_argument(at + "drive: required, an object of LED type → drive level");
    for (const auto& [led, level] : c.at("drive").items()) {
      const auto type = spectral::parse_led_type(led);
      if (!type) throw std::invalid_argument(at + "drive." + led + ": not an LED type (W57, W40, W27, R, G, B)");
      if (!level.is_number() || !std::isfinite(level.get<double>()))
        throw std::invalid_argument(at + "drive." + led + ": must be a number");
      capture.drive[spectral::led_type_index(*type)] = level.get<double>();
    }
    capture.white_fill = number<double>(c, "white_fill", at, capture.white_fill);
    capture.frames = number<int>(c, "frames", at, capture.frames);
    capture.white_frames = number<int>(c, "white_frames", at, capture.frames);
    capture.settle_ms = number<int>(c, "settle_ms", at, capture.settle_ms);
    plan.captures.push_back(std::move(capture));
  }
  if (json.contains("channels")) {
    const auto& channels = json.at("channels");
    if (!channels.is_array()) throw std::invalid_argument("channels: must be an array");
    if (channels.size() > kMaxPlannedChannels)
      throw std::invalid_argument("channels: at most " + std::to_string(kMaxPlannedChannels));
    for (std::size_t i = 0; i < channels.size(); ++i) {
      const auto& c = channels[i];
      const std::string at = "channels[" + std::to_string(i) + "].";
      if (!c.is_object()) throw std::invalid_argument(at.substr(0, at.size() - 1) + ": must be an object");
      PlannedChannel channel;
      channel.capture = text(c, "capture", at, true);
      const std::string camera = text(c, "camera_channel", at, true);
      if (camera == "R") channel.camera_channel = 0;
      else if (camera == "G") channel.camera_channel = 1;
      else if (camera == "B") channel.camera_channel = 2;
      else throw std::invalid_argument(at + "camera_channel: must be \"R\", \"G\" or \"B\"");
      channel.minus = text(c, "minus", at, false);
      plan.channels.push_back(std::move(channel));
    }
  }
  if (std::string error; !plan.IsValid(&error)) throw std::invalid_argument(error);
  return plan;
}

nlohmann::json to_json(const PlanDescription& plan) {
  nlohmann::json json{{"name", plan.name}, {"dark_frames", plan.dark_frames}};
  json["captures"] = nlohmann::json::array();
  for (const PlannedCapture& c : plan.captures) {
    nlohmann::json drive = nlohmann::json::object();
    for (int t = 0; t < spectral::kLedTypeCount; ++t)
      if (c.drive[t] != 0) drive[std::string(spectral::led_type_name(spectral::kAllLedTypes[t]))] = c.drive[t];
    json["captures"].push_back({{"name", c.name}, {"drive", drive}, {"white_fill", c.white_fill}, {"frames", c.frames},
                                {"white_frames", c.white_frames}, {"settle_ms", c.settle_ms}});
  }
  if (!plan.channels.empty()) {
    json["channels"] = nlohmann::json::array();
    for (const PlannedChannel& c : plan.channels) {
      nlohmann::json channel{{"capture", c.capture}, {"camera_channel", kCameraChannelNames[c.camera_channel]}};
      if (!c.minus.empty()) channel["minus"] = c.minus;
      json["channels"].push_back(channel);
    }
  }
  return json;
}

}  // namespace chromo::planning
