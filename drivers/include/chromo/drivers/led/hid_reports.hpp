#pragma once
// The driver's side of the HID report protocol (docs/protocols/led-hid.md):
// encodes command reports and parses reply reports. Parsers throw
// DeviceError(kProtocol) naming what was wrong for any report that is short,
// oversized, has the wrong report id, sequence or command echo, a payload
// length that does not fit, or non-zero padding.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "chromo/drivers/led_controller.hpp"

namespace chromo::drivers::hid_reports {

std::vector<std::uint8_t> encode_command(std::uint8_t sequence, std::uint8_t command,
                                         std::span<const std::uint8_t> payload);
// Zone: nullopt → all zones. Levels are clamped to nothing: validate first.
// With `polarised` (the sphere has polariser banks) the 19-byte state with
// the polarisation word, else the 17-byte state of a sphere without them.
std::vector<std::uint8_t> encode_state_payload(const LedState& state, bool polarised);

struct Reply {
  std::uint8_t sequence = 0;
  std::uint8_t command = 0;
  std::uint8_t status = 0;
  std::vector<std::uint8_t> payload;
};
// `device` names the device in errors.
Reply parse_reply(std::span<const std::uint8_t> report, const std::string& device);

LedControllerInfo parse_info_payload(std::span<const std::uint8_t> payload, const std::string& device);
LedStatus parse_status_payload(std::span<const std::uint8_t> payload, const std::string& device);
// FIRE_TRIGGER's reply: the pulse's number.
std::uint32_t parse_fire_trigger_payload(std::span<const std::uint8_t> payload, const std::string& device);

// "out of range" etc., for error messages.
std::string status_name(std::uint8_t status);

}  // namespace chromo::drivers::hid_reports
