// Device side of the HID LED protocol: the simulator's own parser and encoder.

#include "chromo/simulators/leds/hid_led_device.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>

#include "chromo/drivers/led/led_hid_protocol.hpp"
#include "device_polarisation_word.hpp"

namespace chromo::simulators {

namespace hid = drivers::led_hid;

namespace {

std::uint16_t u16_at(std::span<const std::uint8_t> bytes, std::size_t at) {
  return static_cast<std::uint16_t>(bytes[at] | bytes[at + 1] << 8);
}
std::uint32_t u32_at(std::span<const std::uint8_t> bytes, std::size_t at) {
  return bytes[at] | bytes[at + 1] << 8 | bytes[at + 2] << 16 | std::uint32_t(bytes[at + 3]) << 24;
}
void append_u16(std::vector<std::uint8_t>& out, std::uint32_t v) {
  out.push_back(static_cast<std::uint8_t>(v & 0xFF));
  out.push_back(static_cast<std::uint8_t>((v >> 8) & 0xFF));
}
void append_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  append_u16(out, v & 0xFFFF);
  append_u16(out, v >> 16);
}
void append_text(std::vector<std::uint8_t>& out, const std::string& text) {
  for (int i = 0; i < hid::kStringFieldSize; ++i)
    out.push_back(i < static_cast<int>(text.size()) ? static_cast<std::uint8_t>(text[i]) : 0);
}

// A 17-byte state is unpolarised; a 19-byte one carries the polarisation
// word in bytes 17-18. nullopt for a word the firmware refuses.
std::optional<drivers::LedState> state_at(std::span<const std::uint8_t> payload) {
  drivers::LedState state;
  if (payload.size() == hid::kPolarisedStatePayloadSize) {
    const auto polarisation = device_polarisation::read_word(u16_at(payload, hid::kStatePayloadSize));
    if (!polarisation) return std::nullopt;
    state.polarisation = *polarisation;
  }
  if (payload[0] != hid::kAllZones) state.zone = payload[0];
  state.pwm_frequency_hz = u32_at(payload, 1);
  for (int i = 0; i < spectral::kLedTypeCount; ++i) state.drive[i] = u16_at(payload, 5 + 2 * i) / 65535.0;
  return state;
}

std::uint8_t status_of(LabResult result) {
  switch (result) {
    case LabResult::kOk: return hid::kOk;
    case LabResult::kOutOfRange: return hid::kOutOfRange;
    case LabResult::kBadState: return hid::kBadState;
    case LabResult::kFault: return hid::kFault;
    case LabResult::kBadPolarisation: return hid::kBadPolarisation;
  }
  return hid::kBadState;
}

}  // namespace

void HidLedDevice::write_report(std::span<const std::uint8_t> report) {
  if (lab_.unresponsive()) return;
  std::vector<std::uint8_t> reply = handle(report);
  switch (std::exchange(corruption_, HidReplyCorruption::kNone)) {
    case HidReplyCorruption::kNone: break;
    case HidReplyCorruption::kShort: reply.resize(10); break;
    case HidReplyCorruption::kOversized: reply.push_back(0); break;
    case HidReplyCorruption::kWrongSequence: reply[1] = static_cast<std::uint8_t>(reply[1] + 1); break;
    case HidReplyCorruption::kBadLength: reply[4] = hid::kReportSize; break;
  }
  replies_.push_back(std::move(reply));
}

std::size_t HidLedDevice::read_report(std::span<std::uint8_t> buffer, int /*timeout_ms*/) {
  // In-process: a reply is either queued already or will never come (the
  // device answers synchronously), so waiting would only slow tests down.
  if (replies_.empty()) return 0;
  std::vector<std::uint8_t> reply = std::move(replies_.front());
  replies_.pop_front();
  std::size_t n = std::min(buffer.size(), reply.size());
  std::copy_n(reply.begin(), n, buffer.begin());
  return n;
}

std::vector<std::uint8_t> HidLedDevice::handle(std::span<const std::uint8_t> report) {
  std::uint8_t sequence = report.size() > 1 ? report[1] : 0;
  std::uint8_t command = report.size() > 2 ? report[2] : 0;
  std::vector<std::uint8_t> payload;
  std::uint8_t status = hid::kOk;

  auto malformed = [&] {
    if (report.size() != hid::kReportSize || report[0] != hid::kCommandReportId) return true;
    if (report[3] > hid::kReportSize - hid::kCommandHeaderSize) return true;
    return !std::all_of(report.begin() + hid::kCommandHeaderSize + report[3], report.end(),
                        [](std::uint8_t b) { return b == 0; });
  };
  if (malformed()) {
    status = hid::kMalformed;
  } else {
    std::span<const std::uint8_t> in = report.subspan(hid::kCommandHeaderSize, report[3]);
    auto need = [&](std::size_t size) {
      if (in.size() == size) return true;
      status = hid::kBadLength;
      return false;
    };
    // A state after `prefix` bytes: 17 bytes, or 19 on a sphere with polarisers.
    const bool polarised = lab_.info().has_polarisers();
    auto need_state = [&](std::size_t prefix) {
      if (polarised && in.size() == prefix + hid::kPolarisedStatePayloadSize) return true;
      return need(prefix + hid::kStatePayloadSize);
    };
    switch (command) {
      case hid::kGetInfo:
        if (need(0)) {
          drivers::LedControllerInfo info = lab_.info();
          payload.push_back(info.drive_mode == drivers::DriveMode::kPwmDuty ? 0 : 1);
          payload.push_back(static_cast<std::uint8_t>(info.zone_count));
          append_u16(payload, static_cast<std::uint32_t>(info.sequence_capacity));
          append_u32(payload, static_cast<std::uint32_t>(info.min_pwm_frequency_hz));
          append_u32(payload, static_cast<std::uint32_t>(info.max_pwm_frequency_hz));
          payload.push_back(static_cast<std::uint8_t>(lab_.options().firmware_major));
          payload.push_back(static_cast<std::uint8_t>(lab_.options().firmware_minor));
          append_text(payload, info.model);
          append_text(payload, info.serial);
          if (info.has_polarisers()) payload.push_back(static_cast<std::uint8_t>(device_polarisation::bank_mask(info.polariser_banks)));
        }
        break;
      case hid::kSetState:
        if (need_state(0)) {
          const std::optional<drivers::LedState> state = state_at(in);
          status = state ? status_of(lab_.apply(*state)) : hid::kBadPolarisation;
        }
        break;
      case hid::kGetStatus:
        if (need(0)) {
          drivers::LedStatus s = lab_.status();
          payload.push_back(s.output_enabled ? 1 : 0);
          append_u16(payload, static_cast<std::uint16_t>(static_cast<std::int16_t>(s.sequence_position)));
          append_u16(payload, s.controller_faults);
          payload.push_back(s.applied.zone ? static_cast<std::uint8_t>(*s.applied.zone) : hid::kAllZones);
          append_u32(payload, static_cast<std::uint32_t>(std::lround(s.applied.pwm_frequency_hz)));
          for (double level : s.applied.drive) append_u16(payload, static_cast<std::uint32_t>(std::lround(level * 65535)));
          for (double t : s.temperature_C)
            append_u16(payload, static_cast<std::uint16_t>(static_cast<std::int16_t>(std::lround(t * 100))));
          for (std::uint32_t f : s.channel_faults) payload.push_back(static_cast<std::uint8_t>(f));
          append_u32(payload, s.trigger_pulses);
          if (polarised) append_u16(payload, device_polarisation::write_word(s.applied.polarisation));
        }
        break;
      case hid::kSetOutput:
        if (need(1)) {
          if (in[0] > 1) status = hid::kOutOfRange;
          else lab_.set_output_enabled(in[0] == 1);
        }
        break;
      case hid::kSequenceBegin:
        if (need(3)) {
          int count = u16_at(in, 0);
          if (count < 1 || count > lab_.info().sequence_capacity || in[2] > hid::kTriggerOwnOutput) {
            status = hid::kOutOfRange;
          } else {
            loading_.assign(count, drivers::LedState{});
            loaded_.assign(count, false);
            loading_trigger_ = in[2] == hid::kTriggerHardwareEdge ? drivers::SequenceTrigger::kHardwareRisingEdge
                               : in[2] == hid::kTriggerSoftware   ? drivers::SequenceTrigger::kSoftware
                                                                  : drivers::SequenceTrigger::kTriggerOutput;
          }
        }
        break;
      case hid::kSequenceState:
        if (need_state(2)) {
          std::size_t index = u16_at(in, 0);
          const std::optional<drivers::LedState> state = state_at(in.subspan(2));
          if (index >= loading_.size()) {
            status = hid::kOutOfRange;
          } else if (!state) {
            status = hid::kBadPolarisation;
          } else {
            loading_[index] = *state;
            loaded_[index] = true;
          }
        }
        break;
      case hid::kSequenceArm:
        if (need(0)) {
          if (loading_.empty() || !std::all_of(loaded_.begin(), loaded_.end(), [](bool b) { return b; }))
            status = hid::kBadState;
          else
            status = status_of(lab_.arm(loading_, loading_trigger_));
        }
        break;
      case hid::kSequenceAdvance:
        if (need(0)) status = status_of(lab_.advance());
        break;
      case hid::kSequenceDisarm:
        if (need(0)) lab_.disarm();
        break;
      case hid::kFireTrigger:
        if (need(hid::kFireTriggerPayloadSize)) {
          std::uint32_t pulse = 0;
          status = status_of(lab_.fire_trigger_output(u16_at(in, 0), &pulse));
          if (status == hid::kOk) append_u32(payload, pulse);
        }
        break;
      default: status = hid::kUnknownCommand;
    }
  }
  std::vector<std::uint8_t> reply(hid::kReportSize, 0);
  reply[0] = hid::kReplyReportId;
  reply[1] = sequence;
  reply[2] = command;
  reply[3] = status;
  reply[4] = static_cast<std::uint8_t>(payload.size());
  std::copy(payload.begin(), payload.end(), reply.begin() + hid::kReplyHeaderSize);
  return reply;
}

}  // namespace chromo::simulators
