// open_devices: see devices.hpp.
#include "chromo/daemon/devices.hpp"

#include "chromo/daemon/internal/devices/virtual_lab.hpp"

namespace chromo::daemon {

OpenedDevices open_devices(DaemonConfig& config) {
  if (!config.devices.empty()) return {builtin_backends().open(config.devices), ""};
  VirtualLab lab = start_virtual_lab(virtual_lab_options(config.virtual_lab));
  config.devices = lab.devices;
  if (config.mixes.empty()) config.mixes = lab.mixes;
  return {std::move(lab.device_set), lab.description};
}

}  // namespace chromo::daemon
