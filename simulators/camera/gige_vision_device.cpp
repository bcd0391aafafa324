// GigeVisionDevice: see gige_vision_device.hpp for the contract and
// docs/protocols/gige-vision.md for the register map.
#include "chromo/simulators/camera/gige_vision_device.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <deque>
#include <optional>
#include <random>
#include <stdexcept>
#include <thread>

#include "gige_protocol.hpp"
#include "gvsp_transmission.hpp"

namespace chromo::simulators {
namespace {

using namespace gige;
using Clock = std::chrono::steady_clock;

constexpr std::uint32_t kXmlAddress = 0x100000;     // the GenICam text in device memory
constexpr std::uint32_t kAutoSubnet = 0x7F4D0000;   // 127.77.0.0/16: automatic addresses
constexpr std::uint16_t kDefaultPacketSize = 1400;
constexpr std::uint32_t kMinPacketSize = 576, kMaxPacketSize = 16000;

bool is_loopback(std::uint32_t host_order_ip) { return (host_order_ip >> 24) == 127; }

std::optional<std::uint32_t> parse_loopback(const std::string& text) {
  in_addr parsed{};
  if (inet_pton(AF_INET, text.c_str(), &parsed) != 1) return std::nullopt;
  const std::uint32_t ip = ntohl(parsed.s_addr);
  if (!is_loopback(ip)) return std::nullopt;
  return ip;
}

std::string ip_text(std::uint32_t host_order_ip) {
  in_addr a{};
  a.s_addr = htonl(host_order_ip);
  char text[INET_ADDRSTRLEN] = {};
  inet_ntop(AF_INET, &a, text, sizeof text);
  return text;
}

sockaddr_in socket_address(std::uint32_t ip, std::uint16_t port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(ip);
  a.sin_port = htons(port);
  return a;
}

}  // namespace

bool GvspFaultOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  const std::pair<const char*, double> probabilities[] = {
      {"loss_probability", loss_probability},
      {"reorder_probability", reorder_probability},
      {"delay_probability", delay_probability}};
  for (const auto& [name, p] : probabilities)
    if (!(p >= 0 && p <= 0.5)) return fail(std::string(name) + " must be in [0, 0.5]");
  if (delay_us < 0 || delay_us > 1000000) return fail("delay_us must be in [0, 1000000]");
  if (delay_probability > 0 && delay_us == 0) return fail("delay_probability > 0 needs delay_us > 0");
  return true;
}

bool GigeVisionDeviceOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (!address.empty() && !parse_loopback(address))
    return fail("address \"" + address.substr(0, 40) + "\" is not an IPv4 address in 127.0.0.0/8");
  if (serial.empty() || serial.size() > 15) return fail("serial must be 1-15 characters");
  if (user_name.size() > 15) return fail("user_name must be 0-15 characters");
  if (manufacturer.size() > 31 || model.size() > 31 || device_version.size() > 31)
    return fail("manufacturer, model and device_version must be at most 31 characters");
  if (genicam_xml.empty()) return fail("genicam_xml is required");
  if (camera_register_base < bootstrap::kEnd || camera_register_base % 4 != 0 || camera_register_count == 0 ||
      camera_register_count > 4096 || camera_register_base + 4 * camera_register_count > kXmlAddress)
    return fail("camera registers must lie, 4-byte aligned, between 0x10000 and 0x100000");
  if (retained_blocks < 1 || retained_blocks > 64) return fail("retained_blocks must be 1-64");
  if (first_block_id == 0) return fail("first_block_id must be 1-65535 (0 is not a block id)");
  return faults.IsValid(error);
}

struct GigeVisionDevice::Impl {
  GigeVisionDeviceOptions options;
  std::uint32_t ip = 0;  // host order, chosen on the first start()
  std::vector<std::uint8_t> xml;  // padded to 4 bytes

  mutable std::mutex mutex;  // registers, privilege, hooks, retained blocks, faults
  std::vector<std::uint8_t> bootstrap_memory = std::vector<std::uint8_t>(bootstrap::kEnd, 0);
  std::vector<std::uint32_t> camera_registers;
  std::optional<sockaddr_in> controller;
  Clock::time_point controller_seen;
  WriteHook write_hook;
  std::function<void()> on_control_lost;
  std::deque<std::shared_ptr<const GvspBlock>> retained;
  std::uint16_t next_block_id = 1;
  GvspFaultOptions faults;
  std::mt19937_64 dice;

  int gvcp_socket = -1, gvsp_socket = -1;
  // Bound to 255.255.255.255:3956 (shared by every device of this machine):
  // broadcast discovery from loopback peers, answered from gvcp_socket. -1 when
  // that bind failed (the device then answers unicast discovery only).
  int discovery_socket = -1;
  std::uint16_t gvsp_port = 0;
  std::thread gvcp_thread;
  std::atomic<bool> stopping{false};
  std::atomic<bool> is_running{false};
  Clock::time_point clock_zero = Clock::now();
  std::mutex send_mutex;  // one send_block at a time

  struct AtomicCounters {
    std::atomic<std::uint64_t> gvcp_commands{0}, gvcp_error_acks{0}, gvcp_ignored{0}, blocks_sent{0},
        packets_sent{0}, packets_dropped{0}, packets_delayed{0}, packets_reordered{0}, resend_requests{0},
        resend_requests_answered{0}, resend_requests_unavailable{0}, packets_resent{0}, control_lost{0};
  } counters;

  std::uint32_t reg(std::uint32_t address) const { return get32(&bootstrap_memory[address]); }
  void set_reg(std::uint32_t address, std::uint32_t value) { put32(&bootstrap_memory[address], value); }
  void set_text(std::uint32_t address, std::size_t size, const std::string& text) {
    std::fill_n(&bootstrap_memory[address], size, 0);
    std::memcpy(&bootstrap_memory[address], text.data(), std::min(text.size(), size - 1));
  }

  void power_on_registers() {
    std::fill(bootstrap_memory.begin(), bootstrap_memory.end(), 0);
    set_reg(bootstrap::kVersion, 2u << 16);  // GigE Vision 2.0
    set_reg(bootstrap::kDeviceMode, 1u << 31 | 1);  // big-endian, UTF-8
    // Locally administered MAC from the address: 02:00:7f:a:b:c.
    set_reg(bootstrap::kMacHigh, 0x0200);
    set_reg(bootstrap::kMacLow, ip);
    set_reg(bootstrap::kSupportedIpConfig, 1u << 0);
    set_reg(bootstrap::kCurrentIpConfig, 1u << 0);
    set_reg(bootstrap::kCurrentIp, ip);
    set_reg(bootstrap::kCurrentSubnetMask, 0xFF000000u);
    set_reg(bootstrap::kCurrentGateway, 0);
    set_text(bootstrap::kManufacturerName, 32, options.manufacturer);
    set_text(bootstrap::kModelName, 32, options.model);
    set_text(bootstrap::kDeviceVersion, 32, options.device_version);
    set_text(bootstrap::kManufacturerInfo, 48, "Chromosphere virtual lab");
    set_text(bootstrap::kSerialNumber, 16, options.serial);
    set_text(bootstrap::kUserDefinedName, 16, options.user_name);
    const std::string url = "Local:chromo-camera.xml;" + to_hex(kXmlAddress) + ";" + to_hex(xml.size());
    set_text(bootstrap::kXmlUrl0, 512, url);
    set_text(bootstrap::kXmlUrl1, 512, url);
    set_reg(bootstrap::kNetworkInterfaces, 1);
    set_reg(bootstrap::kMessageChannels, 0);
    set_reg(bootstrap::kStreamChannels, 1);
    set_reg(bootstrap::kGvcpCapability, bootstrap::kCapabilityWriteMemory | bootstrap::kCapabilityPacketResend |
                                            bootstrap::kCapabilityUserDefinedName |
                                            bootstrap::kCapabilitySerialNumber);
    set_reg(bootstrap::kHeartbeatTimeout, 3000);
    set_reg(bootstrap::kTickFrequencyHigh, 0);
    set_reg(bootstrap::kTickFrequencyLow, 1000000000u);
    set_reg(bootstrap::kStreamPacketSize, kDefaultPacketSize);
    set_reg(bootstrap::kStreamSourcePort, gvsp_port);
    controller.reset();
    retained.clear();
    next_block_id = options.first_block_id;
  }

  static std::string to_hex(std::size_t value) {
    char text[24];
    std::snprintf(text, sizeof text, "%zx", value);
    return text;
  }

  // --- sockets ---

  static int udp_socket() {
    const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd < 0) throw std::runtime_error(std::string("GigE Vision device: socket(): ") + std::strerror(errno));
    return fd;
  }

  // Binds the GVCP socket on ip:3956; false when the address is taken.
  bool bind_gvcp(std::uint32_t candidate) {
    const int fd = udp_socket();
    const sockaddr_in at = socket_address(candidate, kGvcpPort);
    if (::bind(fd, reinterpret_cast<const sockaddr*>(&at), sizeof at) != 0) {
      const int error = errno;
      ::close(fd);
      if (error == EADDRINUSE) return false;
      throw std::runtime_error("GigE Vision device: cannot bind " + ip_text(candidate) + ":3956: " +
                               std::strerror(error));
    }
    gvcp_socket = fd;
    ip = candidate;
    return true;
  }

  void open_sockets() {
    if (ip != 0) {
      if (!bind_gvcp(ip))
        throw std::runtime_error("GigE Vision device: " + ip_text(ip) + ":3956 is taken (another device there?)");
    } else if (!options.address.empty()) {
      const std::uint32_t wanted = *parse_loopback(options.address);
      if (!bind_gvcp(wanted))
        throw std::runtime_error("GigE Vision device: " + options.address +
                                 ":3956 is taken (another camera simulator on this address?)");
    } else {
      std::random_device entropy;
      std::mt19937 pick(entropy());
      std::uniform_int_distribution<std::uint32_t> host(1, 0xFFFE);
      bool bound = false;
      for (int attempt = 0; attempt < 64 && !bound; ++attempt) bound = bind_gvcp(kAutoSubnet | host(pick));
      if (!bound)
        throw std::runtime_error("GigE Vision device: no free address in 127.77.0.0/16 after 64 attempts "
                                 "(is something bound to 0.0.0.0:3956?)");
    }
    gvsp_socket = udp_socket();
    const sockaddr_in at = socket_address(ip, 0);
    sockaddr_in bound{};
    socklen_t length = sizeof bound;
    const int send_buffer = 4 << 20;
    ::setsockopt(gvsp_socket, SOL_SOCKET, SO_SNDBUF, &send_buffer, sizeof send_buffer);
    if (::bind(gvsp_socket, reinterpret_cast<const sockaddr*>(&at), sizeof at) != 0 ||
        ::getsockname(gvsp_socket, reinterpret_cast<sockaddr*>(&bound), &length) != 0) {
      const int error = errno;
      close_sockets();
      throw std::runtime_error("GigE Vision device: cannot bind the stream socket on " + ip_text(ip) + ": " +
                               std::strerror(error));
    }
    gvsp_port = ntohs(bound.sin_port);
    open_discovery_socket();
  }

  // Aravis' discovery (arv_update_device_list, arv-test-0.8) broadcasts
  // DISCOVERY_CMD to 255.255.255.255:3956 from each interface's address; on
  // lo the kernel delivers it to sockets bound to the limited broadcast
  // address, which every device shares (SO_REUSEADDR).
  void open_discovery_socket() {
    const int fd = udp_socket();
    const int on = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
    const sockaddr_in at = socket_address(INADDR_BROADCAST, kGvcpPort);
    if (::bind(fd, reinterpret_cast<const sockaddr*>(&at), sizeof at) != 0) {
      ::close(fd);
      return;
    }
    discovery_socket = fd;
  }

  void close_sockets() {
    if (gvcp_socket >= 0) ::close(gvcp_socket);
    if (gvsp_socket >= 0) ::close(gvsp_socket);
    if (discovery_socket >= 0) ::close(discovery_socket);
    gvcp_socket = gvsp_socket = discovery_socket = -1;
  }

  void send_to(int fd, const std::vector<std::uint8_t>& datagram, const sockaddr_in& to) {
    if (!is_loopback(ntohl(to.sin_addr.s_addr))) return;  // never leaves 127.0.0.0/8
    ::sendto(fd, datagram.data(), datagram.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
  }

  // --- GVCP ---

  void gvcp_loop() {
    std::vector<std::uint8_t> datagram(2048);
    while (!stopping) {
      pollfd wait[2] = {{gvcp_socket, POLLIN, 0}, {discovery_socket, POLLIN, 0}};
      if (::poll(wait, discovery_socket >= 0 ? 2 : 1, 50) > 0) {
        for (int i = 0; i < 2; ++i) {
          if ((wait[i].revents & POLLIN) == 0) continue;
          sockaddr_in from{};
          socklen_t from_length = sizeof from;
          const ssize_t n = ::recvfrom(wait[i].fd, datagram.data(), datagram.size(), 0,
                                       reinterpret_cast<sockaddr*>(&from), &from_length);
          if (n <= 0) continue;
          if (i == 0) {
            handle_datagram(datagram.data(), static_cast<std::size_t>(n), from);
          } else if (is_broadcast_discovery(datagram.data(), static_cast<std::size_t>(n), from)) {
            handle_datagram(datagram.data(), static_cast<std::size_t>(n), from);
          } else {
            ++counters.gvcp_ignored;
          }
        }
      }
      check_heartbeat();
    }
  }

  // On the broadcast socket only DISCOVERY_CMD from a loopback peer is
  // answered (a LAN host's discovery reaches it too, and nothing is sent
  // outside 127.0.0.0/8).
  static bool is_broadcast_discovery(const std::uint8_t* p, std::size_t n, const sockaddr_in& from) {
    return n >= kGvcpHeaderBytes && p[0] == kCommandKey && get16(p + 2) == kDiscoveryCmd &&
           is_loopback(ntohl(from.sin_addr.s_addr));
  }

  void check_heartbeat() {
    std::function<void()> lost;
    {
      std::lock_guard lock(mutex);
      if (!controller) return;
      const auto timeout = std::chrono::milliseconds(reg(bootstrap::kHeartbeatTimeout));
      if (Clock::now() - controller_seen <= timeout) return;
      controller.reset();
      set_reg(bootstrap::kControlChannelPrivilege, 0);
      ++counters.control_lost;
      lost = on_control_lost;
    }
    if (lost) lost();
  }

  static bool same_peer(const sockaddr_in& a, const sockaddr_in& b) {
    return a.sin_addr.s_addr == b.sin_addr.s_addr && a.sin_port == b.sin_port;
  }

  void reply(std::uint16_t status, std::uint16_t ack_command, std::uint16_t request_id,
             const std::vector<std::uint8_t>& body, const sockaddr_in& to) {
    std::vector<std::uint8_t> out(kGvcpHeaderBytes + body.size());
    put16(&out[0], status);
    put16(&out[2], ack_command);
    put16(&out[4], static_cast<std::uint16_t>(body.size()));
    put16(&out[6], request_id);
    std::copy(body.begin(), body.end(), out.begin() + kGvcpHeaderBytes);
    if (status != kStatusSuccess) ++counters.gvcp_error_acks;
    send_to(gvcp_socket, out, to);
  }

  void handle_datagram(const std::uint8_t* p, std::size_t n, const sockaddr_in& from) {
    if (n < kGvcpHeaderBytes || p[0] != kCommandKey) {
      ++counters.gvcp_ignored;
      return;
    }
    const std::uint8_t flags = p[1];
    const std::uint16_t command = get16(p + 2);
    const std::size_t length = get16(p + 4);
    const std::uint16_t request_id = get16(p + 6);
    if (length > n - kGvcpHeaderBytes || length > kGvcpMaxDataBytes) {
      ++counters.gvcp_ignored;
      return;
    }
    ++counters.gvcp_commands;
    const std::uint8_t* data = p + kGvcpHeaderBytes;
    const bool ack = (flags & kFlagAckRequired) != 0;
    auto answer = [&](std::uint16_t status, std::uint16_t ack_command, const std::vector<std::uint8_t>& body) {
      if (ack || command == kDiscoveryCmd) reply(status, ack_command, request_id, body, from);
    };
    {
      std::lock_guard lock(mutex);
      if (controller && same_peer(*controller, from)) controller_seen = Clock::now();
    }
    switch (command) {
      case kDiscoveryCmd: {
        std::vector<std::uint8_t> body;
        {
          std::lock_guard lock(mutex);
          body.assign(bootstrap_memory.begin(), bootstrap_memory.begin() + bootstrap::kDiscoveryDataBytes);
        }
        answer(kStatusSuccess, kDiscoveryAck, body);
        return;
      }
      case kPacketResendCmd: handle_resend(flags, data, length); return;
      case kReadRegCmd: {
        if (length == 0 || length % 4 != 0) return answer(kStatusInvalidParameter, kReadRegAck, {});
        std::vector<std::uint8_t> body(length);
        std::lock_guard lock(mutex);
        for (std::size_t i = 0; i < length; i += 4) {
          std::uint32_t value = 0;
          const std::uint16_t status = read_register_locked(get32(data + i), &value);
          if (status != kStatusSuccess) return answer(status, kReadRegAck, {});
          put32(&body[i], value);
        }
        return answer(kStatusSuccess, kReadRegAck, body);
      }
      case kWriteRegCmd: {
        if (length == 0 || length % 8 != 0) return answer(kStatusInvalidParameter, kWriteRegAck, {0, 0, 0, 0});
        std::uint16_t written = 0;
        std::uint16_t status = kStatusSuccess;
        {
          std::lock_guard lock(mutex);
          for (std::size_t i = 0; i < length && status == kStatusSuccess; i += 8) {
            status = write_register_locked(get32(data + i), get32(data + i + 4), from);
            if (status == kStatusSuccess) ++written;
          }
        }
        std::vector<std::uint8_t> body(4, 0);
        put16(&body[2], written);
        return answer(status, kWriteRegAck, body);
      }
      case kReadMemCmd: {
        if (length < 8) return answer(kStatusInvalidParameter, kReadMemAck, {});
        const std::uint32_t address = get32(data);
        const std::uint32_t count = get16(data + 6);
        if (address % 4 != 0 || count % 4 != 0) return answer(kStatusBadAlignment, kReadMemAck, {});
        if (count == 0 || count > kMemoryAccessMaxBytes) return answer(kStatusInvalidParameter, kReadMemAck, {});
        std::vector<std::uint8_t> body(4 + count);
        put32(&body[0], address);
        std::lock_guard lock(mutex);
        const std::uint16_t status = read_memory_locked(address, count, &body[4]);
        if (status != kStatusSuccess) return answer(status, kReadMemAck, {});
        return answer(kStatusSuccess, kReadMemAck, body);
      }
      case kWriteMemCmd: {
        std::vector<std::uint8_t> body(4, 0);
        if (length < 8) return answer(kStatusInvalidParameter, kWriteMemAck, body);
        const std::uint32_t address = get32(data);
        const std::size_t count = length - 4;
        if (address % 4 != 0 || count % 4 != 0) return answer(kStatusBadAlignment, kWriteMemAck, body);
        if (count > kMemoryAccessMaxBytes) return answer(kStatusInvalidParameter, kWriteMemAck, body);
        std::uint16_t status = kStatusSuccess;
        std::uint16_t written = 0;
        {
          std::lock_guard lock(mutex);
          // Whole words, each through the register write path (its checks and hooks).
          for (std::size_t i = 0; i < count && status == kStatusSuccess; i += 4) {
            if (!writable_user_name(address + i)) {
              status = write_register_locked(static_cast<std::uint32_t>(address + i), get32(data + 4 + i), from);
            } else if (controller && !same_peer(*controller, from)) {
              status = kStatusAccessDenied;
            } else {
              std::memcpy(&bootstrap_memory[address + i], data + 4 + i, 4);
            }
            if (status == kStatusSuccess) written += 4;
          }
          if (writable_user_name(address)) bootstrap_memory[bootstrap::kUserDefinedName + 15] = 0;
        }
        put16(&body[2], written);
        return answer(status, kWriteMemAck, body);
      }
      default:
        answer(kStatusNotImplemented, static_cast<std::uint16_t>(command + 1), {});
    }
  }

  static bool writable_user_name(std::size_t address) {
    return address >= bootstrap::kUserDefinedName && address < bootstrap::kUserDefinedName + 16;
  }

  bool in_camera_block(std::uint32_t address) const {
    return address >= options.camera_register_base &&
           address < options.camera_register_base + 4 * options.camera_register_count;
  }

  std::uint16_t read_register_locked(std::uint32_t address, std::uint32_t* value) {
    if (address % 4 != 0) return kStatusBadAlignment;
    if (address < bootstrap::kEnd) {
      *value = reg(address);
      return kStatusSuccess;
    }
    if (in_camera_block(address)) {
      *value = camera_registers[(address - options.camera_register_base) / 4];
      return kStatusSuccess;
    }
    return kStatusInvalidAddress;
  }

  std::uint16_t read_memory_locked(std::uint32_t address, std::uint32_t count, std::uint8_t* out) {
    const std::uint64_t end = static_cast<std::uint64_t>(address) + count;
    if (end <= bootstrap::kEnd) {
      std::memcpy(out, &bootstrap_memory[address], count);
      return kStatusSuccess;
    }
    if (address >= kXmlAddress && end <= kXmlAddress + xml.size()) {
      std::memcpy(out, &xml[address - kXmlAddress], count);
      return kStatusSuccess;
    }
    if (in_camera_block(address) && in_camera_block(static_cast<std::uint32_t>(end - 4))) {
      for (std::uint32_t i = 0; i < count; i += 4)
        put32(out + i, camera_registers[(address + i - options.camera_register_base) / 4]);
      return kStatusSuccess;
    }
    return kStatusInvalidAddress;
  }

  std::uint16_t write_register_locked(std::uint32_t address, std::uint32_t value, const sockaddr_in& from) {
    if (address % 4 != 0) return kStatusBadAlignment;
    if (address == bootstrap::kControlChannelPrivilege) {
      if (controller && !same_peer(*controller, from)) return kStatusAccessDenied;
      if ((value & (bootstrap::kPrivilegeControl | bootstrap::kPrivilegeExclusive)) != 0) {
        controller = from;
        controller_seen = Clock::now();
      } else {
        controller.reset();
      }
      set_reg(address, value & (bootstrap::kPrivilegeControl | bootstrap::kPrivilegeExclusive));
      return kStatusSuccess;
    }
    if (controller && !same_peer(*controller, from)) return kStatusAccessDenied;
    if (in_camera_block(address)) {
      if (write_hook) {
        const RegisterReader read = [this](std::uint32_t at) {
          return in_camera_block(at) ? camera_registers[(at - options.camera_register_base) / 4] : 0u;
        };
        const std::uint16_t status = write_hook(address, value, read);
        if (status != kStatusSuccess) return status;
      }
      camera_registers[(address - options.camera_register_base) / 4] = value;
      return kStatusSuccess;
    }
    if (address >= bootstrap::kEnd) return kStatusInvalidAddress;
    switch (address) {
      case bootstrap::kHeartbeatTimeout:
        if (value < 500) return kStatusInvalidParameter;  // GigE Vision's minimum
        break;
      case bootstrap::kStreamPort: value &= 0xFFFF; break;
      case bootstrap::kStreamPacketSize: {
        const std::uint32_t size = value & 0xFFFF;
        if (size < kMinPacketSize || size > kMaxPacketSize) return kStatusInvalidParameter;
        value = size;  // fire-test and do-not-fragment bits are not kept (no test packet)
        break;
      }
      case bootstrap::kStreamPacketDelay: break;
      case bootstrap::kStreamDestination:
        if (value != 0 && !is_loopback(value)) return kStatusInvalidParameter;  // loopback only
        break;
      case bootstrap::kTimestampControl:
        if (value & 1u) clock_zero = Clock::now();
        if (value & 2u) {
          const std::uint64_t ticks = ticks_now();
          set_reg(bootstrap::kTimestampValueHigh, static_cast<std::uint32_t>(ticks >> 32));
          set_reg(bootstrap::kTimestampValueLow, static_cast<std::uint32_t>(ticks));
        }
        return kStatusSuccess;  // self-clearing
      default:
        if (writable_user_name(address)) break;
        return kStatusWriteProtect;
    }
    set_reg(address, value);
    return kStatusSuccess;
  }

  std::uint64_t ticks_now() const {
    return static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - clock_zero).count());
  }

  // --- GVSP ---

  void handle_resend(std::uint8_t flags, const std::uint8_t* data, std::size_t length) {
    ++counters.resend_requests;
    {
      std::lock_guard lock(mutex);
      if (!faults.answer_resend_requests) return;
    }
    std::uint64_t block_id = 0;
    std::uint32_t first = 0, last = 0;
    if ((flags & kFlagExtendedIds) != 0) {
      if (length < 20) return;
      first = get32(data + 4);
      last = get32(data + 8);
      block_id = static_cast<std::uint64_t>(get32(data + 12)) << 32 | get32(data + 16);
    } else {
      if (length < 12) return;
      block_id = get32(data) & 0xFFFF;
      first = get32(data + 4) & 0x00FFFFFF;
      last = get32(data + 8) & 0x00FFFFFF;
    }
    std::shared_ptr<const GvspBlock> block;
    sockaddr_in destination{};
    {
      std::lock_guard lock(mutex);
      for (const auto& kept : retained)
        if (kept->block_id == block_id) block = kept;
      if (!block) {
        // No longer kept: one PACKET_UNAVAILABLE packet to the current stream destination.
        destination = socket_address(reg(bootstrap::kStreamDestination),
                                     static_cast<std::uint16_t>(reg(bootstrap::kStreamPort)));
      }
    }
    if (!block) {
      ++counters.resend_requests_unavailable;
      if (destination.sin_port == 0 || block_id > 0xFFFF) return;
      send_to(gvsp_socket, gvsp_unavailable_packet(static_cast<std::uint16_t>(block_id), first), destination);
      ++counters.packets_sent;
      return;
    }
    ++counters.resend_requests_answered;
    last = std::min(last, block->last_packet_id());
    std::vector<std::uint8_t> packet;
    for (std::uint32_t id = first; id <= last; ++id) {
      build_gvsp_packet(*block, id, packet);
      send_to(gvsp_socket, packet, block->destination);
      ++counters.packets_sent;
      ++counters.packets_resent;
    }
  }

  bool send_block(const GvspImageBlock& image, std::uint16_t* block_id_out) {
    std::lock_guard send_lock(send_mutex);
    auto block = std::make_shared<GvspBlock>();
    GvspFaultOptions fault;
    {
      std::lock_guard lock(mutex);
      if (!is_running) return false;
      const std::uint32_t host = reg(bootstrap::kStreamDestination);
      const auto port = static_cast<std::uint16_t>(reg(bootstrap::kStreamPort));
      if (host == 0 || port == 0 || !is_loopback(host)) return false;
      block->destination = socket_address(host, port);
      block->block_id = next_block_id;
      next_block_id = next_block_id == 0xFFFF ? 1 : next_block_id + 1;
      block->image = image;
      block->data_bytes_per_packet = reg(bootstrap::kStreamPacketSize) - kIpUdpOverheadBytes - kGvspHeaderBytes;
      const std::size_t size = image.payload ? image.payload->size() : 0;
      block->payload_packets =
          static_cast<std::uint32_t>((size + block->data_bytes_per_packet - 1) / block->data_bytes_per_packet);
      retained.push_back(block);
      while (retained.size() > static_cast<std::size_t>(options.retained_blocks)) retained.pop_front();
      fault = faults;
    }
    if (!block->image.payload) block->image.payload = std::make_shared<const std::vector<std::uint8_t>>();
    if (block_id_out != nullptr) *block_id_out = block->block_id;

    std::uniform_real_distribution<double> uniform(0, 1);
    std::vector<std::uint8_t> packet;
    const TransmissionCounts faulted = transmit_with_faults(
        block->last_packet_id(), fault,
        [&] {
          std::lock_guard lock(mutex);
          return uniform(dice);
        },
        [&](std::uint32_t id) {
          build_gvsp_packet(*block, id, packet);
          send_to(gvsp_socket, packet, block->destination);
          ++counters.packets_sent;
        });
    counters.packets_dropped += faulted.dropped;
    counters.packets_delayed += faulted.delayed;
    counters.packets_reordered += faulted.reordered;
    ++counters.blocks_sent;
    return true;
  }
};

GigeVisionDevice::GigeVisionDevice(GigeVisionDeviceOptions options) : impl_(std::make_unique<Impl>()) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("GigeVisionDeviceOptions: " + error);
  impl_->options = std::move(options);
  impl_->xml.assign(impl_->options.genicam_xml.begin(), impl_->options.genicam_xml.end());
  impl_->xml.resize((impl_->xml.size() + 3) / 4 * 4, 0);
  impl_->camera_registers.assign(impl_->options.camera_register_count, 0);
  impl_->faults = impl_->options.faults;
  impl_->dice.seed(impl_->options.faults.seed);
}

GigeVisionDevice::~GigeVisionDevice() { stop(); }

void GigeVisionDevice::start() {
  if (impl_->is_running) return;
  impl_->open_sockets();
  {
    std::lock_guard lock(impl_->mutex);
    impl_->clock_zero = Clock::now();
    impl_->power_on_registers();
  }
  impl_->stopping = false;
  impl_->is_running = true;
  impl_->gvcp_thread = std::thread([impl = impl_.get()] { impl->gvcp_loop(); });
}

void GigeVisionDevice::stop() {
  if (!impl_->is_running) return;
  impl_->stopping = true;
  if (impl_->gvcp_thread.joinable()) impl_->gvcp_thread.join();
  std::lock_guard send_lock(impl_->send_mutex);
  impl_->is_running = false;
  impl_->close_sockets();
}

bool GigeVisionDevice::running() const { return impl_->is_running; }

std::string GigeVisionDevice::address() const { return impl_->ip == 0 ? std::string() : ip_text(impl_->ip); }

void GigeVisionDevice::set_write_hook(WriteHook hook) {
  std::lock_guard lock(impl_->mutex);
  impl_->write_hook = std::move(hook);
}

void GigeVisionDevice::set_on_control_lost(std::function<void()> callback) {
  std::lock_guard lock(impl_->mutex);
  impl_->on_control_lost = std::move(callback);
}

void GigeVisionDevice::set_faults(const GvspFaultOptions& faults) {
  std::string error;
  if (!faults.IsValid(&error)) throw std::invalid_argument("GvspFaultOptions: " + error);
  std::lock_guard lock(impl_->mutex);
  impl_->faults = faults;
  impl_->dice.seed(faults.seed);
}

std::uint32_t GigeVisionDevice::camera_register(std::uint32_t address) const {
  std::lock_guard lock(impl_->mutex);
  if (!impl_->in_camera_block(address) || address % 4 != 0)
    throw std::out_of_range("GigeVisionDevice::camera_register: not a camera register");
  return impl_->camera_registers[(address - impl_->options.camera_register_base) / 4];
}

void GigeVisionDevice::set_camera_register(std::uint32_t address, std::uint32_t value) {
  std::lock_guard lock(impl_->mutex);
  if (!impl_->in_camera_block(address) || address % 4 != 0)
    throw std::out_of_range("GigeVisionDevice::set_camera_register: not a camera register");
  impl_->camera_registers[(address - impl_->options.camera_register_base) / 4] = value;
}

bool GigeVisionDevice::send_block(const GvspImageBlock& block, std::uint16_t* block_id) {
  return impl_->send_block(block, block_id);
}

std::uint64_t GigeVisionDevice::now_ticks() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->ticks_now();
}

GigeVisionDeviceCounters GigeVisionDevice::counters() const {
  const auto& c = impl_->counters;
  GigeVisionDeviceCounters out;
  out.gvcp_commands = c.gvcp_commands;
  out.gvcp_error_acks = c.gvcp_error_acks;
  out.gvcp_ignored = c.gvcp_ignored;
  out.blocks_sent = c.blocks_sent;
  out.packets_sent = c.packets_sent;
  out.packets_dropped = c.packets_dropped;
  out.packets_delayed = c.packets_delayed;
  out.packets_reordered = c.packets_reordered;
  out.resend_requests = c.resend_requests;
  out.resend_requests_answered = c.resend_requests_answered;
  out.resend_requests_unavailable = c.resend_requests_unavailable;
  out.packets_resent = c.packets_resent;
  out.control_lost = c.control_lost;
  return out;
}

}  // namespace chromo::simulators
