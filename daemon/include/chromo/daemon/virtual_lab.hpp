#pragma once
// The built-in virtual lab chromod runs without a configuration. Today it is
// the loopback devices (loopback_lab.hpp) because the protocol simulators of
// simulators/ are not built in yet; when they are, this starts them in-process
// (Modbus TCP LED controller, GigE Vision camera on loopback) and returns
// devices connected to them through the real drivers.

#include <map>
#include <string>
#include <vector>

#include "chromo/daemon/device_set.hpp"

namespace chromo::daemon {

struct VirtualLab {
  std::vector<DeviceConfig> devices;
  DeviceSet device_set;
  std::map<std::string, drivers::DriveLevels> mixes;
  std::string description;
};

VirtualLab start_virtual_lab();

}  // namespace chromo::daemon
