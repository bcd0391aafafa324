// DaemonConfig: the checks between keys (IsValid), the table of keys and
// parse_config (config.hpp). Each key's value reader is config_values.cpp's,
// each check of a final value (files, folders, addresses) config_checks.cpp's.
#include "chromo/daemon/config.hpp"

#include <functional>
#include <limits>
#include <set>
#include <stdexcept>

#include "chromo/daemon/internal/devices/virtual_lab.hpp"
#include "chromo/estimation/estimator.hpp"
#include "chromo/files/bounded_read.hpp"
#include "chromo/session/session_plan.hpp"
#include "config_checks.hpp"
#include "config_values.hpp"

namespace chromo::daemon {

namespace fs = std::filesystem;
using nlohmann::json;

std::string device_kind_name(DeviceKind kind) {
  switch (kind) {
    case DeviceKind::kLedController: return "led_controller";
    case DeviceKind::kCamera: return "camera";
    case DeviceKind::kSpectrometer: return "spectrometer";
  }
  return "unknown";
}

bool is_loopback_address(const std::string& host_port) {
  const auto colon = host_port.rfind(':');
  std::string host = colon == std::string::npos ? host_port : host_port.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

bool is_valid_host_name(const std::string& name) {
  if (name.empty() || name.size() > 253) return false;
  if (name.front() == '[')  // an IPv6 address, as a Host header writes it
    return name.size() > 2 && name.back() == ']' &&
           name.find_first_not_of("0123456789abcdefABCDEF:.", 1) == name.size() - 1;
  return name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-.") == std::string::npos &&
         name.front() != '.' && name.front() != '-';
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
  if (!web_address.empty() && token.size() < 16)
    return fail("token: the web view (web_address) needs a token of at least 16 characters to log in with");
  if (!web_address.empty() && tls_certificate_file.empty() && !is_loopback_address(web_address))
    return fail("web_address: \"" + web_address +
                "\" is not a loopback address: the web view needs TLS there (tls_certificate_file and tls_private_key_file)");
  if (max_streams < 1 || max_streams > 1024) return fail("max_streams: must be in [1, 1024]");
  if (max_profile_exports < 1 || max_profile_exports > 16) return fail("max_profile_exports: must be in [1, 16]");
  if (tcp_handshake_timeout_ms < 100 || tcp_handshake_timeout_ms > 120000)
    return fail("tcp_handshake_timeout_ms: must be in [100, 120000]");
  if (tcp_idle_timeout_ms < 100 || tcp_idle_timeout_ms > 3600000)
    return fail("tcp_idle_timeout_ms: must be in [100, 3600000]");
  if (max_tcp_connections < 1 || max_tcp_connections > 4096) return fail("max_tcp_connections: must be in [1, 4096]");
  if (web_max_body_bytes < 1024 || web_max_body_bytes > (64u << 20))
    return fail("web_max_body_bytes: must be in [1024, 67108864]");
  if (web_stream_keepalive_ms < 100 || web_stream_keepalive_ms > 600000)
    return fail("web_stream_keepalive_ms: must be in [100, 600000]");
  if (web_request_head_timeout_ms < 500 || web_request_head_timeout_ms > 120000)
    return fail("web_request_head_timeout_ms: must be in [500, 120000]");
  if (web_max_streams < 1 || web_max_streams > kMaxWebStreams)
    return fail("web_max_streams: must be in [1, " + std::to_string(kMaxWebStreams) + "]");
  for (std::size_t i = 0; i < web_host_names.size(); ++i)
    if (!is_valid_host_name(web_host_names[i]))
      return fail("web_host_names[" + std::to_string(i) + "]: \"" + web_host_names[i].substr(0, 64) +
                  "\" is not a host name or numeric address without a port (letters, digits, '-', '.', at most 253; IPv6 in [])");
  if (storage_queue_frames < 1 || storage_queue_frames > 100000) return fail("storage_queue_frames: must be in [1, 100000]");
  if (estimator_queue_frames > 100000) return fail("estimator_queue_frames: must be at most 100000");
  if (frame_timeout_ms < 1 || frame_timeout_ms > 600000) return fail("frame_timeout_ms: must be in [1, 600000]");
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
  if (estimation.discrepancy != "learned" && estimation.discrepancy != "none")
    return fail("estimation.discrepancy: \"" + estimation.discrepancy + "\" is not learned or none");
  if (estimation.skin_denoise != "on" && estimation.skin_denoise != "off")
    return fail("estimation.skin_denoise: \"" + estimation.skin_denoise + "\" is not on or off");
  if (estimation.registration_tiles != "on" && estimation.registration_tiles != "off")
    return fail("estimation.registration_tiles: \"" + estimation.registration_tiles + "\" is not on or off");
  if (estimation.local_bias != "on" && estimation.local_bias != "off")
    return fail("estimation.local_bias: \"" + estimation.local_bias + "\" is not on or off");
  if (estimation.discrepancy_layer != "on" && estimation.discrepancy_layer != "off")
    return fail("estimation.discrepancy_layer: \"" + estimation.discrepancy_layer + "\" is not on or off");
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

using config_values::shown;
using config_values::read_unsigned;
using config_values::read_signed;
using config_values::read_number;
using config_values::read_string;
using config_values::NestedError;
using config_values::read_levels;
using config_values::read_device;
using config_checks::regular_file_error;
using config_checks::folder_error_tried;
using config_checks::unix_socket_error;
using config_checks::tcp_address_error;
using config_checks::pem_file_error;
using config_checks::led_library_error;
using config_checks::camera_sensitivity_error;
using config_checks::films_error;
using config_checks::optional_folder;
using config_checks::optional_existing_folder;

// ---- the table of keys ----

// One key: how its JSON value is read (type and range: the reader throws),
// and what is checked of its final value, present in the file or not
// (returns "" or what is wrong). Built only by the factories below, each of
// which demands the key's range or its check.
struct Key {
  std::string name;
  std::function<void(const json&, DaemonConfig&)> read;
  std::function<std::string(const DaemonConfig&)> check;
};

template <class Get>
Key unsigned_key(std::string name, std::uint64_t min, std::uint64_t max, Get get) {
  return {std::move(name),
          [=](const json& v, DaemonConfig& c) {
            get(c) = static_cast<std::remove_reference_t<decltype(get(c))>>(read_unsigned(v, min, max));
          },
          [](const DaemonConfig&) { return std::string(); }};
}
template <class Get>
Key signed_key(std::string name, std::int64_t min, std::int64_t max, Get get) {
  return {std::move(name),
          [=](const json& v, DaemonConfig& c) {
            get(c) = static_cast<std::remove_reference_t<decltype(get(c))>>(read_signed(v, min, max));
          },
          [](const DaemonConfig&) { return std::string(); }};
}
template <class Get>
Key number_key(std::string name, double min, double max, bool min_open, Get get) {
  return {std::move(name), [=](const json& v, DaemonConfig& c) { get(c) = read_number(v, min, max, min_open); },
          [](const DaemonConfig&) { return std::string(); }};
}
template <class Get>
Key bool_key(std::string name, Get get) {
  return {std::move(name),
          [=](const json& v, DaemonConfig& c) {
            if (!v.is_boolean()) throw std::invalid_argument(shown(v) + " is not true or false");
            get(c) = v.get<bool>();
          },
          [](const DaemonConfig&) { return std::string(); }};
}
// A string whose final value `check` accepts ("" or what is wrong).
template <class Get>
Key string_key(std::string name, Get get, std::function<std::string(const std::string&)> check) {
  return {std::move(name), [=](const json& v, DaemonConfig& c) { get(c) = read_string(v); },
          [=](const DaemonConfig& c) { return check(std::string(get(const_cast<DaemonConfig&>(c)))); }};
}

std::string any_string(const std::string&) { return {}; }

const std::vector<Key>& estimation_keys() {
  static const std::vector<Key> keys = {
      bool_key("enabled", [](DaemonConfig& c) -> auto& { return c.estimation.enabled; }),
      string_key("method", [](DaemonConfig& c) -> auto& { return c.estimation.method; },
                 [](const std::string& v) {
                   return estimation::parse_method_name(v) ? std::string()
                                                           : "\"" + v + "\" is not fast, exhaustive or 2d";
                 }),
      string_key("model", [](DaemonConfig& c) -> auto& { return c.estimation.model; },
                 [](const std::string& v) {
                   return estimation::parse_model_name(v) ? std::string() : "\"" + v + "\" is not auto, 2d or 4d";
                 }),
      string_key("discrepancy", [](DaemonConfig& c) -> auto& { return c.estimation.discrepancy; },
                 [](const std::string& v) {
                   return v == "learned" || v == "none" ? std::string() : "\"" + v + "\" is not learned or none";
                 }),
      string_key("skin_denoise", [](DaemonConfig& c) -> auto& { return c.estimation.skin_denoise; },
                 [](const std::string& v) { return v == "on" || v == "off" ? std::string() : "\"" + v + "\" is not on or off"; }),
      string_key("registration_tiles", [](DaemonConfig& c) -> auto& { return c.estimation.registration_tiles; },
                 [](const std::string& v) { return v == "on" || v == "off" ? std::string() : "\"" + v + "\" is not on or off"; }),
      string_key("local_bias", [](DaemonConfig& c) -> auto& { return c.estimation.local_bias; },
                 [](const std::string& v) { return v == "on" || v == "off" ? std::string() : "\"" + v + "\" is not on or off"; }),
      string_key("discrepancy_layer", [](DaemonConfig& c) -> auto& { return c.estimation.discrepancy_layer; },
                 [](const std::string& v) { return v == "on" || v == "off" ? std::string() : "\"" + v + "\" is not on or off"; }),
      string_key("led_library", [](DaemonConfig& c) -> auto& { return c.estimation.led_library; }, led_library_error),
      string_key("camera_sensitivity", [](DaemonConfig& c) -> auto& { return c.estimation.camera_sensitivity; },
                 camera_sensitivity_error),
      {"camera_sensitivities",
       [](const json& v, DaemonConfig& c) {
         if (!v.is_object()) throw std::invalid_argument(shown(v) + " is not a JSON object (camera name: sensitivity)");
         std::map<std::string, std::string> sensitivities;
         for (auto item = v.begin(); item != v.end(); ++item) {
           if (item.key().empty()) throw std::invalid_argument("a camera name is empty");
           if (!item.value().is_string())
             throw NestedError("[\"" + item.key() + "\"]: " + shown(item.value()) +
                               " is not a string (builtin:NAME or a CSV)");
           sensitivities[item.key()] = item.value().get<std::string>();
         }
         c.estimation.camera_sensitivities = std::move(sensitivities);
       },
       [](const DaemonConfig& c) {  // each one read as what it is
         for (auto entry = c.estimation.camera_sensitivities.begin(); entry != c.estimation.camera_sensitivities.end();
              ++entry)
           if (auto error = camera_sensitivity_error(entry->second); !error.empty())
             return "[\"" + entry->first + "\"]: " + error;
         return std::string();
       }},
      {"camera_field_width_mm",  // camera → the subject's width one frame row spans (the maps' scale bar)
       [](const json& v, DaemonConfig& c) {
         if (!v.is_object()) throw std::invalid_argument(shown(v) + " is not a JSON object (camera name: mm)");
         std::map<std::string, double> widths;
         for (auto item = v.begin(); item != v.end(); ++item) {
           if (item.key().empty()) throw std::invalid_argument("a camera name is empty");
           const double mm = item.value().is_number() ? item.value().get<double>() : std::nan("");
           if (!(mm > 0 && mm <= 10000))
             throw NestedError("[\"" + item.key() + "\"]: " + shown(item.value()) + " is not a width in (0, 10000] mm");
           widths[item.key()] = mm;
         }
         c.estimation.camera_field_width_mm = std::move(widths);
       },
       [](const DaemonConfig&) { return std::string(); }},
      number_key("white_reflectance", 0, 1, true, [](DaemonConfig& c) -> auto& { return c.estimation.white_reflectance; }),
      string_key("films_extinction_ratio", [](DaemonConfig& c) -> auto& { return c.estimation.films_extinction_ratio; },
                 films_error),
      string_key("cache_dir", [](DaemonConfig& c) -> auto& { return c.estimation.cache_dir; }, optional_folder),
      unsigned_key("cache_limit_bytes", 1ull << 20, 1ull << 50,
                   [](DaemonConfig& c) -> auto& { return c.estimation.cache_limit_bytes; }),
      signed_key("threads", 0, 256, [](DaemonConfig& c) -> auto& { return c.estimation.threads; }),
  };
  return keys;
}

void read_section(const json& value, const std::vector<Key>& keys, const std::string& section, DaemonConfig& config);

const std::vector<Key>& capture_keys() {
  static const std::vector<Key> keys = {
      bool_key("exposure_per_capture", [](DaemonConfig& c) -> auto& { return c.capture.exposure_per_capture; }),
      number_key("white_share", 0, 1, true, [](DaemonConfig& c) -> auto& { return c.capture.white_share; }),
      unsigned_key("frames_per_capture", 1, session::kMaxFramesPerCamera,
                   [](DaemonConfig& c) -> auto& { return c.capture.frames_per_capture; }),
      unsigned_key("reference_frames", 0, session::kMaxFramesPerCamera,
                   [](DaemonConfig& c) -> auto& { return c.capture.reference_frames; }),
      number_key("subject_fill", 0, 0.99, false, [](DaemonConfig& c) -> auto& { return c.capture.subject_fill; }),
      number_key("subject_percentile", 0, 1, true, [](DaemonConfig& c) -> auto& { return c.capture.subject_percentile; }),
      number_key("max_subject_exposure_ratio", 1, 64, false,
                 [](DaemonConfig& c) -> auto& { return c.capture.max_subject_exposure_ratio; }),
      number_key("blue_ratio", 0, 100, false, [](DaemonConfig& c) -> auto& { return c.capture.blue_ratio; }),
      string_key("polarised_plan", [](DaemonConfig& c) -> auto& { return c.capture.polarised_plan; },
                 [](const std::string& value) {
                   return value == "auto" || value == "on" || value == "off"
                              ? std::string()
                              : "\"" + value.substr(0, 32) + "\" is not auto, on or off";
                 }),
  };
  return keys;
}

const std::vector<Key>& hazard_keys() {
  static const std::vector<Key> keys = {
      number_key("w57_full_drive_irradiance_W_per_m2", 0, 1e5, true,
                 [](DaemonConfig& c) -> auto& { return c.hazard.w57_full_drive_irradiance_W_per_m2; }),
      number_key("limit_J_per_m2_sr", 0, 1e12, true, [](DaemonConfig& c) -> auto& { return c.hazard.limit_J_per_m2_sr; }),
      number_key("frame_allowance_ms", 0, 60000, false, [](DaemonConfig& c) -> auto& { return c.hazard.frame_allowance_ms; }),
  };
  return keys;
}

const std::vector<Key>& virtual_lab_keys() {
  static const std::vector<Key> keys = {
      {"cameras",
       [](const json& v, DaemonConfig& c) {
         try {
           c.virtual_lab.cameras = read_virtual_cameras(v);
         } catch (const std::invalid_argument& error) {
           throw NestedError(error.what());  // "[1].sensor_width: ..." or ": ..."
         }
       },
       [](const DaemonConfig& c) {  // the sensitivity files, read as what they are
         for (std::size_t i = 0; i < c.virtual_lab.cameras.size(); ++i) {
           const std::string& source = c.virtual_lab.cameras[i].sensitivity;
           if (source.empty()) continue;
           if (auto error = camera_sensitivity_error(source); !error.empty())
             return "[" + std::to_string(i) + "].sensitivity: " + error;
         }
         return std::string();
       }},
      number_key("patch_width_mm", 0, 10000, true, [](DaemonConfig& c) -> auto& { return c.virtual_lab.patch_width_mm; }),
      bool_key("polarisers", [](DaemonConfig& c) -> auto& { return c.virtual_lab.polarisers; }),
      bool_key("subsurface", [](DaemonConfig& c) -> auto& { return c.virtual_lab.subsurface; }),
      number_key("subsurface_blue_px", 0, 64, true, [](DaemonConfig& c) -> auto& { return c.virtual_lab.subsurface_blue_px; }),
      number_key("subsurface_red_px", 0, 64, true, [](DaemonConfig& c) -> auto& { return c.virtual_lab.subsurface_red_px; }),
  };
  return keys;
}

// The virtual lab's checks between keys (names against the lab's other
// devices, every posed camera seeing the patch): VirtualLabOptions'.
std::string virtual_lab_error(const DaemonConfig& c) {
  std::string error;
  return virtual_lab_options(c.virtual_lab).IsValid(&error) ? std::string() : "." + error;
}

// A section of keys ("estimation", "capture", "hazard"): read and checked key by key.
// `between`, if given, checks the section's keys together after each key's own check.
Key section_key(std::string name, const std::vector<Key>& (*keys)(),
                std::string (*between)(const DaemonConfig&) = nullptr) {
  return {name, [=](const json& v, DaemonConfig& c) { read_section(v, keys(), name, c); },
          [=](const DaemonConfig& c) {
            for (const auto& key : keys())
              if (auto error = key.check(c); !error.empty())
                return "." + key.name + (error.front() == '[' ? "" : ": ") + error;
            return between ? between(c) : std::string();
          }};
}

void read_section(const json& value, const std::vector<Key>& keys, const std::string& section, DaemonConfig& config) {
  if (!value.is_object()) throw std::invalid_argument(shown(value) + " is not a JSON object");
  for (const auto& [name, item] : value.items()) {
    const Key* key = nullptr;
    for (const auto& k : keys)
      if (k.name == name) key = &k;
    if (!key) {
      const std::string message = "unknown key \"" + name + "\" (see docs/config.md)";
      if (section.empty()) throw std::invalid_argument(message);
      throw NestedError(": " + message);
    }
    const std::string path = section.empty() ? name : "." + name;
    try {
      key->read(item, config);
    } catch (const NestedError& error) {
      throw NestedError(path + error.what());
    } catch (const std::invalid_argument& error) {
      throw NestedError(path + ": " + error.what());
    }
  }
}

const std::vector<Key>& top_level_keys() {
  static const std::vector<Key> keys = {
      string_key("runtime_dir", [](DaemonConfig& c) -> auto& { return c.runtime_dir; },
                 [](const std::string& v) {
                   if (v.empty())
                     return std::string("no default (none of CHROMO_RUNTIME_DIR, XDG_RUNTIME_DIR, HOME is set): set it");
                   return folder_error_tried(v);
                 }),
      string_key("unix_socket", [](DaemonConfig& c) -> auto& { return c.unix_socket; }, unix_socket_error),
      string_key("log_format", [](DaemonConfig& c) -> auto& { return c.log_format; },
                 [](const std::string& v) {
                   return v == "text" || v == "json" ? std::string() : "\"" + v.substr(0, 64) + "\" is not text or json";
                 }),
      {"unix_socket_mode",
       [](const json& v, DaemonConfig& c) {
         const std::string text = read_string(v);
         if (text.empty() || text.size() > 4 || text.find_first_not_of("01234567") != std::string::npos ||
             std::stoul(text, nullptr, 8) > 0777)
           throw std::invalid_argument(shown(v) + " is not an octal file mode of at most 0777 (e.g. \"0660\")");
         c.unix_socket_mode = static_cast<std::uint32_t>(std::stoul(text, nullptr, 8));
       },
       [](const DaemonConfig& c) {
         return (c.unix_socket_mode & 0600) == 0600 ? std::string()
                                                    : "the owner must be able to read and write the socket (0600)";
       }},
      string_key("tcp_address", [](DaemonConfig& c) -> auto& { return c.tcp_address; }, tcp_address_error),
      string_key("token", [](DaemonConfig& c) -> auto& { return c.token; }, any_string),  // length: IsValid
      string_key("tls_certificate_file", [](DaemonConfig& c) -> auto& { return c.tls_certificate_file; }, pem_file_error),
      string_key("tls_private_key_file", [](DaemonConfig& c) -> auto& { return c.tls_private_key_file; }, pem_file_error),
      bool_key("tcp_insecure", [](DaemonConfig& c) -> auto& { return c.tcp_insecure; }),  // with TLS or token: IsValid
      unsigned_key("max_streams", 1, 1024, [](DaemonConfig& c) -> auto& { return c.max_streams; }),
      unsigned_key("tcp_handshake_timeout_ms", 100, 120000,
                   [](DaemonConfig& c) -> auto& { return c.tcp_handshake_timeout_ms; }),
      unsigned_key("tcp_idle_timeout_ms", 100, 3600000, [](DaemonConfig& c) -> auto& { return c.tcp_idle_timeout_ms; }),
      unsigned_key("max_tcp_connections", 1, 4096, [](DaemonConfig& c) -> auto& { return c.max_tcp_connections; }),
      string_key("maps_dir", [](DaemonConfig& c) -> auto& { return c.maps_dir; }, optional_folder),
      unsigned_key("max_read_maps_bytes", 1ull << 20, 1ull << 36,
                   [](DaemonConfig& c) -> auto& { return c.max_read_maps_bytes; }),
      unsigned_key("max_profile_exports", 1, 16, [](DaemonConfig& c) -> auto& { return c.max_profile_exports; }),
      string_key("web_address", [](DaemonConfig& c) -> auto& { return c.web_address; }, tcp_address_error),
      string_key("web_dir", [](DaemonConfig& c) -> auto& { return c.web_dir; }, optional_existing_folder),
      unsigned_key("web_max_body_bytes", 1024, 64u << 20, [](DaemonConfig& c) -> auto& { return c.web_max_body_bytes; }),
      unsigned_key("web_stream_keepalive_ms", 100, 600000,
                   [](DaemonConfig& c) -> auto& { return c.web_stream_keepalive_ms; }),
      unsigned_key("web_max_streams", 1, kMaxWebStreams, [](DaemonConfig& c) -> auto& { return c.web_max_streams; }),
      unsigned_key("web_request_head_timeout_ms", 500, 120000,
                   [](DaemonConfig& c) -> auto& { return c.web_request_head_timeout_ms; }),
      {"web_host_names",
       [](const json& v, DaemonConfig& c) {
         if (!v.is_array()) throw std::invalid_argument(shown(v) + " is not a JSON array of host names");
         std::vector<std::string> names;
         for (std::size_t i = 0; i < v.size(); ++i) {
           if (!v[i].is_string()) throw NestedError("[" + std::to_string(i) + "]: " + shown(v[i]) + " is not a string");
           if (!is_valid_host_name(v[i].get<std::string>()))
             throw NestedError("[" + std::to_string(i) + "]: " + shown(v[i]) +
                               " is not a host name or numeric address without a port");
           names.push_back(v[i].get<std::string>());
         }
         c.web_host_names = std::move(names);
       },
       [](const DaemonConfig&) { return std::string(); }},
      string_key("sessions_dir", [](DaemonConfig& c) -> auto& { return c.sessions_dir; },
                 [](const std::string& v) { return folder_error_tried(v); }),
      unsigned_key("storage_limit_bytes", 0, std::numeric_limits<std::int64_t>::max(),
                   [](DaemonConfig& c) -> auto& { return c.storage_limit_bytes; }),
      unsigned_key("storage_queue_frames", 1, 100000, [](DaemonConfig& c) -> auto& { return c.storage_queue_frames; }),
      unsigned_key("estimator_queue_frames", 0, 100000,
                   [](DaemonConfig& c) -> auto& { return c.estimator_queue_frames; }),
      unsigned_key("frame_timeout_ms", 1, 600000, [](DaemonConfig& c) -> auto& { return c.frame_timeout_ms; }),
      unsigned_key("frame_attempts", 1, 100, [](DaemonConfig& c) -> auto& { return c.frame_attempts; }),
      string_key("led_library", [](DaemonConfig& c) -> auto& { return c.led_library; }, led_library_error),
      {"devices",
       [](const json& v, DaemonConfig& c) {
         if (!v.is_array()) throw std::invalid_argument(shown(v) + " is not a JSON array");
         c.devices.clear();
         for (std::size_t i = 0; i < v.size(); ++i) try {
             c.devices.push_back(read_device(v[i]));
           } catch (const std::invalid_argument& error) {
             throw NestedError("[" + std::to_string(i) + "]." + error.what());
           }
       },
       // Backend names, addresses and settings: BackendRegistry::open, before any device opens.
       [](const DaemonConfig&) { return std::string(); }},
      {"mixes",
       [](const json& v, DaemonConfig& c) {
         if (!v.is_object()) throw std::invalid_argument(shown(v) + " is not a JSON object");
         for (const auto& [name, levels] : v.items()) try {
             c.mixes[name] = read_levels(levels);
           } catch (const std::invalid_argument& error) {
             throw NestedError("." + name + "." + error.what());
           }
       },
       [](const DaemonConfig&) { return std::string(); }},  // names: IsValid
      section_key("estimation", estimation_keys),
      section_key("capture", capture_keys),
      section_key("hazard", hazard_keys),
      section_key("virtual_lab", virtual_lab_keys, virtual_lab_error),
  };
  return keys;
}

}  // namespace

std::vector<std::string> config_key_names() {
  std::vector<std::string> names;
  for (const auto& key : top_level_keys())
    if (key.name != "estimation" && key.name != "capture" && key.name != "hazard" && key.name != "virtual_lab")
      names.push_back(key.name);
  for (const auto& key : estimation_keys()) names.push_back("estimation." + key.name);
  for (const auto& key : capture_keys()) names.push_back("capture." + key.name);
  for (const auto& key : hazard_keys()) names.push_back("hazard." + key.name);
  for (const auto& key : virtual_lab_keys()) names.push_back("virtual_lab." + key.name);
  return names;
}

DaemonConfig read_config_values(const json& json_config, const std::string& origin) {
  if (!json_config.is_object()) throw std::invalid_argument(origin + ": must be a JSON object");
  DaemonConfig config;
  try {
    read_section(json_config, top_level_keys(), "", config);
  } catch (const std::invalid_argument& error) {  // NestedError too: its path starts at a top-level key
    throw std::invalid_argument(origin + ": " + error.what());
  }
  // The socket goes into the runtime folder unless it is named.
  if (json_config.contains("runtime_dir") && !json_config.contains("unix_socket"))
    config.unix_socket = (config.runtime_dir / "chromod.sock").string();
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument(origin + ": " + error);
  return config;
}

DaemonConfig parse_config(const json& json_config, const std::string& origin) {
  DaemonConfig config = read_config_values(json_config, origin);
  // Every key's check on its final value, given or default.
  for (const auto& key : top_level_keys())
    if (auto problem = key.check(config); !problem.empty())
      throw std::invalid_argument(origin + ": " + key.name + (problem.front() == '.' ? "" : ": ") + problem);
  return config;
}

json read_config_json(const fs::path& path) {
  std::string text;
  try {
    text = files::read_text_file(path, "configuration");
  } catch (const files::InputFileError& e) {
    throw std::invalid_argument(e.what());
  }
  auto parsed = json::parse(text, nullptr, false);
  if (parsed.is_discarded()) throw std::invalid_argument(path.string() + ": not valid JSON");
  if (!parsed.is_object()) throw std::invalid_argument(path.string() + ": must be a JSON object");
  return parsed;
}

DaemonConfig read_config_file(const fs::path& path) { return parse_config(read_config_json(path), path.string()); }

std::map<std::string, drivers::DriveLevels> default_virtual_lab_mixes() {
  // Order: W57 W40 W27 R G B. Placeholders for sessions before a calibration
  // has solved the real mixes; replaced by the solver's weights when available.
  return {{"d65", {0.80, 0.0, 0.0, 0.05, 0.10, 0.25}},
          {"w57", {0.80, 0.0, 0.0, 0.0, 0.0, 0.0}},
          {"w57+blue", {0.80, 0.0, 0.0, 0.0, 0.0, 0.40}}};
}

}  // namespace chromo::daemon
