#pragma once
// LedController: the sphere's LED driver, whatever its transport (USB HID,
// Modbus TCP/RTU, or a simulator speaking one of those protocols).
//
// What a drive level means is declared by the device (LedControllerInfo::
// drive_mode):
//  - kPwmDuty: the level is the PWM duty cycle (0-1) at pwm_frequency_hz; the
//    spectrum keeps its shape, and an exposure must span whole PWM periods
//    (exposure_us · pwm_frequency_hz an integer, or long enough that the
//    remainder is negligible), so the PWM frequency is part of the state.
//  - kConstantCurrent: the level is the fraction of the channel's maximum
//    current; the spectrum shifts with current (and temperature).
//
// Thread rules: a LedController is used from one thread at a time (the daemon
// owns it and serialises calls). Every call either completes with the device's
// acknowledgement or throws DeviceError; nothing is silently dropped.
// Lifetime: the object owns its transport; destroying it closes the link and
// leaves the LEDs in whatever state they were (call set_output_enabled(false)
// first to switch off).

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "chromo/spectral/led_type.hpp"

namespace chromo::drivers {

using spectral::kLedTypeCount;
using spectral::LedType;

enum class DriveMode { kPwmDuty, kConstantCurrent };

struct LedControllerInfo {
  std::string model;
  std::string serial;
  std::string firmware_version;
  DriveMode drive_mode = DriveMode::kPwmDuty;
  int zone_count = 1;               // independently drivable zones of the sphere
  int sequence_capacity = 0;        // max states in a hardware-timed sequence
  double min_pwm_frequency_hz = 0;  // only for kPwmDuty
  double max_pwm_frequency_hz = 0;
  // LED types with a cross and a parallel bank (docs/polarisation.md); all
  // false on a sphere without polarisers, which accepts only kUnpolarised.
  std::array<bool, kLedTypeCount> polariser_banks{};
  bool has_polarisers() const {
    for (bool bank : polariser_banks)
      if (bank) return true;
    return false;
  }
};

// Drive levels of the six LED types, each in [0, 1].
using DriveLevels = std::array<double, kLedTypeCount>;

// Polarisation of an LED type's light relative to the cameras' fixed
// analysers (docs/polarisation.md). A sphere with polarisers has, for each
// LED type it lists in LedControllerInfo::polariser_banks, two banks: one
// behind polarisers crossed to the analysers (kCross) and one behind
// polarisers rotated by 90 degrees (kParallel). kUnpolarised drives an LED
// type's only bank on a sphere without polarisers, and both banks at the
// level on a sphere with them (their light adds up to unpolarised light).
enum class Polarisation : std::uint8_t { kUnpolarised = 0, kCross = 1, kParallel = 2 };
inline constexpr int kPolarisationCodeCount = 3;
using PolarisationPerType = std::array<Polarisation, kLedTypeCount>;  // indexed by led_type_index()
// "unpolarised", "cross", "parallel"; "unknown" for any other code.
inline const char* polarisation_name(Polarisation polarisation) {
  switch (polarisation) {
    case Polarisation::kUnpolarised: return "unpolarised";
    case Polarisation::kCross: return "cross";
    case Polarisation::kParallel: return "parallel";
  }
  return "unknown";
}

struct LedState {
  DriveLevels drive{};            // indexed by led_type_index()
  double pwm_frequency_hz = 0;    // kPwmDuty devices; 0 = keep the current frequency
  std::optional<int> zone;        // nullopt = all zones
  PolarisationPerType polarisation{};  // all kUnpolarised by default
};

// Fault bits per channel and for the whole controller.
enum LedFault : std::uint32_t {
  kLedFaultNone = 0,
  kLedFaultOverTemperature = 1u << 0,  // channel (or controller) too hot: output reduced or off
  kLedFaultOpenCircuit = 1u << 1,      // channel draws no current: dead LED or cable
  kLedFaultShortCircuit = 1u << 2,
  kLedFaultSupply = 1u << 3,           // supply voltage out of range
};

struct LedStatus {
  LedState applied;                                  // what the device says it is driving now
  bool output_enabled = false;
  std::array<double, kLedTypeCount> temperature_C{}; // per-channel LED (heatsink) temperature
  std::array<std::uint32_t, kLedTypeCount> channel_faults{};
  std::uint32_t controller_faults = kLedFaultNone;
  int sequence_position = -1;  // index of the state being shown in an armed sequence, -1 when none
  // Pulses fired on the trigger output since power-on (fire_trigger), wrapping
  // at 2^32: the number of the last pulse, 0 before the first.
  std::uint32_t trigger_pulses = 0;
};

// The trigger output's pulse width limits (fire_trigger), microseconds.
inline constexpr std::uint32_t kMinTriggerPulseWidthUs = 1;
inline constexpr std::uint32_t kMaxTriggerPulseWidthUs = 10000;

enum class SequenceTrigger {
  kHardwareRisingEdge,  // advance on the trigger input's rising edge (camera exposure-active)
  kSoftware,            // advance on advance_sequence()
  kTriggerOutput,       // advance on the controller's own trigger output pulse (fire_trigger), before the pulse leaves
};

class LedController {
 public:
  virtual ~LedController() = default;

  virtual LedControllerInfo info() const = 0;

  // Software-timed: applies the state and returns once the device has
  // acknowledged it as applied. DeviceError(kInvalidRequest) for a level
  // outside [0, 1], an unknown zone or a PWM frequency outside the limits.
  virtual void set_state(const LedState& state) = 0;
  virtual LedStatus read_status() = 0;
  virtual void set_output_enabled(bool enabled) = 0;

  // Hardware-timed: the device holds the states and shows state k+1 on the
  // k-th trigger; the first state is shown at once. At most
  // info().sequence_capacity states.
  virtual void arm_sequence(std::span<const LedState> states, SequenceTrigger trigger) = 0;
  virtual void advance_sequence() = 0;  // only for SequenceTrigger::kSoftware
  virtual void disarm_sequence() = 0;

  // Trigger master: fires one pulse of pulse_width_us on the controller's
  // trigger output (wired to every camera's trigger input, Line0) and returns
  // its number (LedStatus::trigger_pulses after it: pulses count from 1 after
  // power-on and wrap at 2^32). A sequence armed with kTriggerOutput shows
  // its next state before the pulse leaves, so the light the cameras expose
  // under is the one this pulse numbers. Returns once the device has
  // acknowledged the pulse as sent. DeviceError(kInvalidRequest) for a width
  // outside [kMinTriggerPulseWidthUs, kMaxTriggerPulseWidthUs] (nothing sent).
  virtual std::uint32_t fire_trigger(std::uint32_t pulse_width_us) = 0;
};

}  // namespace chromo::drivers
