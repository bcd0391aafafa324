#include "chromo/session/session_provenance.hpp"

#include <cmath>
#include <ctime>
#include <iomanip>
#include <sstream>

#include "chromo/session/session_plan.hpp"

namespace chromo::session {

double seconds_since(const std::string& utc, std::chrono::system_clock::time_point now) {
  std::tm tm{};
  std::istringstream in(utc);
  in >> std::get_time(&tm, "%Y-%m-%dT%H:%M:%S");
  if (utc.empty() || in.fail()) return -1;
  const auto then = std::chrono::system_clock::from_time_t(timegm(&tm));
  return std::chrono::duration<double>(now - then).count();
}

nlohmann::json to_json(const SessionProvenance& p) {
  nlohmann::json mixes = nlohmann::json::object();
  for (const auto& [name, mix] : p.mixes) mixes[name] = {{"weights", drive_levels_to_json(mix.drive)}, {"origin", mix.origin}};
  return {{"led_library",
           {{"kind", p.led_library.kind},
            {"file", p.led_library.file},
            {"created_utc", p.led_library.created_utc},
            {"age_at_start_s", p.led_library.age_at_start_s}}},
          {"mixes", mixes},
          {"camera_sensitivity", p.camera_sensitivity},
          {"camera_sensitivity_of", p.camera_sensitivity_of},
          {"camera_field_width_mm", p.camera_field_width_mm},
          {"white_reflectance", p.white_reflectance},
          {"plan", p.plan},
          {"operator", p.operator_name},
          {"study", p.study},
          {"estimator", {{"version", p.estimator_version}, {"options", p.estimator_options}}}};
}

SessionProvenance provenance_from_json(const nlohmann::json& json) {
  SessionProvenance p;
  if (!json.is_object()) throw std::invalid_argument("provenance: not an object");
  std::string key = "provenance";
  try {
    p.recorded = true;
    const nlohmann::json empty = nlohmann::json::object();
    const auto& library = json.contains("led_library") ? json.at("led_library") : empty;
    key = "provenance.led_library";
    p.led_library.kind = library.value("kind", "");
    p.led_library.file = library.value("file", "");
    p.led_library.created_utc = library.value("created_utc", "");
    p.led_library.age_at_start_s = library.value("age_at_start_s", -1.0);
    key = "provenance.mixes";
    const nlohmann::json mixes = json.value("mixes", empty);
    for (const auto& [name, mix] : mixes.items())
      p.mixes[name] = {drive_levels_from_json(mix.at("weights")), mix.value("origin", "")};
    key = "provenance.camera_sensitivity";
    p.camera_sensitivity = json.value("camera_sensitivity", "");
    p.camera_sensitivity_of = json.value("camera_sensitivity_of", std::map<std::string, std::string>{});
    key = "provenance.camera_field_width_mm";
    p.camera_field_width_mm = json.value("camera_field_width_mm", std::map<std::string, double>{});
    for (const auto& [camera, width_mm] : p.camera_field_width_mm)
      if (!(width_mm > 0) || !std::isfinite(width_mm))
        throw std::invalid_argument(key + "." + camera + ": " + std::to_string(width_mm) + " is not a width > 0 mm");
    key = "provenance.white_reflectance";
    p.white_reflectance = json.value("white_reflectance", 0.0);
    key = "provenance.plan";
    p.plan = json.value("plan", "");
    p.operator_name = json.value("operator", "");
    p.study = json.value("study", "");
    key = "provenance.estimator";
    const nlohmann::json estimator = json.value("estimator", empty);
    p.estimator_version = estimator.value("version", "");
    p.estimator_options = estimator.value("options", std::map<std::string, std::string>{});
  } catch (const nlohmann::json::exception& error) {
    throw std::invalid_argument(key + ": " + error.what());
  }
  return p;
}

}  // namespace chromo::session
