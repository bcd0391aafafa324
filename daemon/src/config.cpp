#include "chromo/daemon/config.hpp"

#include <fstream>
#include <set>
#include <stdexcept>

#include "chromo/session/session_plan.hpp"
#include "chromo/estimation/estimator.hpp"

namespace chromo::daemon {

std::string device_kind_name(DeviceKind kind) {
  switch (kind) {
    case DeviceKind::kLedController: return "led_controller";
    case DeviceKind::kCamera: return "camera";
    case DeviceKind::kSpectrometer: return "spectrometer";
  }
  return "unknown";
}

bool DaemonConfig::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (unix_socket.empty() && tcp_address.empty()) return fail("listen: neither unix_socket nor tcp_address is set");
  if (!tcp_address.empty() && token.size() < 16)
    return fail("token: TCP listening needs a bearer token of at least 16 characters");
  if (tls_certificate_file.empty() != tls_private_key_file.empty())
    return fail("tls: tls_certificate_file and tls_private_key_file go together");
  if (!tcp_address.empty() && tls_certificate_file.empty() && !tcp_insecure)
    return fail("tcp_insecure: TCP without TLS needs \"tcp_insecure\": true (or tls_certificate_file and tls_private_key_file)");
  if (tcp_insecure && !tls_certificate_file.empty())
    return fail("tcp_insecure: true contradicts tls_certificate_file (TLS is on)");
  if (max_streams < 1 || max_streams > 1024) return fail("max_streams: must be in [1, 1024]");
  if (storage_queue_frames < 1 || storage_queue_frames > 100000) return fail("storage_queue_frames: must be in [1, 100000]");
  if (estimator_queue_frames > 100000) return fail("estimator_queue_frames: must be at most 100000");
  if (frame_attempts < 1 || frame_attempts > 100) return fail("frame_attempts: must be in [1, 100]");
  std::set<std::string> names;
  for (std::size_t i = 0; i < devices.size(); ++i) {
    const auto field = "devices[" + std::to_string(i) + "].";
    if (!session::is_valid_name(devices[i].name)) return fail(field + "name: must match [A-Za-z0-9_+.-]{1,64}");
    if (!names.insert(devices[i].name).second) return fail(field + "name: \"" + devices[i].name + "\" is used twice");
    if (devices[i].backend.empty()) return fail(field + "backend: missing");
  }
  if (!chromo::estimation::parse_method_name(estimation.method))
    return fail("estimation.method: \"" + estimation.method + "\" is not fast, exhaustive or 2d");
  if (!chromo::estimation::parse_model_name(estimation.model))
    return fail("estimation.model: \"" + estimation.model + "\" is not auto, 2d or 4d");
  if (!(estimation.white_reflectance > 0 && estimation.white_reflectance <= 1))
    return fail("estimation.white_reflectance: must be in (0, 1]");
  if (estimation.threads < 0 || estimation.threads > 256) return fail("estimation.threads: must be in [0, 256]");
  for (const auto& [name, levels] : mixes) {
    if (!session::is_valid_mix(name)) return fail("mixes." + name + ": not a mix name (d65, w57, w57+blue[:R])");
    for (double level : levels)
      if (!(level >= 0 && level <= 1)) return fail("mixes." + name + ": levels must be in [0, 1]");
  }
  return true;
}

namespace {
drivers::DriveLevels parse_levels(const nlohmann::json& json, const std::string& field) {
  drivers::DriveLevels levels{};
  for (const auto& [key, value] : json.items()) {
    auto type = spectral::parse_led_type(key);
    if (!type) throw std::invalid_argument(field + "." + key + ": not an LED type (W57, W40, W27, R, G, B)");
    levels[static_cast<std::size_t>(spectral::led_type_index(*type))] = value.get<double>();
  }
  return levels;
}
}  // namespace

DaemonConfig parse_config(const nlohmann::json& json, const std::string& origin) {
  DaemonConfig config;
  static const std::set<std::string> known{"unix_socket", "unix_socket_mode", "tcp_address", "token",
                                           "tls_certificate_file", "tls_private_key_file", "tcp_insecure",
                                           "max_streams", "maps_dir", "sessions_dir",
                                           "storage_limit_bytes", "storage_queue_frames", "estimator_queue_frames",
                                           "frame_timeout_ms", "frame_attempts", "led_library", "devices", "mixes",
                                           "estimation"};
  if (!json.is_object()) throw std::invalid_argument(origin + ": must be a JSON object");
  std::string field;
  try {
    for (const auto& [key, value] : json.items())
      if (!known.count(key)) throw std::invalid_argument(origin + ": unknown key \"" + key + "\" (see docs/config.md)");
    auto get = [&](const char* key, auto& target) {
      field = key;
      if (json.contains(key)) target = json.at(key).get<std::remove_reference_t<decltype(target)>>();
    };
    get("unix_socket", config.unix_socket);
    if (json.contains("unix_socket_mode")) {
      field = "unix_socket_mode";
      config.unix_socket_mode = static_cast<std::uint32_t>(std::stoul(json.at("unix_socket_mode").get<std::string>(), nullptr, 8));
    }
    get("tcp_address", config.tcp_address);
    get("token", config.token);
    get("tls_certificate_file", config.tls_certificate_file);
    get("tls_private_key_file", config.tls_private_key_file);
    get("tcp_insecure", config.tcp_insecure);
    get("max_streams", config.max_streams);
    std::string maps_dir;
    get("maps_dir", maps_dir);
    config.maps_dir = maps_dir;
    std::string sessions_dir = config.sessions_dir.string();
    get("sessions_dir", sessions_dir);
    config.sessions_dir = sessions_dir;
    get("storage_limit_bytes", config.storage_limit_bytes);
    get("storage_queue_frames", config.storage_queue_frames);
    get("estimator_queue_frames", config.estimator_queue_frames);
    get("frame_timeout_ms", config.frame_timeout_ms);
    get("frame_attempts", config.frame_attempts);
    std::string led_library;
    get("led_library", led_library);
    config.led_library = led_library;
    if (json.contains("devices")) {
      std::size_t index = 0;
      for (const auto& device : json.at("devices")) {
        field = "devices[" + std::to_string(index++) + "]";
        DeviceConfig d;
        if (!device.is_object()) throw std::invalid_argument(origin + ": " + field + ": must be a JSON object");
        for (const auto& [key, value] : device.items())
          if (key != "name" && key != "kind" && key != "backend" && key != "address" && key != "settings")
            throw std::invalid_argument(origin + ": " + field + "." + key +
                                        ": unknown key (name, kind, backend, address, settings)");
        if (device.contains("settings") && !device.at("settings").is_object())
          throw std::invalid_argument(origin + ": " + field + ".settings: must be a JSON object");
        d.name = device.at("name").get<std::string>();
        std::string kind = device.at("kind").get<std::string>();
        if (kind == "led_controller") d.kind = DeviceKind::kLedController;
        else if (kind == "camera") d.kind = DeviceKind::kCamera;
        else if (kind == "spectrometer") d.kind = DeviceKind::kSpectrometer;
        else throw std::invalid_argument(origin + ": " + field + ".kind: \"" + kind +
                                         "\" is not led_controller, camera or spectrometer");
        d.backend = device.at("backend").get<std::string>();
        d.address = device.value("address", "");
        d.settings = device.value("settings", nlohmann::json::object());
        config.devices.push_back(std::move(d));
      }
    }
    if (json.contains("mixes"))
      for (const auto& [name, levels] : json.at("mixes").items()) {
        field = "mixes." + name;
        config.mixes[name] = parse_levels(levels, field);
      }
    if (json.contains("estimation")) {
      field = "estimation";
      const auto& e = json.at("estimation");
      if (!e.is_object()) throw std::invalid_argument(origin + ": estimation: must be an object");
      static const std::set<std::string> known_estimation{"enabled", "method", "model", "led_library",
                                                          "camera_sensitivity", "white_reflectance", "cache_dir",
                                                          "threads"};
      for (const auto& [key, value] : e.items())
        if (!known_estimation.count(key))
          throw std::invalid_argument(origin + ": estimation: unknown key \"" + key + "\" (see docs/config.md)");
      auto get_estimation = [&](const char* key, auto& target) {
        field = std::string("estimation.") + key;
        if (e.contains(key)) target = e.at(key).get<std::remove_reference_t<decltype(target)>>();
      };
      get_estimation("enabled", config.estimation.enabled);
      get_estimation("method", config.estimation.method);
      get_estimation("model", config.estimation.model);
      get_estimation("led_library", config.estimation.led_library);
      get_estimation("camera_sensitivity", config.estimation.camera_sensitivity);
      get_estimation("white_reflectance", config.estimation.white_reflectance);
      get_estimation("cache_dir", config.estimation.cache_dir);
      get_estimation("threads", config.estimation.threads);
    }
  } catch (const nlohmann::json::exception& error) {
    throw std::invalid_argument(origin + ": " + field + ": " + error.what());
  } catch (const std::logic_error& error) {
    if (dynamic_cast<const std::invalid_argument*>(&error) && std::string(error.what()).rfind(origin, 0) == 0) throw;
    throw std::invalid_argument(origin + ": " + field + ": " + error.what());
  }
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument(origin + ": " + error);
  return config;
}

DaemonConfig read_config_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path.string() + ": cannot be read");
  auto json = nlohmann::json::parse(in, nullptr, false);
  if (json.is_discarded()) throw std::invalid_argument(path.string() + ": not valid JSON");
  return parse_config(json, path.string());
}

std::map<std::string, drivers::DriveLevels> default_virtual_lab_mixes() {
  // Order: W57 W40 W27 R G B. Placeholders for sessions before a calibration
  // has solved the real mixes; replaced by the solver's weights when available.
  return {{"d65", {0.80, 0.0, 0.0, 0.05, 0.10, 0.25}},
          {"w57", {0.80, 0.0, 0.0, 0.0, 0.0, 0.0}},
          {"w57+blue", {0.80, 0.0, 0.0, 0.0, 0.0, 0.40}}};
}

}  // namespace chromo::daemon
