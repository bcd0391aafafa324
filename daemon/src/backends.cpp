// The backends built into this daemon. Drivers (drivers/) and the virtual lab
// (simulators/) register here as they are built in.
#include "chromo/daemon/device_set.hpp"
#include "chromo/daemon/loopback_lab.hpp"

namespace chromo::daemon {

BackendRegistry builtin_backends() {
  BackendRegistry registry;
  // One LoopbackLab per registry: loopback devices of one configuration share it.
  auto lab = std::make_shared<LoopbackLab>();
  registry.add_led_controller("loopback", [lab](const DeviceConfig& c) { return make_loopback_led_controller(lab, c); });
  registry.add_camera("loopback", [lab](const DeviceConfig& c) { return make_loopback_camera(lab, c); });
  return registry;
}

}  // namespace chromo::daemon
