// The backends built into this daemon: the real drivers of drivers/, each
// with the settings docs/config.md lists. A setting that is unknown, of the
// wrong type or out of range throws std::invalid_argument naming
// "settings.<key>" (DeviceSet::open adds the device's name); a device that
// does not answer becomes its open_error instead.
#include <cctype>
#include <charconv>
#include <set>
#include <stdexcept>

#include "chromo/daemon/internal/devices/device_set.hpp"
#include "chromo/drivers/camera/aravis_camera.hpp"
#include "chromo/drivers/led_controller_factory.hpp"
#include "chromo/drivers/spectrometer_factory.hpp"

namespace chromo::daemon {

namespace {

// Reads a device's "settings" object, refusing keys the backend does not know.
class Settings {
 public:
  Settings(const DeviceConfig& config, std::set<std::string> known) : json_(config.settings) {
    if (!json_.is_object()) throw std::invalid_argument("settings: must be a JSON object");
    for (const auto& [key, value] : json_.items())
      if (!known.count(key)) {
        std::string list;
        for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
        throw std::invalid_argument("settings." + key + ": unknown for this backend (known: " +
                                    (list.empty() ? std::string("none") : list) + ")");
      }
  }
  bool has(const std::string& key) const { return json_.contains(key); }
  long long integer(const std::string& key, long long fallback, long long min, long long max) const {
    if (!has(key)) return fallback;
    const auto& value = json_.at(key);
    if (!value.is_number_integer()) throw std::invalid_argument("settings." + key + ": must be an integer");
    const auto v = value.get<long long>();
    if (v < min || v > max)
      throw std::invalid_argument("settings." + key + ": " + std::to_string(v) + " is outside [" + std::to_string(min) +
                                  ", " + std::to_string(max) + "]");
    return v;
  }
  double number(const std::string& key, double fallback, double min, double max) const {
    if (!has(key)) return fallback;
    const auto& value = json_.at(key);
    if (!value.is_number()) throw std::invalid_argument("settings." + key + ": must be a number");
    const auto v = value.get<double>();
    if (!(v >= min && v <= max))
      throw std::invalid_argument("settings." + key + ": outside [" + std::to_string(min) + ", " + std::to_string(max) + "]");
    return v;
  }
  std::string text(const std::string& key, const std::string& fallback) const {
    if (!has(key)) return fallback;
    if (!json_.at(key).is_string()) throw std::invalid_argument("settings." + key + ": must be a string");
    return json_.at(key).get<std::string>();
  }
  const nlohmann::json& raw(const std::string& key) const { return json_.at(key); }

 private:
  const nlohmann::json& json_;
};

std::chrono::milliseconds timeout_setting(const Settings& s, const std::string& key) {
  return std::chrono::milliseconds(s.integer(key, 300, 10, 60000));
}

std::uint16_t hex16(const std::string& text, const std::string& what) {
  unsigned value = 0;
  auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value, 16);
  if (error != std::errc() || end != text.data() + text.size() || text.empty() || value > 0xffff)
    throw std::invalid_argument("address: " + what + " \"" + text + "\" is not a 4-digit hex number");
  return static_cast<std::uint16_t>(value);
}

std::unique_ptr<drivers::LedController> open_modbus_tcp(const DeviceConfig& config) {
  Settings s(config, {"unit_id", "response_timeout_ms"});
  drivers::ModbusLinkOptions options;
  options.unit_id = static_cast<int>(s.integer("unit_id", 1, 1, 247));
  options.response_timeout = timeout_setting(s, "response_timeout_ms");
  const auto colon = config.address.rfind(':');
  std::string host = config.address.substr(0, colon);
  int port = 502;
  if (colon != std::string::npos) {
    const std::string digits = config.address.substr(colon + 1);
    auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), port);
    if (error != std::errc() || end != digits.data() + digits.size() || port < 1 || port > 65535)
      throw std::invalid_argument("address: \"" + config.address + "\" is not host:port with a port in 1-65535");
  }
  if (host.empty()) throw std::invalid_argument("address: missing the host (host:port)");
  return drivers::make_modbus_tcp_led_controller(host, port, options);
}

std::unique_ptr<drivers::LedController> open_modbus_rtu(const DeviceConfig& config) {
  Settings s(config, {"unit_id", "response_timeout_ms", "baud"});
  drivers::ModbusLinkOptions options;
  options.unit_id = static_cast<int>(s.integer("unit_id", 1, 1, 247));
  options.response_timeout = timeout_setting(s, "response_timeout_ms");
  const int baud = static_cast<int>(s.integer("baud", 115200, 1200, 4000000));
  if (config.address.empty()) throw std::invalid_argument("address: the serial device path is missing (e.g. /dev/ttyUSB0)");
  return drivers::make_modbus_rtu_led_controller(config.address, baud, options);
}

std::unique_ptr<drivers::LedController> open_hid(const DeviceConfig& config) {
  Settings s(config, {"reply_timeout_ms"});
  drivers::HidLinkOptions options;
  options.reply_timeout = timeout_setting(s, "reply_timeout_ms");
  const HidAddress address = parse_hid_address(config.address);
  return drivers::make_hid_led_controller(address.vendor_id, address.product_id, address.serial, options);
}

std::unique_ptr<drivers::Spectrometer> open_usb_spectrometer(const DeviceConfig& config) {
  Settings s(config, {});
  return drivers::make_usb_spectrometer(config.address);
}

const std::set<std::string> kCameraCaptureSettings{"pixel_format", "roi", "gain_db", "trigger_input"};

std::unique_ptr<drivers::Camera> open_aravis(const DeviceConfig& config) {
  auto known = kCameraCaptureSettings;
  known.insert({"packet_size_bytes", "buffer_count", "socket_buffer_bytes", "frame_retention_ms", "ip_address"});
  Settings s(config, known);
  camera_capture_settings(config);  // validates pixel_format, roi, gain_db before connecting
  drivers::AravisCameraOptions options;
  if (config.address.empty()) throw std::invalid_argument("address: the camera's serial number is missing");
  options.serial = config.address;
  if (config.settings.contains("ip_address")) {
    if (!config.settings.at("ip_address").is_string())
      throw std::invalid_argument("settings.ip_address: must be a string (IPv4 a.b.c.d)");
    options.address = config.settings.at("ip_address").get<std::string>();
  }
  options.packet_size_bytes = static_cast<int>(s.integer("packet_size_bytes", 0, 0, 16000));
  options.buffer_count = static_cast<int>(s.integer("buffer_count", options.buffer_count, 2, 256));
  options.socket_buffer_bytes =
      static_cast<std::size_t>(s.integer("socket_buffer_bytes", static_cast<long long>(options.socket_buffer_bytes), 65536, 1ll << 30));
  options.frame_retention_ms = static_cast<int>(s.integer("frame_retention_ms", options.frame_retention_ms, 10, 60000));
  if (config.settings.contains("trigger_input")) options.hardware_trigger_line = config.settings.at("trigger_input").get<std::string>();
  if (std::string error; !options.IsValid(&error)) throw std::invalid_argument("settings: " + error);
  return drivers::AravisCamera::open(options);
}

}  // namespace

drivers::CameraSettings camera_capture_settings(const DeviceConfig& config) {
  drivers::CameraSettings settings;
  const auto& json = config.settings;
  if (!json.is_object()) throw std::invalid_argument("settings: must be a JSON object");
  if (json.contains("pixel_format")) {
    if (!json.at("pixel_format").is_string()) throw std::invalid_argument("settings.pixel_format: must be a string");
    const std::string name = json.at("pixel_format").get<std::string>();
    const auto format = drivers::parse_pixel_format(name);
    if (!format)
      throw std::invalid_argument("settings.pixel_format: \"" + name.substr(0, 64) + "\" unknown (" +
                                  drivers::pixel_format_names() + ")");
    settings.pixel_format = *format;
  }
  if (json.contains("gain_db")) {
    if (!json.at("gain_db").is_number()) throw std::invalid_argument("settings.gain_db: must be a number");
    settings.gain_db = json.at("gain_db").get<double>();
    if (!(settings.gain_db >= 0 && settings.gain_db <= 48)) throw std::invalid_argument("settings.gain_db: outside [0, 48]");
  }
  if (json.contains("roi")) {
    const auto& roi = json.at("roi");
    if (!roi.is_object()) throw std::invalid_argument("settings.roi: must be {\"x\", \"y\", \"width\", \"height\"}");
    for (const auto& [key, value] : roi.items()) {
      if (key != "x" && key != "y" && key != "width" && key != "height")
        throw std::invalid_argument("settings.roi." + key + ": unknown (x, y, width, height)");
      if (!value.is_number_integer() || value.get<long long>() < 0 || value.get<long long>() > 65535)
        throw std::invalid_argument("settings.roi." + key + ": must be an integer in [0, 65535]");
    }
    settings.roi = {roi.value("x", 0), roi.value("y", 0), roi.value("width", 0), roi.value("height", 0)};
  }
  // Wired to the LED controller's trigger output: hardware-triggered on that
  // input line; otherwise the sequencer triggers the camera by software.
  settings.trigger_mode = drivers::TriggerMode::kSoftware;
  if (json.contains("trigger_input")) {
    const auto& line = json.at("trigger_input");
    const bool valid = line.is_string() && line.get<std::string>().size() == 5 &&
                       line.get<std::string>().starts_with("Line") && std::isdigit(static_cast<unsigned char>(line.get<std::string>()[4]));
    if (!valid) throw std::invalid_argument("settings.trigger_input: must be \"Line0\" … \"Line9\" (the input wired to the LED controller's trigger output)");
    settings.trigger_mode = drivers::TriggerMode::kHardware;
  }
  return settings;
}

BackendRegistry builtin_backends() {
  BackendRegistry registry;
  registry.add_led_controller("modbus-tcp", open_modbus_tcp);
  registry.add_led_controller("modbus-rtu", open_modbus_rtu);
  registry.add_led_controller("hid", open_hid);
  registry.add_spectrometer("usb", open_usb_spectrometer);
  registry.add_camera("aravis", open_aravis);
  return registry;
}

HidAddress parse_hid_address(const std::string& address) {
  const auto first = address.find(':');
  if (first == std::string::npos) throw std::invalid_argument("address: must be vendor:product[:serial] (hex ids)");
  const auto second = address.find(':', first + 1);
  HidAddress parsed;
  parsed.vendor_id = hex16(address.substr(0, first), "vendor id");
  parsed.product_id =
      hex16(address.substr(first + 1, second == std::string::npos ? std::string::npos : second - first - 1), "product id");
  parsed.serial = second == std::string::npos ? "" : address.substr(second + 1);
  return parsed;
}

}  // namespace chromo::daemon
