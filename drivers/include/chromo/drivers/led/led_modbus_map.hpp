#pragma once
// Register map of the Modbus LED controller (docs/protocols/led-modbus.md).
// Constants only: the driver and the simulator each have their own encoding
// and decoding code, so that a mistake in one is caught by the other.
//
// Conventions: drive levels are unsigned 16-bit, 0 = off, 65535 = full (the
// level in [0, 1] times 65535, rounded); 32-bit values span two registers,
// high word first; temperatures are signed centi-degrees Celsius.

#include <cstdint>

namespace chromo::drivers::led_modbus {

inline constexpr int kProtocolVersion = 1;
inline constexpr int kDefaultUnitId = 1;
inline constexpr std::uint16_t kDriveFullScale = 65535;
inline constexpr std::uint16_t kAllZones = 0xFFFF;

// ---- Holding registers (function codes 3, 6, 16) ----
// Staging state, written together with a command in one "write multiple" (16).
inline constexpr int kHoldDrive0 = 0x0000;          // 6 registers, W57, W40, W27, R, G, B
inline constexpr int kHoldZone = 0x0006;            // zone index, or kAllZones
inline constexpr int kHoldPwmHzHigh = 0x0007;       // PWM frequency in Hz, 0 = keep
inline constexpr int kHoldPwmHzLow = 0x0008;
inline constexpr int kHoldCommandCode = 0x0009;     // see Command
inline constexpr int kHoldCommandSequence = 0x000A; // the device acts when this changes
inline constexpr int kHoldSequenceLength = 0x000B;  // states in the sequence table (arm)
inline constexpr int kHoldSequenceTrigger = 0x000C; // 0 hardware rising edge, 1 software, 2 own trigger output
inline constexpr int kHoldTriggerPulseWidthUs = 0x000D;  // FIRE_TRIGGER: pulse width, us (1-10000)
inline constexpr int kHoldPolarisation = 0x000E;    // APPLY: polarisation word (2 bits per LED type, docs/polarisation.md)
inline constexpr int kHoldStagingCount = 0x000F;    // registers 0x0000..0x000E
// Sequence table: state k at kHoldSequenceTable + k * kSequenceStride:
// drive[6], zone, pwm high, pwm low, polarisation word (0 = unpolarised:
// the register was reserved, written 0, before polarisers).
inline constexpr int kHoldSequenceTable = 0x0100;
inline constexpr int kSequenceStride = 10;
inline constexpr int kSequencePolarisationOffset = 9;
inline constexpr int kMaxSequenceStates = 64;
inline constexpr int kHoldRegisterCount = kHoldSequenceTable + kSequenceStride * kMaxSequenceStates;

enum Command : std::uint16_t {
  kCommandNone = 0,
  kCommandApplyState = 1,     // apply the staging state
  kCommandArmSequence = 2,    // arm the sequence table (length, trigger)
  kCommandAdvance = 3,        // software trigger of an armed kSoftware sequence
  kCommandDisarm = 4,
  kCommandFireTrigger = 5,    // one pulse on the trigger output (width in kHoldTriggerPulseWidthUs)
};

// Sequence trigger codes (kHoldSequenceTrigger).
inline constexpr std::uint16_t kTriggerHardwareEdge = 0, kTriggerSoftware = 1, kTriggerOwnOutput = 2;

// ---- Input registers (function code 4) ----
inline constexpr int kInProtocolVersion = 0x0000;
inline constexpr int kInDriveMode = 0x0001;        // 0 PWM duty, 1 constant current
inline constexpr int kInZoneCount = 0x0002;
inline constexpr int kInSequenceCapacity = 0x0003;
inline constexpr int kInMinPwmHzHigh = 0x0004;     // 2 registers
inline constexpr int kInMaxPwmHzHigh = 0x0006;     // 2 registers
inline constexpr int kInFirmwareVersion = 0x0008;  // major << 8 | minor
inline constexpr int kInPolariserBanks = 0x0009;   // bit i: LED type i has a cross and a parallel bank; 0 = no polarisers
inline constexpr int kInSerial = 0x0010;           // 8 registers: 16 ASCII bytes, high byte first, NUL padded
inline constexpr int kInModel = 0x0018;            // 8 registers
inline constexpr int kInInfoCount = 0x0020;        // info block: registers 0x0000..0x001F

inline constexpr int kInAppliedDrive0 = 0x0020;    // 6 registers
inline constexpr int kInAppliedZone = 0x0026;
inline constexpr int kInAppliedPwmHzHigh = 0x0027; // 2 registers
inline constexpr int kInAckSequence = 0x0029;      // last command sequence processed
inline constexpr int kInSequencePosition = 0x002A; // 0xFFFF = no sequence armed
inline constexpr int kInControllerFaults = 0x002B; // LedFault bits
inline constexpr int kInCommandResult = 0x002C;    // CommandResult of the last command
inline constexpr int kInTriggerPulsesHigh = 0x002D; // 2 registers: pulses fired on the trigger output (u32)
inline constexpr int kInTemperature0 = 0x0030;     // 6 registers, centi-°C, signed
inline constexpr int kInChannelFaults0 = 0x0038;   // 6 registers, LedFault bits
inline constexpr int kInAppliedPolarisation = 0x003E;  // polarisation word of the applied state
inline constexpr int kInStatusFirst = 0x0020;      // status block: 0x0020..0x003E
inline constexpr int kInStatusCount = 0x001F;
inline constexpr int kInputRegisterCount = 0x0040;

enum CommandResult : std::uint16_t {
  kResultOk = 0,
  kResultUnknownCommand = 1,
  kResultOutOfRange = 2,   // zone, PWM frequency, sequence length, trigger or pulse width outside the limits
  kResultBadState = 3,     // e.g. advance without an armed software sequence
  kResultFault = 4,        // refused: controller over-temperature
  kResultBadPolarisation = 5,  // polarisation word: code 3, bits 12-15, or cross/parallel for a type without a bank
};

// Polarisation word: LED type i (W57, W40, W27, R, G, B) in bits 2i..2i+1.
inline constexpr std::uint16_t kPolarisationUnpolarised = 0, kPolarisationCross = 1, kPolarisationParallel = 2;

// ---- Coils (function codes 1, 5, 15) ----
inline constexpr int kCoilOutputEnable = 0x0000;
inline constexpr int kCoilCount = 1;

}  // namespace chromo::drivers::led_modbus
