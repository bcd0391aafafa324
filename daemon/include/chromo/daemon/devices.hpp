#pragma once
// The devices chromod runs with, opened from its configuration: the
// configured devices through the built-in backends (backends.cpp), or, with
// none configured, the built-in virtual lab (config.virtual_lab) as one more
// backend (internal/devices/virtual_lab.hpp). chromod includes this, never a
// simulator.

#include <string>

#include "chromo/daemon/config.hpp"
#include "chromo/daemon/internal/devices/device_set.hpp"

namespace chromo::daemon {

struct OpenedDevices {
  DeviceSet devices;
  std::string virtual_lab;  // what the virtual lab started ("" with configured devices)
};

// Opens config.devices; when it is empty, starts the virtual lab and writes
// its devices into config.devices and, if config.mixes is empty, its
// placeholder mixes into config.mixes. A device that cannot be opened keeps
// its open_error; throws std::invalid_argument for an unknown backend or
// setting, std::runtime_error when a simulator cannot start.
OpenedDevices open_devices(DaemonConfig& config);

}  // namespace chromo::daemon
