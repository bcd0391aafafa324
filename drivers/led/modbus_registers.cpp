#include "chromo/drivers/led/modbus_registers.hpp"

#include <algorithm>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/led/led_modbus_map.hpp"
#include "polarisation_word.hpp"

namespace chromo::drivers::led_modbus {
namespace {

using Kind = DeviceError::Kind;

double register_to_level(std::uint16_t value) { return value / double(kDriveFullScale); }
std::uint32_t join32(std::uint16_t high, std::uint16_t low) { return (std::uint32_t(high) << 16) | low; }

std::string registers_to_ascii(std::span<const std::uint16_t> registers) {
  std::string text;
  for (std::uint16_t r : registers)
    for (int shift : {8, 0}) {
      const char c = static_cast<char>((r >> shift) & 0xFF);
      if (c == '\0') return text;
      text += c;
    }
  return text;
}

void check_count(std::span<const std::uint16_t> registers, std::size_t expected, const std::string& device,
                 const char* request) {
  if (registers.size() != expected)
    throw DeviceError(Kind::kProtocol, device, request,
                      std::to_string(registers.size()) + " registers, expected " + std::to_string(expected));
}

}  // namespace

LedControllerInfo decode_info_registers(std::span<const std::uint16_t> regs, const std::string& device) {
  check_count(regs, kInInfoCount, device, "read info");
  if (regs[kInProtocolVersion] != kProtocolVersion)
    throw DeviceError(Kind::kProtocol, device, "read info",
                      "protocol version " + std::to_string(regs[kInProtocolVersion]) + ", expected " +
                          std::to_string(kProtocolVersion));
  if (regs[kInDriveMode] > 1)
    throw DeviceError(Kind::kProtocol, device, "read info", "unknown drive mode " + std::to_string(regs[kInDriveMode]));
  LedControllerInfo info;
  info.drive_mode = regs[kInDriveMode] == 0 ? DriveMode::kPwmDuty : DriveMode::kConstantCurrent;
  info.zone_count = regs[kInZoneCount];
  info.sequence_capacity = std::min<int>(regs[kInSequenceCapacity], kMaxSequenceStates);
  info.min_pwm_frequency_hz = join32(regs[kInMinPwmHzHigh], regs[kInMinPwmHzHigh + 1]);
  info.max_pwm_frequency_hz = join32(regs[kInMaxPwmHzHigh], regs[kInMaxPwmHzHigh + 1]);
  const int firmware = regs[kInFirmwareVersion];
  info.firmware_version = std::to_string(firmware >> 8) + "." + std::to_string(firmware & 0xFF);
  info.serial = registers_to_ascii(regs.subspan(kInSerial, 8));
  info.model = registers_to_ascii(regs.subspan(kInModel, 8));
  info.polariser_banks =
      detail::decode_polariser_bank_mask(regs[kInPolariserBanks], device, "info: polariser banks (input register 0x0009)");
  if (info.zone_count < 1)
    throw DeviceError(Kind::kProtocol, device, "read info", "zone count " + std::to_string(info.zone_count));
  return info;
}

StatusRegisters decode_status_registers(std::span<const std::uint16_t> regs, const std::string& device) {
  check_count(regs, kInStatusCount, device, "read status");
  auto at = [&](int address) { return regs[static_cast<std::size_t>(address - kInStatusFirst)]; };
  StatusRegisters out;
  LedStatus& status = out.status;
  for (int i = 0; i < kLedTypeCount; ++i) {
    status.applied.drive[i] = register_to_level(at(kInAppliedDrive0 + i));
    status.temperature_C[i] = static_cast<std::int16_t>(at(kInTemperature0 + i)) / 100.0;
    status.channel_faults[i] = at(kInChannelFaults0 + i);
  }
  if (at(kInAppliedZone) != kAllZones) status.applied.zone = at(kInAppliedZone);
  status.applied.pwm_frequency_hz = join32(at(kInAppliedPwmHzHigh), at(kInAppliedPwmHzHigh + 1));
  const std::uint16_t position = at(kInSequencePosition);
  status.sequence_position = position == 0xFFFF ? -1 : position;
  status.controller_faults = at(kInControllerFaults);
  status.trigger_pulses = join32(at(kInTriggerPulsesHigh), at(kInTriggerPulsesHigh + 1));
  status.applied.polarisation = detail::decode_polarisation_word(
      at(kInAppliedPolarisation), device, "status: applied polarisation (input register 0x003E)");
  out.ack_sequence = at(kInAckSequence);
  out.command_result = at(kInCommandResult);
  return out;
}

}  // namespace chromo::drivers::led_modbus
