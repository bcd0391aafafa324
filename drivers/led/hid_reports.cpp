#include "chromo/drivers/led/hid_reports.hpp"

#include <algorithm>
#include <cmath>

#include "chromo/drivers/device_error.hpp"
#include "chromo/drivers/led/led_hid_protocol.hpp"
#include "polarisation_word.hpp"

namespace chromo::drivers::hid_reports {
namespace {

namespace hid = led_hid;

[[noreturn]] void malformed(const std::string& device, const std::string& what) {
  throw DeviceError(DeviceError::Kind::kProtocol, device, "read reply report", what);
}

std::uint16_t u16(std::span<const std::uint8_t> b, std::size_t at) {
  return static_cast<std::uint16_t>(b[at] | b[at + 1] << 8);
}
std::uint32_t u32(std::span<const std::uint8_t> b, std::size_t at) {
  return b[at] | b[at + 1] << 8 | b[at + 2] << 16 | std::uint32_t(b[at + 3]) << 24;
}
std::string text(std::span<const std::uint8_t> b, std::size_t at) {
  std::string s;
  for (std::size_t i = at; i < at + hid::kStringFieldSize && b[i] != 0; ++i) s += static_cast<char>(b[i]);
  return s;
}
void require_size(std::span<const std::uint8_t> payload, int size, const char* what, const std::string& device) {
  if (payload.size() != static_cast<std::size_t>(size))
    malformed(device, std::string(what) + " payload of " + std::to_string(payload.size()) + " bytes, expected " +
                          std::to_string(size));
}
// A payload of a sphere without polarisers (`plain` bytes) or with them (`polarised`).
void require_either_size(std::span<const std::uint8_t> payload, int plain, int polarised, const char* what,
                         const std::string& device) {
  if (payload.size() != static_cast<std::size_t>(plain) && payload.size() != static_cast<std::size_t>(polarised))
    malformed(device, std::string(what) + " payload of " + std::to_string(payload.size()) + " bytes, expected " +
                          std::to_string(plain) + " or, with polarisers, " + std::to_string(polarised));
}

}  // namespace

std::vector<std::uint8_t> encode_command(std::uint8_t sequence, std::uint8_t command,
                                         std::span<const std::uint8_t> payload) {
  std::vector<std::uint8_t> report(hid::kReportSize, 0);
  report[0] = hid::kCommandReportId;
  report[1] = sequence;
  report[2] = command;
  report[3] = static_cast<std::uint8_t>(payload.size());
  std::copy(payload.begin(), payload.end(), report.begin() + hid::kCommandHeaderSize);
  return report;
}

std::vector<std::uint8_t> encode_state_payload(const LedState& state, bool polarised) {
  std::vector<std::uint8_t> payload;
  payload.push_back(state.zone ? static_cast<std::uint8_t>(*state.zone) : hid::kAllZones);
  auto hz = static_cast<std::uint32_t>(std::lround(state.pwm_frequency_hz));
  for (int shift = 0; shift < 32; shift += 8) payload.push_back(static_cast<std::uint8_t>((hz >> shift) & 0xFF));
  for (double level : state.drive) {
    auto v = static_cast<std::uint16_t>(std::lround(level * hid::kDriveFullScale));
    payload.push_back(static_cast<std::uint8_t>(v & 0xFF));
    payload.push_back(static_cast<std::uint8_t>(v >> 8));
  }
  if (polarised) {
    const std::uint16_t word = detail::encode_polarisation_word(state.polarisation);
    payload.push_back(static_cast<std::uint8_t>(word & 0xFF));
    payload.push_back(static_cast<std::uint8_t>(word >> 8));
  }
  return payload;
}

Reply parse_reply(std::span<const std::uint8_t> report, const std::string& device) {
  if (report.size() != static_cast<std::size_t>(hid::kReportSize))
    malformed(device, (report.size() < hid::kReportSize ? "short report: " : "oversized report: ") +
                          std::to_string(report.size()) + " bytes, expected " + std::to_string(hid::kReportSize));
  if (report[0] != hid::kReplyReportId)
    malformed(device, "report id " + std::to_string(report[0]) + ", expected " + std::to_string(hid::kReplyReportId));
  std::size_t length = report[4];
  if (length > static_cast<std::size_t>(hid::kMaxPayload))
    malformed(device, "payload length " + std::to_string(length) + " exceeds the report (max " +
                          std::to_string(hid::kMaxPayload) + ")");
  if (!std::all_of(report.begin() + hid::kReplyHeaderSize + static_cast<std::ptrdiff_t>(length), report.end(),
                   [](std::uint8_t b) { return b == 0; }))
    malformed(device, "non-zero bytes after the payload");
  Reply reply;
  reply.sequence = report[1];
  reply.command = report[2];
  reply.status = report[3];
  reply.payload.assign(report.begin() + hid::kReplyHeaderSize,
                       report.begin() + hid::kReplyHeaderSize + static_cast<std::ptrdiff_t>(length));
  return reply;
}

LedControllerInfo parse_info_payload(std::span<const std::uint8_t> p, const std::string& device) {
  require_either_size(p, hid::kInfoPayloadSize, hid::kPolarisedInfoPayloadSize, "info", device);
  if (p[0] > 1) malformed(device, "unknown drive mode " + std::to_string(p[0]));
  LedControllerInfo info;
  info.drive_mode = p[0] == 0 ? DriveMode::kPwmDuty : DriveMode::kConstantCurrent;
  info.zone_count = p[1];
  if (info.zone_count < 1) malformed(device, "zone count 0");
  info.sequence_capacity = u16(p, 2);
  info.min_pwm_frequency_hz = u32(p, 4);
  info.max_pwm_frequency_hz = u32(p, 8);
  info.firmware_version = std::to_string(p[12]) + "." + std::to_string(p[13]);
  info.model = text(p, 14);
  info.serial = text(p, 30);
  if (p.size() == static_cast<std::size_t>(hid::kPolarisedInfoPayloadSize))
    info.polariser_banks = detail::decode_polariser_bank_mask(p[46], device, "info: polariser bank mask (byte 46)");
  return info;
}

LedStatus parse_status_payload(std::span<const std::uint8_t> p, const std::string& device) {
  require_either_size(p, hid::kStatusPayloadSize, hid::kPolarisedStatusPayloadSize, "status", device);
  LedStatus status;
  if (p[0] > 1) malformed(device, "output enable byte " + std::to_string(p[0]));
  status.output_enabled = p[0] == 1;
  status.sequence_position = static_cast<std::int16_t>(u16(p, 1));
  status.controller_faults = u16(p, 3);
  if (p[5] != hid::kAllZones) status.applied.zone = p[5];
  status.applied.pwm_frequency_hz = u32(p, 6);
  for (int i = 0; i < kLedTypeCount; ++i) {
    status.applied.drive[i] = u16(p, 10 + 2 * i) / double(hid::kDriveFullScale);
    status.temperature_C[i] = static_cast<std::int16_t>(u16(p, 22 + 2 * i)) / 100.0;
    status.channel_faults[i] = p[34 + i];
  }
  status.trigger_pulses = u32(p, 40);
  if (p.size() == static_cast<std::size_t>(hid::kPolarisedStatusPayloadSize))
    status.applied.polarisation =
        detail::decode_polarisation_word(u16(p, 44), device, "status: applied polarisation (bytes 44-45)");
  return status;
}

std::uint32_t parse_fire_trigger_payload(std::span<const std::uint8_t> p, const std::string& device) {
  require_size(p, hid::kFireTriggerReplySize, "fire trigger", device);
  return u32(p, 0);
}

std::string status_name(std::uint8_t status) {
  switch (status) {
    case hid::kOk: return "ok";
    case hid::kUnknownCommand: return "unknown command";
    case hid::kBadLength: return "bad payload length";
    case hid::kOutOfRange: return "out of range";
    case hid::kBadState: return "not in a state to do it";
    case hid::kFault: return "refused: controller fault";
    case hid::kMalformed: return "malformed report";
    case hid::kBadPolarisation:
      return "bad polarisation (state payload bytes 17-18: a code above 2, bits 12-15 set, or cross/parallel for "
             "an LED type without a polariser bank)";
    default: return "unknown status " + std::to_string(status);
  }
}

}  // namespace chromo::drivers::hid_reports
