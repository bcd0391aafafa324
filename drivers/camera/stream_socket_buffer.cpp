#include "stream_socket_buffer.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <climits>
#include <filesystem>
#include <string>
#include <system_error>

namespace chromo::drivers::detail {

namespace {

bool is_udp_socket_on_port(int fd, std::uint16_t local_port) {
  int type = 0;
  socklen_t length = sizeof type;
  if (getsockopt(fd, SOL_SOCKET, SO_TYPE, &type, &length) != 0 || type != SOCK_DGRAM) return false;
  sockaddr_storage address{};
  length = sizeof address;
  if (getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0) return false;
  if (address.ss_family == AF_INET) return ntohs(reinterpret_cast<const sockaddr_in&>(address).sin_port) == local_port;
  if (address.ss_family == AF_INET6)
    return ntohs(reinterpret_cast<const sockaddr_in6&>(address).sin6_port) == local_port;
  return false;
}

}  // namespace

std::size_t size_udp_receive_buffer(std::uint16_t local_port, std::size_t buffer_bytes) {
  if (local_port == 0) return 0;
  const int requested = buffer_bytes > static_cast<std::size_t>(INT_MAX) ? INT_MAX : static_cast<int>(buffer_bytes);
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator("/proc/self/fd", error)) {
    int fd = -1;
    try {
      fd = std::stoi(entry.path().filename().string());
    } catch (const std::exception&) {
      continue;
    }
    std::error_code link_error;
    const std::string target = std::filesystem::read_symlink(entry.path(), link_error).string();
    if (link_error || target.rfind("socket:", 0) != 0 || !is_udp_socket_on_port(fd, local_port)) continue;
    if (setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &requested, sizeof requested) != 0) return 0;
    int applied = 0;
    socklen_t length = sizeof applied;
    if (getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &applied, &length) != 0) return 0;
    return static_cast<std::size_t>(applied);
  }
  return 0;
}

}  // namespace chromo::drivers::detail
