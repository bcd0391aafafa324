// open_devices: see devices.hpp.
#include "chromo/daemon/devices.hpp"

#include "chromo/daemon/internal/devices/virtual_lab.hpp"
#include "chromo/simulators/camera/lab_cameras.hpp"

namespace chromo::daemon {

OpenedDevices open_devices(DaemonConfig& config) {
  if (!config.devices.empty()) return {builtin_backends().open(config.devices), ""};
  const VirtualLabOptions options = virtual_lab_options(config.virtual_lab);
  VirtualLab lab = start_virtual_lab(options);
  config.devices = lab.devices;
  // The lab knows its cameras' geometry: the maps' scale (docs/maps.md "Scale
  // bar"); a width configured for a camera (estimation.camera_field_width_mm) stays.
  for (const auto& camera : options.cameras)
    config.estimation.camera_field_width_mm.try_emplace(camera.name,
                                                        simulators::lab_camera_field_width_mm(camera, options.patch_width_mm));
  if (config.mixes.empty()) config.mixes = lab.mixes;
  return {std::move(lab.device_set), lab.description};
}

}  // namespace chromo::daemon
