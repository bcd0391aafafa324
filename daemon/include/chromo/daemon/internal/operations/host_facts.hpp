#pragma once
// What the lab's checks (lab_checks.hpp) read of the host: the kernel's
// receive-buffer ceiling, the interface that reaches a camera and its MTU,
// free disk, the clock's NTP state, and the device nodes of USB and HID
// devices. Each reader takes its root folder so that a check is pointed at
// the real /proc, /sys and /dev in chromod and at a folder of real files in
// tests. Nothing here changes the host.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "chromo/daemon/internal/operations/lab_checks.hpp"

namespace chromo::daemon {

// net.core.rmem_max in bytes (<proc_sys>/net/core/rmem_max); nullopt when unreadable.
std::optional<std::uint64_t> read_rmem_max(const std::filesystem::path& proc_sys = "/proc/sys");

struct InterfaceRoute {
  std::string name;   // "eth1", "lo"
  int mtu_bytes = 0;  // 0 = unreadable
};
// The interface holding an IPv4 address whose subnet contains `ipv4`
// (getifaddrs; 127.0.0.0/8 is lo's); nullopt when none does or `ipv4` is not
// an IPv4 address.
std::optional<InterfaceRoute> interface_reaching(const std::string& ipv4);

// Free bytes for an unprivileged writer at `folder` or its nearest existing
// parent (statvfs f_bavail); nullopt when none can be read.
std::optional<std::uint64_t> free_disk_bytes(const std::filesystem::path& folder);

// Whether chromod's user may create files in `folder` (or, when it does not
// exist yet, in its nearest existing parent).
bool folder_writable(const std::filesystem::path& folder);

// The kernel clock's NTP state (adjtimex): synchronised and its maxerror.
void read_clock_state(HostFacts& host);

// Everything above for the sessions folder.
HostFacts read_host_facts(const std::filesystem::path& sessions_dir);

// The device node of the first USB device with these ids
// (<sys>/bus/usb/devices/*/idVendor, idProduct, busnum, devnum →
// <dev>/bus/usb/BBB/DDD); empty when none is plugged in.
std::filesystem::path find_usb_device_node(std::uint16_t vendor_id, std::uint16_t product_id,
                                           const std::filesystem::path& sys = "/sys",
                                           const std::filesystem::path& dev = "/dev");
// The hidraw node of the first HID device with these ids
// (<sys>/class/hidraw/*/device/uevent's HID_ID → <dev>/hidrawN); empty when none.
std::filesystem::path find_hidraw_node(std::uint16_t vendor_id, std::uint16_t product_id,
                                       const std::filesystem::path& sys = "/sys",
                                       const std::filesystem::path& dev = "/dev");

// Whether the service's user can read and write a device node: for a
// non-root process, access(R_OK|W_OK); for root (who may open anything), the
// node's mode must grant read and write to its group or to everyone, as the
// package's udev rules do, since chromod.service does not run as root.
bool device_node_usable(const std::filesystem::path& node);

}  // namespace chromo::daemon
