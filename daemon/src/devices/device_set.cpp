#include "chromo/daemon/internal/devices/device_set.hpp"

#include <stdexcept>

namespace chromo::daemon {

namespace {
template <typename Interface>
NamedDevice<Interface>* find_device(std::vector<std::unique_ptr<NamedDevice<Interface>>>& devices,
                                    const std::string& name, const char* kind, std::string* error) {
  if (name.empty()) {
    if (devices.size() == 1) return devices.front().get();
    if (error)
      *error = devices.empty() ? std::string("no ") + kind + " is configured"
                               : std::string("there are ") + std::to_string(devices.size()) + " " + kind + "s: name one";
    return nullptr;
  }
  for (auto& device : devices)
    if (device->config.name == name) return device.get();
  if (error) *error = std::string("no ") + kind + " named \"" + name.substr(0, 64) + "\"";
  return nullptr;
}

template <typename Interface, typename Factory>
void open_into(std::vector<std::unique_ptr<NamedDevice<Interface>>>& out, const DeviceConfig& config,
               const std::map<std::string, Factory>& factories) {
  auto factory = factories.find(config.backend);
  if (factory == factories.end())
    throw std::invalid_argument("device \"" + config.name + "\": backend \"" + config.backend + "\" is not built in for " +
                                device_kind_name(config.kind));
  auto named = std::make_unique<NamedDevice<Interface>>();
  named->config = config;
  try {
    named->device = factory->second(config);
  } catch (const std::invalid_argument& error) {
    // A setting the backend refuses: a configuration error, not a device that is away.
    throw std::invalid_argument("device \"" + config.name + "\" (" + config.backend + "): " + error.what());
  } catch (const std::exception& error) {
    named->open_error = error.what();
  }
  out.push_back(std::move(named));
}
}  // namespace

NamedDevice<drivers::LedController>* DeviceSet::led_controller(const std::string& name, std::string* error) {
  return find_device(led_controllers, name, "LED controller", error);
}

NamedDevice<drivers::Spectrometer>* DeviceSet::spectrometer(const std::string& name, std::string* error) {
  return find_device(spectrometers, name, "spectrometer", error);
}

void BackendRegistry::add_led_controller(const std::string& backend, LedFactory factory) {
  led_[backend] = std::move(factory);
}
void BackendRegistry::add_camera(const std::string& backend, CameraFactory factory) {
  camera_[backend] = std::move(factory);
}
void BackendRegistry::add_spectrometer(const std::string& backend, SpectrometerFactory factory) {
  spectrometer_[backend] = std::move(factory);
}

DeviceSet BackendRegistry::open(const std::vector<DeviceConfig>& devices) const {
  DeviceSet set;
  for (const auto& config : devices) {
    switch (config.kind) {
      case DeviceKind::kLedController: open_into(set.led_controllers, config, led_); break;
      case DeviceKind::kCamera: open_into(set.cameras, config, camera_); break;
      case DeviceKind::kSpectrometer: open_into(set.spectrometers, config, spectrometer_); break;
    }
  }
  return set;
}

std::vector<std::string> BackendRegistry::backends(DeviceKind kind) const {
  std::vector<std::string> names;
  auto collect = [&](const auto& map) {
    for (const auto& [name, factory] : map) names.push_back(name);
  };
  if (kind == DeviceKind::kLedController) collect(led_);
  if (kind == DeviceKind::kCamera) collect(camera_);
  if (kind == DeviceKind::kSpectrometer) collect(spectrometer_);
  return names;
}

}  // namespace chromo::daemon
