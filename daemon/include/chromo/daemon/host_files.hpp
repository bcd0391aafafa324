#pragma once
// The host's files a configuration needs, which the Debian package installs
// (packaging/README.md) and `chromod --write-host-files DIR` regenerates
// after the configuration's devices change:
//
//   udev/rules.d/60-chromosphere.rules  the USB2000+ spectrometer (2457:101e) and
//                                       every configured `hid` LED controller
//                                       (vendor:product from its address), their
//                                       nodes given to the service's group, mode 0660
//   sysctl.d/60-chromosphere.conf       net.core.rmem_max at least the largest
//                                       configured camera's socket_buffer_bytes
//                                       (else the driver's 32 MiB default)
//
// Pure text from the configuration; nothing here reads the host.

#include <cstdint>
#include <filesystem>
#include <string>

#include "chromo/daemon/config.hpp"

namespace chromo::daemon {

// The group that owns the devices' nodes: the service's own (chromod.service).
inline constexpr const char* kServiceGroup = "chromosphere";

// The udev rules for the configuration's USB and HID devices. Throws
// std::invalid_argument naming the device whose hid address is not
// vendor:product[:serial] in hex.
std::string udev_rules(const DaemonConfig& config, const std::string& group = kServiceGroup);

// The receive-buffer ceiling the configured cameras need, in bytes.
std::uint64_t needed_rmem_max_bytes(const DaemonConfig& config);
// The sysctl drop-in setting it.
std::string sysctl_conf(const DaemonConfig& config);

// Writes both under `root` (root/udev/rules.d/..., root/sysctl.d/...),
// durably; creates the folders. Returns the paths written.
std::vector<std::filesystem::path> write_host_files(const DaemonConfig& config, const std::filesystem::path& root);

}  // namespace chromo::daemon
