#include "chromo/daemon/virtual_lab.hpp"

#include "chromo/daemon/loopback_lab.hpp"

namespace chromo::daemon {

VirtualLab start_virtual_lab() {
  VirtualLab lab;
  lab.devices = loopback_lab_devices();
  lab.device_set = builtin_backends().open(lab.devices);
  lab.mixes = default_virtual_lab_mixes();
  lab.description = "loopback devices: the protocol simulators are not built in yet";
  return lab;
}

}  // namespace chromo::daemon
