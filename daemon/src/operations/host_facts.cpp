// What the lab's checks read of the host (host_facts.hpp).
#include "chromo/daemon/internal/operations/host_facts.hpp"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <sys/statvfs.h>
#include <sys/stat.h>
#include <sys/timex.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

#include <fmt/format.h>

namespace chromo::daemon {
namespace {

std::optional<std::string> read_line(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::string line;
  if (!in || !std::getline(in, line)) return std::nullopt;
  return line;
}

std::optional<unsigned long> read_number(const std::filesystem::path& file, int base) {
  auto line = read_line(file);
  if (!line) return std::nullopt;
  try {
    std::size_t used = 0;
    const unsigned long value = std::stoul(*line, &used, base);
    return value;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// The folder itself or, when it does not exist yet, its nearest existing parent.
std::filesystem::path existing_folder(std::filesystem::path folder) {
  folder = std::filesystem::absolute(folder);
  std::error_code error;
  while (!std::filesystem::exists(folder, error) && folder.has_relative_path()) folder = folder.parent_path();
  return folder;
}

}  // namespace

std::optional<std::uint64_t> read_rmem_max(const std::filesystem::path& proc_sys) {
  auto value = read_number(proc_sys / "net/core/rmem_max", 10);
  if (!value) return std::nullopt;
  return static_cast<std::uint64_t>(*value);
}

std::optional<InterfaceRoute> interface_reaching(const std::string& ipv4) {
  in_addr target{};
  if (inet_pton(AF_INET, ipv4.c_str(), &target) != 1) return std::nullopt;
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) != 0) return std::nullopt;
  std::optional<InterfaceRoute> found;
  for (ifaddrs* entry = list; entry != nullptr && !found; entry = entry->ifa_next) {
    if (entry->ifa_addr == nullptr || entry->ifa_netmask == nullptr || entry->ifa_addr->sa_family != AF_INET) continue;
    const auto address = reinterpret_cast<const sockaddr_in*>(entry->ifa_addr)->sin_addr.s_addr;
    const auto mask = reinterpret_cast<const sockaddr_in*>(entry->ifa_netmask)->sin_addr.s_addr;
    if ((address & mask) != (target.s_addr & mask)) continue;
    InterfaceRoute route{entry->ifa_name, 0};
    if (auto mtu = read_number(std::filesystem::path("/sys/class/net") / route.name / "mtu", 10))
      route.mtu_bytes = static_cast<int>(*mtu);
    found = route;
  }
  freeifaddrs(list);
  return found;
}

std::optional<std::uint64_t> free_disk_bytes(const std::filesystem::path& folder) {
  struct statvfs stats {};
  if (statvfs(existing_folder(folder).c_str(), &stats) != 0) return std::nullopt;
  return static_cast<std::uint64_t>(stats.f_bavail) * stats.f_frsize;
}

bool folder_writable(const std::filesystem::path& folder) {
  const auto existing = existing_folder(folder);
  std::error_code error;
  return std::filesystem::is_directory(existing, error) && access(existing.c_str(), W_OK | X_OK) == 0;
}

void read_clock_state(HostFacts& host) {
  timex clock{};
  const int state = adjtimex(&clock);
  if (state == -1) return;
  host.clock_synchronised = state != TIME_ERROR && (clock.status & STA_UNSYNC) == 0;
  host.clock_max_error_us = clock.maxerror;
}

HostFacts read_host_facts(const std::filesystem::path& sessions_dir) {
  HostFacts host;
  host.sessions_dir = sessions_dir;
  host.rmem_max_bytes = read_rmem_max();
  host.free_disk_bytes = free_disk_bytes(sessions_dir);
  host.sessions_dir_writable = folder_writable(sessions_dir);
  read_clock_state(host);
  return host;
}

std::filesystem::path find_usb_device_node(std::uint16_t vendor_id, std::uint16_t product_id,
                                           const std::filesystem::path& sys, const std::filesystem::path& dev) {
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(sys / "bus/usb/devices", error)) {
    const auto vendor = read_number(entry.path() / "idVendor", 16);
    const auto product = read_number(entry.path() / "idProduct", 16);
    if (!vendor || !product || *vendor != vendor_id || *product != product_id) continue;
    const auto bus = read_number(entry.path() / "busnum", 10);
    const auto device = read_number(entry.path() / "devnum", 10);
    if (!bus || !device) continue;
    return dev / "bus/usb" / fmt::format("{:03}", *bus) / fmt::format("{:03}", *device);
  }
  return {};
}

std::filesystem::path find_hidraw_node(std::uint16_t vendor_id, std::uint16_t product_id,
                                       const std::filesystem::path& sys, const std::filesystem::path& dev) {
  // HID_ID=<bus>:<vendor, 8 hex digits>:<product, 8 hex digits>
  const std::string wanted = fmt::format(":{:08X}:{:08X}", vendor_id, product_id);
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(sys / "class/hidraw", error)) {
    std::ifstream uevent(entry.path() / "device/uevent");
    for (std::string line; std::getline(uevent, line);) {
      if (line.rfind("HID_ID=", 0) != 0) continue;
      std::string id = line.substr(7);
      for (auto& c : id) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      if (id.size() >= wanted.size() && id.compare(id.size() - wanted.size(), wanted.size(), wanted) == 0)
        return dev / entry.path().filename();
    }
  }
  return {};
}

bool device_node_usable(const std::filesystem::path& node) {
  struct stat info {};
  if (stat(node.c_str(), &info) != 0) return false;
  if (geteuid() != 0) return access(node.c_str(), R_OK | W_OK) == 0;
  constexpr mode_t group_rw = S_IRGRP | S_IWGRP, others_rw = S_IROTH | S_IWOTH;
  return (info.st_mode & group_rw) == group_rw || (info.st_mode & others_rw) == others_rw;
}

}  // namespace chromo::daemon
