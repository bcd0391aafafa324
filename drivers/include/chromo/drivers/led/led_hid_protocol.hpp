#pragma once
// Report protocol of the USB HID LED controller (docs/protocols/led-hid.md).
// Constants only: the driver (drivers/led/hid_reports.cpp) and the simulator
// (simulators/leds/hid_led_device.cpp) each encode and parse the bytes
// themselves.
//
// Every report is kReportSize bytes including the report id (hidapi's
// convention: byte 0 is the report id). Multi-byte fields are little endian.
//
// Command (host → device, output report kCommandReportId):
//   [0] report id  [1] sequence  [2] command  [3] payload length n (≤ 60)
//   [4 .. 4+n) payload   [4+n .. 64) zero
// Reply (device → host, input report kReplyReportId), one per command:
//   [0] report id  [1] sequence echoed  [2] command echoed  [3] status
//   [4] payload length n  [5 .. 5+n) payload  [5+n .. 64) zero

#include <cstdint>

namespace chromo::drivers::led_hid {

inline constexpr int kReportSize = 64;
inline constexpr std::uint8_t kCommandReportId = 0x01;
inline constexpr std::uint8_t kReplyReportId = 0x02;
inline constexpr int kCommandHeaderSize = 4;
inline constexpr int kReplyHeaderSize = 5;
inline constexpr int kMaxPayload = kReportSize - kReplyHeaderSize;  // 59
inline constexpr std::uint16_t kDriveFullScale = 65535;
inline constexpr std::uint8_t kAllZones = 0xFF;
inline constexpr int kStringFieldSize = 16;  // model, serial: ASCII, NUL padded

enum Command : std::uint8_t {
  kGetInfo = 0x01,        // → info payload (kInfoPayloadSize)
  kSetState = 0x02,       // state payload (kStatePayloadSize) → empty, once applied
  kGetStatus = 0x03,      // → status payload (kStatusPayloadSize)
  kSetOutput = 0x04,      // [0] 0 off / 1 on → empty
  kSequenceBegin = 0x05,  // [0..1] state count, [2] trigger (0 hardware, 1 software, 2 own trigger output) → empty
  kSequenceState = 0x06,  // [0..1] index, then a state payload → empty
  kSequenceArm = 0x07,    // → empty; needs every state of the begun sequence
  kSequenceAdvance = 0x08,
  kSequenceDisarm = 0x09,
  kFireTrigger = 0x0A,    // [0..1] pulse width us (1-10000) → [0..3] the pulse's number (u32)
};

// Sequence trigger codes (kSequenceBegin byte 2).
inline constexpr std::uint8_t kTriggerHardwareEdge = 0, kTriggerSoftware = 1, kTriggerOwnOutput = 2;
inline constexpr int kFireTriggerPayloadSize = 2;
inline constexpr int kFireTriggerReplySize = 4;

enum Status : std::uint8_t {
  kOk = 0x00,
  kUnknownCommand = 0x01,
  kBadLength = 0x02,      // payload length wrong for the command
  kOutOfRange = 0x03,     // zone, PWM frequency, index or count outside the limits
  kBadState = 0x04,       // e.g. arm before all states were loaded, advance when not armed
  kFault = 0x05,          // refused because of a controller fault (over-temperature)
  kMalformed = 0x06,      // report id, length byte or padding wrong
  kBadPolarisation = 0x07,  // state payload bytes 17-18: code 3, bits 12-15, or cross/parallel without a bank
};

// State payload: [0] zone (or kAllZones), [1..4] PWM frequency Hz (u32, 0 = keep),
// [5..16] six drive levels u16 (W57, W40, W27, R, G, B).
// A sphere with polarisers also takes [17..18] the polarisation word (u16,
// LED type i in bits 2i..2i+1: 0 unpolarised, 1 cross, 2 parallel); a
// 17-byte state is unpolarised (docs/polarisation.md).
inline constexpr int kStatePayloadSize = 17;
inline constexpr int kPolarisedStatePayloadSize = 19;
// Info payload: [0] drive mode (0 PWM, 1 constant current), [1] zone count,
// [2..3] sequence capacity, [4..7] min PWM Hz, [8..11] max PWM Hz,
// [12] firmware major, [13] firmware minor, [14..29] model, [30..45] serial.
// A sphere with polarisers adds [46] the polariser bank mask (bit i: LED type i).
inline constexpr int kInfoPayloadSize = 46;
inline constexpr int kPolarisedInfoPayloadSize = 47;
// Status payload: [0] output enabled, [1..2] sequence position (i16, -1 none),
// [3..4] controller faults, [5] applied zone, [6..9] applied PWM Hz,
// [10..21] applied drive u16 ×6, [22..33] temperatures i16 centi-°C ×6,
// [34..39] channel fault bits u8 ×6, [40..43] trigger output pulses fired (u32).
// A sphere with polarisers adds [44..45] the applied polarisation word (u16).
inline constexpr int kStatusPayloadSize = 44;
inline constexpr int kPolarisedStatusPayloadSize = 46;

}  // namespace chromo::drivers::led_hid
