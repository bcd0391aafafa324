// The simulator's Modbus front-end. Its register encoding and decoding are its
// own (never the driver's); only the addresses come from led_modbus_map.hpp.

#include "chromo/simulators/leds/modbus_led_server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <vector>

#include "chromo/drivers/led/led_modbus_map.hpp"
#include "device_polarisation_word.hpp"

namespace chromo::simulators {

namespace map = drivers::led_modbus;

struct ModbusLedServer::Impl {
  modbus_t* ctx = nullptr;
  modbus_mapping_t* mapping = nullptr;
  int listen_fd = -1;
  int master_fd = -1;
  int slave_fd = -1;  // held open so that the master never sees a hang-up
  int stop_pipe[2] = {-1, -1};
  std::vector<int> clients;
  std::uint16_t last_command_sequence = 0;
  std::uint16_t ack_sequence = 0;
  std::uint16_t result = map::kResultOk;

  ~Impl() {
    for (int fd : clients) ::close(fd);
    if (listen_fd >= 0) ::close(listen_fd);
    if (slave_fd >= 0) ::close(slave_fd);
    if (master_fd >= 0) ::close(master_fd);
    for (int fd : stop_pipe)
      if (fd >= 0) ::close(fd);
    if (mapping) modbus_mapping_free(mapping);
    if (ctx) modbus_free(ctx);  // sockets are closed above, not by libmodbus
  }
};

namespace {

[[noreturn]] void fail(const std::string& what) {
  throw std::runtime_error("Modbus LED simulator: " + what + ": " + std::strerror(errno));
}

// The output-enable coil's value in a write that libmodbus will accept
// (0x05: value 0xFF00 or 0x0000; 0x0F: 1..0x7B0 coils, a matching byte
// count, within the coils), or nullopt when `pdu` (function code first)
// does not write that coil.
std::optional<bool> output_enable_written(const unsigned char* pdu, int length) {
  const auto word = [pdu](int at) { return static_cast<int>(pdu[at]) << 8 | pdu[at + 1]; };
  if (length >= 5 && pdu[0] == 0x05 && word(1) == map::kCoilOutputEnable) {
    if (word(3) == 0xFF00) return true;
    if (word(3) == 0x0000) return false;
    return std::nullopt;
  }
  if (length >= 6 && pdu[0] == 0x0F) {
    const int first = word(1), count = word(3), bytes = pdu[5];
    if (count < 1 || count > 0x7B0 || bytes != (count + 7) / 8 || length < 6 + bytes || first + count > map::kCoilCount)
      return std::nullopt;
    const int bit = map::kCoilOutputEnable - first;
    if (bit < 0 || bit >= count) return std::nullopt;
    return ((pdu[6 + bit / 8] >> (bit % 8)) & 1) != 0;
  }
  return std::nullopt;
}

void put_ascii(std::uint16_t* registers, int count, const std::string& text) {
  for (int i = 0; i < count; ++i) {
    auto byte = [&](std::size_t k) { return k < text.size() ? static_cast<unsigned char>(text[k]) : 0u; };
    registers[i] = static_cast<std::uint16_t>(byte(2 * i) << 8 | byte(2 * i + 1));
  }
}

void put_u32(std::uint16_t* registers, double value) {
  auto v = static_cast<std::uint32_t>(std::lround(value));
  registers[0] = static_cast<std::uint16_t>(v >> 16);
  registers[1] = static_cast<std::uint16_t>(v & 0xFFFF);
}

// The device's reading of a state block: drive[6], zone, PWM high, PWM low,
// and the polarisation word (the staging block's 0x000E, or the table
// entry's tenth register); nullopt for a word the firmware refuses.
std::optional<drivers::LedState> read_state(const std::uint16_t* registers, std::uint16_t polarisation_word) {
  const auto polarisation = device_polarisation::read_word(polarisation_word);
  if (!polarisation) return std::nullopt;
  drivers::LedState state;
  state.polarisation = *polarisation;
  for (int i = 0; i < spectral::kLedTypeCount; ++i) state.drive[i] = registers[i] / 65535.0;
  if (registers[6] != map::kAllZones) state.zone = registers[6];
  state.pwm_frequency_hz = (std::uint32_t(registers[7]) << 16) | registers[8];
  return state;
}

std::uint16_t result_code(LabResult result) {
  switch (result) {
    case LabResult::kOk: return map::kResultOk;
    case LabResult::kOutOfRange: return map::kResultOutOfRange;
    case LabResult::kBadState: return map::kResultBadState;
    case LabResult::kFault: return map::kResultFault;
    case LabResult::kBadPolarisation: return map::kResultBadPolarisation;
  }
  return map::kResultBadState;
}

}  // namespace

ModbusLedServer::ModbusLedServer(LedLab& lab) : lab_(lab), impl_(std::make_unique<Impl>()) {
  impl_->mapping = modbus_mapping_new(map::kCoilCount, 0, map::kHoldRegisterCount, map::kInputRegisterCount);
  if (!impl_->mapping) fail("modbus_mapping_new");
  if (::pipe(impl_->stop_pipe) != 0) fail("pipe");
  drivers::LedControllerInfo info = lab_.info();
  std::uint16_t* in = impl_->mapping->tab_input_registers;
  in[map::kInProtocolVersion] = map::kProtocolVersion;
  in[map::kInDriveMode] = info.drive_mode == drivers::DriveMode::kPwmDuty ? 0 : 1;
  in[map::kInZoneCount] = static_cast<std::uint16_t>(info.zone_count);
  in[map::kInSequenceCapacity] = static_cast<std::uint16_t>(std::min(info.sequence_capacity, map::kMaxSequenceStates));
  put_u32(&in[map::kInMinPwmHzHigh], info.min_pwm_frequency_hz);
  put_u32(&in[map::kInMaxPwmHzHigh], info.max_pwm_frequency_hz);
  in[map::kInFirmwareVersion] =
      static_cast<std::uint16_t>(lab_.options().firmware_major << 8 | lab_.options().firmware_minor);
  put_ascii(&in[map::kInSerial], 8, info.serial);
  put_ascii(&in[map::kInModel], 8, info.model);
  in[map::kInPolariserBanks] = device_polarisation::bank_mask(info.polariser_banks);
  impl_->mapping->tab_registers[map::kHoldZone] = map::kAllZones;
}

ModbusLedServer::~ModbusLedServer() {
  if (thread_.joinable()) {
    char byte = 0;
    [[maybe_unused]] auto written = ::write(impl_->stop_pipe[1], &byte, 1);
    thread_.join();
  }
}

std::unique_ptr<ModbusLedServer> ModbusLedServer::start_tcp(LedLab& lab, int port, int unit_id,
                                                             const std::string& address) {
  std::unique_ptr<ModbusLedServer> server(new ModbusLedServer(lab));
  Impl& impl = *server->impl_;
  server->unit_id_ = unit_id;
  server->host_ = address;
  impl.ctx = modbus_new_tcp(address.c_str(), port);
  if (!impl.ctx) fail("modbus_new_tcp");
  modbus_set_slave(impl.ctx, unit_id);
  impl.listen_fd = modbus_tcp_listen(impl.ctx, 8);
  if (impl.listen_fd < 0) fail("listen on " + address + ":" + std::to_string(port));
  sockaddr_in bound{};
  socklen_t length = sizeof bound;
  if (::getsockname(impl.listen_fd, reinterpret_cast<sockaddr*>(&bound), &length) != 0) fail("getsockname");
  server->port_ = ntohs(bound.sin_port);
  server->thread_ = std::thread([s = server.get()] { s->serve_tcp(); });
  return server;
}

std::unique_ptr<ModbusLedServer> ModbusLedServer::start_rtu(LedLab& lab, int unit_id) {
  std::unique_ptr<ModbusLedServer> server(new ModbusLedServer(lab));
  Impl& impl = *server->impl_;
  server->unit_id_ = unit_id;
  impl.master_fd = ::posix_openpt(O_RDWR | O_NOCTTY);
  if (impl.master_fd < 0) fail("posix_openpt");
  if (::grantpt(impl.master_fd) != 0 || ::unlockpt(impl.master_fd) != 0) fail("grantpt/unlockpt");
  const char* name = ::ptsname(impl.master_fd);
  if (!name) fail("ptsname");
  server->device_path_ = name;
  impl.slave_fd = ::open(name, O_RDWR | O_NOCTTY);
  if (impl.slave_fd < 0) fail("open " + server->device_path_);
  termios raw{};
  if (::tcgetattr(impl.slave_fd, &raw) != 0) fail("tcgetattr");
  ::cfmakeraw(&raw);
  if (::tcsetattr(impl.slave_fd, TCSANOW, &raw) != 0) fail("tcsetattr");
  impl.ctx = modbus_new_rtu(name, 115200, 'N', 8, 1);
  if (!impl.ctx) fail("modbus_new_rtu");
  modbus_set_slave(impl.ctx, unit_id);
  modbus_set_socket(impl.ctx, impl.master_fd);  // serve on the master side without modbus_connect
  server->thread_ = std::thread([s = server.get()] { s->serve_rtu(); });
  return server;
}

std::string ModbusLedServer::address() const {
  return port_ ? "tcp://" + host_ + ":" + std::to_string(port_) : "rtu://" + device_path_;
}

void ModbusLedServer::serve_tcp() {
  Impl& impl = *impl_;
  std::vector<unsigned char> query(MODBUS_TCP_MAX_ADU_LENGTH);
  for (;;) {
    std::vector<pollfd> fds{{impl.stop_pipe[0], POLLIN, 0}, {impl.listen_fd, POLLIN, 0}};
    for (int fd : impl.clients) fds.push_back({fd, POLLIN, 0});
    if (::poll(fds.data(), fds.size(), -1) < 0) {
      if (errno == EINTR) continue;
      return;
    }
    if (fds[0].revents) return;
    if (fds[1].revents & POLLIN) {
      int listen_fd = impl.listen_fd;
      int client = modbus_tcp_accept(impl.ctx, &listen_fd);
      if (client >= 0) impl.clients.push_back(client);
    }
    for (std::size_t k = 2; k < fds.size(); ++k) {
      if (!fds[k].revents) continue;
      modbus_set_socket(impl.ctx, fds[k].fd);
      int length = modbus_receive(impl.ctx, query.data());
      if (length > 0) {
        handle_request(query.data(), length);
      } else if (length < 0) {  // closed by the client, or garbage: drop the connection
        ::close(fds[k].fd);
        std::erase(impl.clients, fds[k].fd);
      }
    }
  }
}

void ModbusLedServer::serve_rtu() {
  Impl& impl = *impl_;
  std::vector<unsigned char> query(MODBUS_RTU_MAX_ADU_LENGTH);
  for (;;) {
    pollfd fds[2] = {{impl.stop_pipe[0], POLLIN, 0}, {impl.master_fd, POLLIN, 0}};
    if (::poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      return;
    }
    if (fds[0].revents) return;
    if (!(fds[1].revents & POLLIN)) {
      ::usleep(10000);  // a hang-up with no reader: wait for the next open
      continue;
    }
    int length = modbus_receive(impl.ctx, query.data());
    if (length > 0) handle_request(query.data(), length);
    // length 0: addressed to another unit; -1: bad CRC or a partial frame, already flushed
  }
}

void ModbusLedServer::handle_request(const unsigned char* query, int length) {
  Impl& impl = *impl_;
  if (lab_.unresponsive()) {
    ++dropped_;
    return;
  }
  std::uint16_t* in = impl.mapping->tab_input_registers;
  drivers::LedStatus status = lab_.status();
  for (int i = 0; i < spectral::kLedTypeCount; ++i) {
    in[map::kInAppliedDrive0 + i] = static_cast<std::uint16_t>(std::lround(status.applied.drive[i] * 65535.0));
    in[map::kInTemperature0 + i] =
        static_cast<std::uint16_t>(static_cast<std::int16_t>(std::lround(status.temperature_C[i] * 100.0)));
    in[map::kInChannelFaults0 + i] = static_cast<std::uint16_t>(status.channel_faults[i]);
  }
  in[map::kInAppliedZone] = status.applied.zone ? static_cast<std::uint16_t>(*status.applied.zone) : map::kAllZones;
  put_u32(&in[map::kInAppliedPwmHzHigh], status.applied.pwm_frequency_hz);
  in[map::kInAckSequence] = impl.ack_sequence;
  in[map::kInSequencePosition] =
      status.sequence_position < 0 ? 0xFFFF : static_cast<std::uint16_t>(status.sequence_position);
  in[map::kInControllerFaults] = static_cast<std::uint16_t>(status.controller_faults);
  in[map::kInCommandResult] = impl.result;
  put_u32(&in[map::kInTriggerPulsesHigh], status.trigger_pulses);
  in[map::kInAppliedPolarisation] = device_polarisation::write_word(status.applied.polarisation);
  impl.mapping->tab_bits[map::kCoilOutputEnable] = status.output_enabled ? 1 : 0;

  // A device answers a coil write once the coil is set (the driver goes on
  // to trigger the camera on that answer): the output enable takes effect
  // before the reply, not after it.
  const int header = modbus_get_header_length(impl.ctx);
  if (const std::optional<bool> enable = output_enable_written(query + header, length - header)) lab_.set_output_enabled(*enable);
  if (modbus_reply(impl.ctx, query, length, impl.mapping) < 0) return;
  ++answered_;

  int function = query[header];
  const std::uint16_t* hold = impl.mapping->tab_registers;
  if ((function == 0x06 || function == 0x10) && hold[map::kHoldCommandSequence] != impl.last_command_sequence) {
    impl.last_command_sequence = hold[map::kHoldCommandSequence];
    LabResult result = LabResult::kOk;
    switch (hold[map::kHoldCommandCode]) {
      case map::kCommandApplyState: {
        const std::optional<drivers::LedState> state = read_state(hold, hold[map::kHoldPolarisation]);
        result = state ? lab_.apply(*state) : LabResult::kBadPolarisation;
        break;
      }
      case map::kCommandArmSequence: {
        int count = hold[map::kHoldSequenceLength];
        int trigger = hold[map::kHoldSequenceTrigger];
        if (count < 1 || count > map::kMaxSequenceStates || trigger > map::kTriggerOwnOutput) {
          result = LabResult::kOutOfRange;
          break;
        }
        std::vector<drivers::LedState> states;
        for (int k = 0; k < count; ++k) {
          const std::uint16_t* entry = &hold[map::kHoldSequenceTable + k * map::kSequenceStride];
          const std::optional<drivers::LedState> state = read_state(entry, entry[map::kSequencePolarisationOffset]);
          if (!state) break;
          states.push_back(*state);
        }
        if (static_cast<int>(states.size()) < count) {
          result = LabResult::kBadPolarisation;
          break;
        }
        result = lab_.arm(states, trigger == map::kTriggerHardwareEdge ? drivers::SequenceTrigger::kHardwareRisingEdge
                                  : trigger == map::kTriggerSoftware     ? drivers::SequenceTrigger::kSoftware
                                                                         : drivers::SequenceTrigger::kTriggerOutput);
        break;
      }
      case map::kCommandFireTrigger: {
        std::uint32_t pulse = 0;
        result = lab_.fire_trigger_output(hold[map::kHoldTriggerPulseWidthUs], &pulse);
        break;
      }
      case map::kCommandAdvance: result = lab_.advance(); break;
      case map::kCommandDisarm: lab_.disarm(); break;
      default:
        impl.ack_sequence = impl.last_command_sequence;
        impl.result = map::kResultUnknownCommand;
        return;
    }
    impl.ack_sequence = impl.last_command_sequence;
    impl.result = result_code(result);
  }
}

}  // namespace chromo::simulators
