#include "chromo/session/frame_record.hpp"

#include <stdexcept>

namespace chromo::session {

namespace {

nlohmann::json levels_json(const drivers::DriveLevels& levels) {
  nlohmann::json json = nlohmann::json::object();
  for (auto type : spectral::kAllLedTypes)
    json[std::string(spectral::led_type_name(type))] = levels[static_cast<std::size_t>(spectral::led_type_index(type))];
  return json;
}

[[noreturn]] void bad(const std::string& field, const std::string& what) {
  throw std::invalid_argument("frame record: " + field + ": " + what);
}

const nlohmann::json& required(const nlohmann::json& json, const char* field) {
  const auto it = json.find(field);
  if (it == json.end()) bad(field, "missing");
  return *it;
}

template <typename T>
T number(const nlohmann::json& value, const std::string& field) {
  if (!value.is_number()) bad(field, "not a number");
  if constexpr (std::is_unsigned_v<T>) {
    if (!value.is_number_unsigned() && !(value.is_number_integer() && value.get<std::int64_t>() >= 0))
      bad(field, "not a non-negative integer");
  } else if constexpr (std::is_integral_v<T>) {
    if (!value.is_number_integer()) bad(field, "not an integer");
  }
  return value.get<T>();
}

template <typename T>
T number_or(const nlohmann::json& json, const char* field, T fallback, const std::string& prefix = "") {
  const auto it = json.find(field);
  return it == json.end() ? fallback : number<T>(*it, prefix + field);
}

std::string text(const nlohmann::json& value, const std::string& field) {
  if (!value.is_string()) bad(field, "not a string");
  return value.get<std::string>();
}

// An object keyed by LED type name: read(value, "field.NAME") for each key into
// its type's slot; types absent keep their default.
template <typename T, typename Read>
std::array<T, drivers::kLedTypeCount> per_led_type(const nlohmann::json& json, const std::string& field,
                                                   const char* what, Read read) {
  if (!json.is_object()) bad(field, std::string("not an object of ") + what);
  std::array<T, drivers::kLedTypeCount> values{};
  for (const auto& [name, value] : json.items()) {
    const auto type = spectral::parse_led_type(name);
    if (!type) bad(field + "." + name, "not an LED type (W57, W40, W27, R, G, B)");
    values[static_cast<std::size_t>(spectral::led_type_index(*type))] = read(value, field + "." + name);
  }
  return values;
}

// Levels by LED type name; types absent are 0 (as the controller drives them).
drivers::DriveLevels levels_from_json(const nlohmann::json& json, const std::string& field) {
  return per_led_type<double>(json, field, "LED levels",
                              [](const nlohmann::json& level, const std::string& name) { return number<double>(level, name); });
}

template <typename T>
std::array<T, drivers::kLedTypeCount> per_channel(const nlohmann::json& json, const char* field) {
  std::array<T, drivers::kLedTypeCount> values{};
  const auto it = json.find(field);
  if (it == json.end()) return values;
  const std::string name = std::string("led.") + field;
  if (!it->is_array() || it->size() != values.size())
    bad(name, "not an array of " + std::to_string(values.size()) + " numbers");
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = number<T>((*it)[i], name + "[" + std::to_string(i) + "]");
  return values;
}

// {"W57": "cross", ...}: the LED types not unpolarised.
nlohmann::json polarisation_json(const drivers::PolarisationPerType& polarisation) {
  nlohmann::json json = nlohmann::json::object();
  for (auto type : spectral::kAllLedTypes) {
    const drivers::Polarisation p = polarisation[static_cast<std::size_t>(spectral::led_type_index(type))];
    if (p != drivers::Polarisation::kUnpolarised) json[std::string(spectral::led_type_name(type))] = drivers::polarisation_name(p);
  }
  return json;
}

// Polarisations by LED type name; types absent are unpolarised.
drivers::PolarisationPerType polarisation_from_json(const nlohmann::json& json, const std::string& field) {
  return per_led_type<drivers::Polarisation>(
      json, field, "LED types and polarisations", [](const nlohmann::json& value, const std::string& name) {
        const std::string state = text(value, name);
        for (drivers::Polarisation p : {drivers::Polarisation::kUnpolarised, drivers::Polarisation::kCross,
                                        drivers::Polarisation::kParallel})
          if (state == drivers::polarisation_name(p)) return p;
        bad(name, "\"" + state.substr(0, 32) + "\" is not unpolarised, cross or parallel");
      });
}

StepRole parse_role(const std::string& name) {
  if (name == "dark") return StepRole::kDark;
  if (name == "white") return StepRole::kWhite;
  if (name == "subject") return StepRole::kSubject;
  bad("role", "\"" + name.substr(0, 32) + "\" is not dark, white or subject");
}

}  // namespace

nlohmann::json to_json(const FrameLedState& led) {
  nlohmann::json json{{"drive", levels_json(led.drive)},
                      {"requested_drive", levels_json(led.requested_drive)},
                      {"temperature_C", led.temperature_C},
                      {"channel_faults", led.channel_faults},
                      {"controller_faults", led.controller_faults},
                      {"sequence_position", led.sequence_position}};
  if (led.polarisation != drivers::PolarisationPerType{}) json["polarisation"] = polarisation_json(led.polarisation);
  if (led.temperatures_at_trigger) json["temperatures_at"] = "trigger";
  return json;
}

nlohmann::json to_json(const FrameRecord& r) {
  nlohmann::json json{{"type", "frame"},
                      {"index", r.index},
                      {"file", r.file},
                      {"step", r.step},
                      {"step_index", r.step_index},
                      {"role", role_name(r.role)},
                      {"frame_in_step", r.frame_in_step},
                      {"exposure_us", r.exposure_us},
                      {"camera", r.camera},
                      {"sequence", r.sequence},
                      {"camera_frame_id", r.camera_frame_id},
                      {"camera_timestamp_ns", r.camera_timestamp_ns},
                      {"host_timestamp_ns", r.host_timestamp_ns},
                      {"width", r.width},
                      {"height", r.height},
                      {"pixel_format", std::string(drivers::pixel_format_name(r.pixel_format))}};
  // Absent (0) in records of frames taken before triggers were numbered.
  if (r.trigger_id != 0) json["trigger_id"] = r.trigger_id;
  if (r.camera_trigger_count != 0) json["camera_trigger_count"] = r.camera_trigger_count;
  if (r.led) json["led"] = to_json(*r.led);
  return json;
}

FrameRecord frame_record_from_json(const nlohmann::json& json) {
  if (!json.is_object()) bad("(record)", "not a JSON object");
  FrameRecord r;
  r.index = number<std::uint64_t>(required(json, "index"), "index");
  r.file = text(required(json, "file"), "file");
  r.step = text(required(json, "step"), "step");
  r.camera = text(required(json, "camera"), "camera");
  r.width = number<int>(required(json, "width"), "width");
  r.height = number<int>(required(json, "height"), "height");
  const std::string format = text(required(json, "pixel_format"), "pixel_format");
  const auto pixel_format = drivers::parse_pixel_format(format);
  if (!pixel_format) {
    std::string what = "\"";
    what.append(format, 0, 32).append("\" unknown (").append(drivers::pixel_format_names()).append(")");
    bad("pixel_format", what);
  }
  r.pixel_format = *pixel_format;
  r.step_index = number_or<int>(json, "step_index", -1);  // -1: no step (counted nowhere)
  if (const auto role = json.find("role"); role != json.end()) r.role = parse_role(text(*role, "role"));
  r.frame_in_step = number_or<std::uint32_t>(json, "frame_in_step", 0);
  r.exposure_us = number_or<double>(json, "exposure_us", 0.0);
  r.sequence = number_or<std::uint64_t>(json, "sequence", 0);
  r.camera_frame_id = number_or<std::uint64_t>(json, "camera_frame_id", 0);
  r.camera_timestamp_ns = number_or<std::uint64_t>(json, "camera_timestamp_ns", 0);
  r.trigger_id = number_or<std::uint64_t>(json, "trigger_id", 0);
  r.camera_trigger_count = number_or<std::uint64_t>(json, "camera_trigger_count", 0);
  r.host_timestamp_ns = number_or<std::int64_t>(json, "host_timestamp_ns", 0);
  if (const auto led = json.find("led"); led != json.end() && led->is_object() && led->contains("drive")) {
    FrameLedState state;
    state.drive = levels_from_json(led->at("drive"), "led.drive");
    if (led->contains("requested_drive")) state.requested_drive = levels_from_json(led->at("requested_drive"), "led.requested_drive");
    state.temperature_C = per_channel<double>(*led, "temperature_C");
    if (const auto at = led->find("temperatures_at"); at != led->end()) {
      if (!at->is_string() || *at != "trigger") bad("led.temperatures_at", "expected \"trigger\"");
      state.temperatures_at_trigger = true;
    }
    state.channel_faults = per_channel<std::uint32_t>(*led, "channel_faults");
    state.controller_faults = number_or<std::uint32_t>(*led, "controller_faults", 0, "led.");
    state.sequence_position = number_or<int>(*led, "sequence_position", -1, "led.");
    if (const auto p = led->find("polarisation"); p != led->end())
      state.polarisation = polarisation_from_json(*p, "led.polarisation");
    r.led = state;
  }
  return r;
}

}  // namespace chromo::session
