// LED controller over Modbus TCP or RTU (libmodbus), register map in
// docs/protocols/led-modbus.md and led/led_modbus_map.hpp.
//
// Every command is one "write multiple registers" of the staging block ending
// with a fresh command sequence number; the device acts on it and publishes the
// sequence number and a result code in input registers, which the driver reads
// back: set_state returns only once the device has acknowledged that sequence.

#include <modbus/modbus.h>

#include <cerrno>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/led/led_modbus_map.hpp"
#include "chromo/drivers/led/modbus_registers.hpp"
#include "chromo/drivers/led_controller_factory.hpp"
#include "led_state_rules.hpp"
#include "polarisation_word.hpp"

namespace chromo::drivers {
namespace {

namespace map = led_modbus;
using Kind = DeviceError::Kind;

struct ModbusDeleter {
  void operator()(modbus_t* ctx) const {
    modbus_close(ctx);
    modbus_free(ctx);
  }
};
using ModbusPtr = std::unique_ptr<modbus_t, ModbusDeleter>;

Kind kind_of_errno(int error) {
  if (error == ETIMEDOUT) return Kind::kTimeout;
  if (error >= EMBXILFUN && error <= EMBXGTAR) return Kind::kRefused;  // Modbus exception replies
  if (error == EMBBADCRC || error == EMBBADDATA || error == EMBBADEXC || error == EMBMDATA ||
      error == EMBBADSLAVE)
    return Kind::kProtocol;
  if (error == ECONNREFUSED || error == ECONNRESET || error == EPIPE || error == ENOTCONN || error == EBADF)
    return Kind::kDisconnected;
  return Kind::kProtocol;
}

std::uint16_t level_to_register(double level) {
  return static_cast<std::uint16_t>(std::lround(level * map::kDriveFullScale));
}

class ModbusLedController final : public LedController {
 public:
  ModbusLedController(ModbusPtr ctx, std::string device) : ctx_(std::move(ctx)), device_(std::move(device)) {
    read_info();
    std::uint16_t last_sequence = 0;
    call("read command sequence", modbus_read_registers(ctx_.get(), map::kHoldCommandSequence, 1, &last_sequence));
    sequence_ = last_sequence;
  }

  LedControllerInfo info() const override { return info_; }

  void set_state(const LedState& state) override {
    detail::validate_state(state, info_, device_);
    // A sphere without polarisers gets the version-1 write (0x0000-0x000A);
    // with polarisers the staging block reaches the polarisation word.
    std::vector<std::uint16_t> block(info_.has_polarisers() ? map::kHoldStagingCount : map::kHoldCommandSequence + 1, 0);
    put_state(state, block.data());
    if (info_.has_polarisers()) block[map::kHoldPolarisation] = detail::encode_polarisation_word(state.polarisation);
    LedStatus status = run_command(map::kCommandApplyState, block, "set state");
    detail::check_applied_state(state, status, device_);
  }

  LedStatus read_status() override {
    std::uint16_t regs[map::kInStatusCount];
    call("read status", modbus_read_input_registers(ctx_.get(), map::kInStatusFirst, map::kInStatusCount, regs));
    const map::StatusRegisters decoded = map::decode_status_registers(regs, device_);
    LedStatus status = decoded.status;
    last_ack_ = decoded.ack_sequence;
    last_result_ = decoded.command_result;
    std::uint8_t coil = 0;
    call("read output enable", modbus_read_bits(ctx_.get(), map::kCoilOutputEnable, 1, &coil));
    status.output_enabled = coil != 0;
    return status;
  }

  void set_output_enabled(bool enabled) override {
    call(enabled ? "enable output" : "disable output",
         modbus_write_bit(ctx_.get(), map::kCoilOutputEnable, enabled ? 1 : 0));
  }

  void arm_sequence(std::span<const LedState> states, SequenceTrigger trigger) override {
    detail::validate_sequence(states, info_, device_);
    constexpr int kStatesPerWrite = 12;  // 120 registers, under Modbus' 123 per write
    for (std::size_t first = 0; first < states.size(); first += kStatesPerWrite) {
      std::size_t count = std::min<std::size_t>(kStatesPerWrite, states.size() - first);
      std::vector<std::uint16_t> table(count * map::kSequenceStride, 0);
      for (std::size_t k = 0; k < count; ++k) put_table_state(states[first + k], &table[k * map::kSequenceStride]);
      int address = map::kHoldSequenceTable + static_cast<int>(first) * map::kSequenceStride;
      call("write sequence table",
           modbus_write_registers(ctx_.get(), address, static_cast<int>(table.size()), table.data()));
    }
    std::vector<std::uint16_t> block{0, 0, static_cast<std::uint16_t>(states.size()), trigger_code(trigger)};
    run_command(map::kCommandArmSequence, block, "arm sequence", map::kHoldCommandCode);
  }

  void advance_sequence() override {
    std::vector<std::uint16_t> block(2, 0);
    run_command(map::kCommandAdvance, block, "advance sequence", map::kHoldCommandCode);
  }

  void disarm_sequence() override {
    std::vector<std::uint16_t> block(2, 0);
    run_command(map::kCommandDisarm, block, "disarm sequence", map::kHoldCommandCode);
  }

  std::uint32_t fire_trigger(std::uint32_t pulse_width_us) override {
    detail::validate_trigger_pulse(pulse_width_us, device_);
    // code, sequence, length, trigger (unchanged: 0s are ignored by FIRE_TRIGGER), pulse width
    std::vector<std::uint16_t> block{0, 0, 0, 0, static_cast<std::uint16_t>(pulse_width_us)};
    return run_command(map::kCommandFireTrigger, block, "fire trigger", map::kHoldCommandCode).trigger_pulses;
  }

 private:
  static std::uint16_t trigger_code(SequenceTrigger trigger) {
    switch (trigger) {
      case SequenceTrigger::kHardwareRisingEdge: return map::kTriggerHardwareEdge;
      case SequenceTrigger::kSoftware: return map::kTriggerSoftware;
      case SequenceTrigger::kTriggerOutput: return map::kTriggerOwnOutput;
    }
    return map::kTriggerHardwareEdge;
  }

  // Writes drive[6], zone, PWM high, PWM low at `out` (and, for a sequence
  // table entry, the polarisation word after them).
  static void put_table_state(const LedState& state, std::uint16_t* out) {
    put_state(state, out);
    out[map::kSequencePolarisationOffset] = detail::encode_polarisation_word(state.polarisation);
  }
  static void put_state(const LedState& state, std::uint16_t* out) {
    for (int i = 0; i < kLedTypeCount; ++i) out[i] = level_to_register(state.drive[i]);
    out[6] = state.zone ? static_cast<std::uint16_t>(*state.zone) : map::kAllZones;
    auto hz = static_cast<std::uint32_t>(std::lround(state.pwm_frequency_hz));
    out[7] = static_cast<std::uint16_t>(hz >> 16);
    out[8] = static_cast<std::uint16_t>(hz & 0xFFFF);
  }

  // `block` starts at register `first` and reaches at least the command
  // sequence register; the command code and a fresh sequence number are put in.
  LedStatus run_command(std::uint16_t code, std::vector<std::uint16_t>& block, const std::string& request,
                        int first = 0) {
    sequence_ = static_cast<std::uint16_t>(sequence_ == 0xFFFF ? 1 : sequence_ + 1);
    block[map::kHoldCommandCode - first] = code;
    block[map::kHoldCommandSequence - first] = sequence_;
    call(request, modbus_write_registers(ctx_.get(), first, static_cast<int>(block.size()), block.data()));
    LedStatus status = read_status();
    if (last_ack_ != sequence_)
      throw DeviceError(Kind::kProtocol, device_, request,
                        "not acknowledged: command sequence " + std::to_string(sequence_) + ", device reports " +
                            std::to_string(last_ack_));
    switch (last_result_) {
      case map::kResultOk: return status;
      case map::kResultFault:
        throw DeviceError(Kind::kFault, device_, request,
                          "refused: controller fault " + detail::describe_faults(status.controller_faults));
      case map::kResultOutOfRange: throw DeviceError(Kind::kRefused, device_, request, "refused: out of range");
      case map::kResultBadState: throw DeviceError(Kind::kRefused, device_, request, "refused: not in a state to do it");
      case map::kResultUnknownCommand: throw DeviceError(Kind::kRefused, device_, request, "refused: unknown command");
      case map::kResultBadPolarisation:
        throw DeviceError(Kind::kRefused, device_, request,
                          "refused: bad polarisation (holding register 0x000E, or a sequence entry's polarisation "
                          "word: a code above 2, bits 12-15 set, or cross/parallel for an LED type without a "
                          "polariser bank)");
      default:
        throw DeviceError(Kind::kProtocol, device_, request, "unknown result code " + std::to_string(last_result_));
    }
  }

  void read_info() {
    std::uint16_t regs[map::kInInfoCount];
    call("read info", modbus_read_input_registers(ctx_.get(), 0, map::kInInfoCount, regs));
    info_ = map::decode_info_registers(regs, device_);
  }

  void call(const std::string& request, int result) {
    if (result != -1) return;
    int error = errno;
    Kind kind = kind_of_errno(error);
    if (kind == Kind::kTimeout) modbus_flush(ctx_.get());  // drop a late answer before the next request
    throw DeviceError(kind, device_, request,
                      kind == Kind::kTimeout ? std::string("no answer in time (") + modbus_strerror(error) + ")"
                                             : modbus_strerror(error));
  }

  ModbusPtr ctx_;
  std::string device_;
  LedControllerInfo info_;
  std::uint16_t sequence_ = 0;
  std::uint16_t last_ack_ = 0;
  std::uint16_t last_result_ = 0;
};

std::unique_ptr<LedController> connect(modbus_t* raw, const std::string& device, const ModbusLinkOptions& options) {
  if (!raw) throw DeviceError(Kind::kNotFound, device, "create Modbus context", modbus_strerror(errno));
  ModbusPtr ctx(raw);
  if (modbus_set_slave(ctx.get(), options.unit_id) == -1)
    throw DeviceError(Kind::kInvalidRequest, device, "set unit id " + std::to_string(options.unit_id),
                      modbus_strerror(errno));
  auto us = options.response_timeout.count() * 1000;
  modbus_set_response_timeout(ctx.get(), static_cast<std::uint32_t>(us / 1000000),
                              static_cast<std::uint32_t>(us % 1000000));
  if (modbus_connect(ctx.get()) == -1) throw DeviceError(Kind::kNotFound, device, "connect", modbus_strerror(errno));
  return std::make_unique<ModbusLedController>(std::move(ctx), device);
}

}  // namespace

std::unique_ptr<LedController> make_modbus_tcp_led_controller(const std::string& host, int port,
                                                              ModbusLinkOptions options) {
  std::string device = "Modbus TCP LED controller " + host + ":" + std::to_string(port) + " unit " +
                       std::to_string(options.unit_id);
  return connect(modbus_new_tcp_pi(host.c_str(), std::to_string(port).c_str()), device, options);
}

std::unique_ptr<LedController> make_modbus_rtu_led_controller(const std::string& device_path, int baud,
                                                              ModbusLinkOptions options) {
  std::string device = "Modbus RTU LED controller " + device_path + " unit " + std::to_string(options.unit_id);
  return connect(modbus_new_rtu(device_path.c_str(), baud, 'N', 8, 1), device, options);
}

}  // namespace chromo::drivers
