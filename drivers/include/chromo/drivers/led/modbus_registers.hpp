#pragma once
// Decoding the LED controller's Modbus input registers
// (docs/protocols/led-modbus.md, led_modbus_map.hpp): what the device answers,
// turned into the driver's types. Pure functions of the register values, so a
// test or a fuzzer can feed any answer; a malformed one throws DeviceError
// (kProtocol) naming the device and the request.

#include <cstdint>
#include <span>
#include <string>

#include "chromo/drivers/led_controller.hpp"

namespace chromo::drivers::led_modbus {

// The info block: input registers 0 .. kInInfoCount-1.
LedControllerInfo decode_info_registers(std::span<const std::uint16_t> registers, const std::string& device);

struct StatusRegisters {
  LedStatus status;                 // output_enabled is a coil: left false here
  std::uint16_t ack_sequence = 0;   // the last command sequence the device acted on
  std::uint16_t command_result = 0;
};
// The status block: input registers kInStatusFirst .. kInStatusFirst+kInStatusCount-1.
StatusRegisters decode_status_registers(std::span<const std::uint16_t> registers, const std::string& device);

}  // namespace chromo::drivers::led_modbus
