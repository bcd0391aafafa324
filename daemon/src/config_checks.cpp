// The configuration's checks of final values: see config_checks.hpp.
#include "config_checks.hpp"

#include <netdb.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <fstream>
#include <vector>

#include "chromo/calibration/led_library_io.hpp"
#include "chromo/daemon/config.hpp"
#include "chromo/session/surface_factors.hpp"
#include "chromo/spectral/camera.hpp"

namespace chromo::daemon::config_checks {

namespace fs = std::filesystem;

std::string regular_file_error(const fs::path& path) {
  std::error_code error;
  const auto status = fs::status(path, error);
  if (error || !fs::exists(status)) return path.string() + ": no such file";
  if (!fs::is_regular_file(status)) return path.string() + ": not a regular file";
  if (::access(path.c_str(), R_OK) != 0) return path.string() + ": cannot be read (permissions)";
  return {};
}

// A folder chromod may create files in: an existing writable folder, or one
// that can be created (its nearest existing ancestor is a writable folder).
std::string folder_error(const fs::path& folder) {
  if (folder.empty()) return "empty path";
  fs::path at = folder;
  std::error_code error;
  while (true) {
    const auto status = fs::status(at, error);
    if (fs::exists(status)) {
      if (!fs::is_directory(status))
        return at == folder ? folder.string() + ": exists and is not a folder"
                            : folder.string() + ": cannot be created (" + at.string() + " is not a folder)";
      if (::access(at.c_str(), W_OK | X_OK) != 0)
        return at == folder ? folder.string() + ": not writable"
                            : folder.string() + ": cannot be created (" + at.string() + " is not writable)";
      return {};
    }
    if (!at.has_parent_path() || at.parent_path() == at) {
      at = ".";
      continue;
    }
    at = at.parent_path();
  }
}

// folder_error, and for a folder that does not exist yet, whether it can
// really be made: it is created and removed again (only what was created).
std::string folder_error_tried(const fs::path& folder) {
  if (auto error = folder_error(folder); !error.empty()) return error;
  std::error_code error;
  if (fs::exists(folder, error)) return {};
  std::vector<fs::path> made;
  for (fs::path at = folder; !at.empty() && !fs::exists(at, error); at = at.parent_path()) {
    made.push_back(at);
    if (at.parent_path() == at) break;
  }
  fs::create_directories(folder, error);
  std::string problem = error ? folder.string() + ": cannot be created (" + error.message() + ")" : std::string();
  for (const auto& path : made) fs::remove(path, error);  // deepest first; only empty folders we made
  return problem;
}

namespace {

// -1: nothing there; 0: a socket nobody listens on; 1: a socket in use; 2: not a socket.
int socket_file_state(const std::string& path) {
  std::error_code error;
  const auto status = fs::symlink_status(path, error);
  if (error || !fs::exists(status)) return -1;
  if (!fs::is_socket(status)) return 2;
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return 1;
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  path.copy(address.sun_path, sizeof address.sun_path - 1);
  const bool listening = ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
  ::close(fd);
  return listening ? 1 : 0;
}

}  // namespace

std::string unix_socket_error(const std::string& path) {
  if (path.empty()) return {};
  if (path.size() >= sizeof(sockaddr_un{}.sun_path))
    return path + ": longer than a Unix socket path may be (" + std::to_string(sizeof(sockaddr_un{}.sun_path) - 1) +
           " bytes)";
  switch (socket_file_state(path)) {
    case 2: return path + ": a file that is not a socket is there (chromod never deletes a file it did not create)";
    case 1: return path + ": another process is listening on it";
    default: break;
  }
  const fs::path parent = fs::path(path).parent_path();
  if (const auto error = folder_error_tried(parent.empty() ? fs::path(".") : parent); !error.empty()) return error;
  return {};
}

std::string tcp_address_error(const std::string& address) {
  if (address.empty()) return {};
  const auto colon = address.rfind(':');
  if (colon == std::string::npos) return "\"" + address + "\" is not host:port";
  std::string host = address.substr(0, colon);
  const std::string port = address.substr(colon + 1);
  if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
      std::stoul(port) > 65535)
    return "\"" + address + "\": the port must be a number in [0, 65535] (0: any free port)";
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  if (host.empty()) return "\"" + address + "\": missing the host (e.g. 0.0.0.0, 127.0.0.1, [::1])";
  // Numeric addresses only (and localhost): a check that looked a name up
  // would send a DNS query from a configuration check.
  if (host == "localhost") return {};
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICHOST;
  addrinfo* found = nullptr;
  const int status = ::getaddrinfo(host.c_str(), port.c_str(), &hints, &found);
  if (found) ::freeaddrinfo(found);
  if (status != 0) return "\"" + address + "\": the host \"" + host + "\" is not a numeric IPv4 or [IPv6] address or localhost (" +
           gai_strerror(status) + ")";
  return {};
}

std::string pem_file_error(const std::string& path) {
  if (path.empty()) return {};
  if (auto error = regular_file_error(path); !error.empty()) return error;
  std::ifstream in(path);
  std::string line;
  for (int i = 0; i < 64 && std::getline(in, line); ++i)
    if (line.rfind("-----BEGIN ", 0) == 0) return {};
  return path + ": not a PEM file (no -----BEGIN line)";
}

std::string led_library_error(const std::string& path) {
  if (path.empty()) return {};
  if (auto error = regular_file_error(path); !error.empty()) return error;
  try {
    calibration::load_led_library(path);
  } catch (const std::exception& error) {
    return path + ": not an LED library (" + error.what() + ")";
  }
  return {};
}

std::string camera_sensitivity_error(const std::string& source) {
  try {
    if (source.rfind("builtin:", 0) == 0) {
      spectral::builtin_camera(source.substr(8));
      return {};
    }
    if (auto error = regular_file_error(source); !error.empty()) return error;
    spectral::read_camera_sensitivity(source);
  } catch (const std::exception& error) {
    return source + ": " + error.what();
  }
  return {};
}

std::string films_error(const std::string& source) {
  if (source.empty() || source == kVirtualLabFilms) return {};
  if (auto error = regular_file_error(source); !error.empty()) return error;
  try {
    session::surface_factors_of_extinction_file(source);
  } catch (const std::exception& error) {
    return error.what();
  }
  return {};
}

std::string optional_folder(const std::string& path) { return path.empty() ? std::string() : folder_error_tried(path); }

// A folder that must exist already (never created): the web view's files.
std::string optional_existing_folder(const std::string& path) {
  if (path.empty()) return {};
  std::error_code error;
  if (!fs::is_directory(path, error)) return path + ": not an existing folder";
  return {};
}

}  // namespace chromo::daemon::config_checks
