#include "led_state_rules.hpp"

#include <cmath>

#include "chromo/drivers/device_error.hpp"

namespace chromo::drivers::detail {

void validate_state(const LedState& state, const LedControllerInfo& info, const std::string& device) {
  auto refuse = [&](const std::string& why) {
    throw DeviceError(DeviceError::Kind::kInvalidRequest, device, "set state", why);
  };
  for (LedType type : spectral::kAllLedTypes) {
    double level = state.drive[led_type_index(type)];
    if (!std::isfinite(level) || level < 0.0 || level > 1.0)
      refuse("drive level of " + std::string(led_type_name(type)) + " is " + std::to_string(level) +
             ", outside [0, 1]");
  }
  for (LedType type : spectral::kAllLedTypes) {
    const int i = led_type_index(type);
    const Polarisation polarisation = state.polarisation[i];
    if (static_cast<int>(polarisation) >= kPolarisationCodeCount)
      refuse("polarisation of " + std::string(led_type_name(type)) + " is code " +
             std::to_string(static_cast<int>(polarisation)) + " (0 unpolarised, 1 cross, 2 parallel)");
    if (polarisation != Polarisation::kUnpolarised && !info.polariser_banks[i])
      refuse("polarisation of " + std::string(led_type_name(type)) + " is " + polarisation_name(polarisation) +
             ", but the sphere has no polariser bank for " + std::string(led_type_name(type)) + " (unpolarised only)");
  }
  if (state.zone && (*state.zone < 0 || *state.zone >= info.zone_count))
    refuse("zone " + std::to_string(*state.zone) + " does not exist (device has " +
           std::to_string(info.zone_count) + ")");
  if (state.pwm_frequency_hz != 0.0) {
    if (info.drive_mode != DriveMode::kPwmDuty)
      refuse("PWM frequency given to a constant-current device");
    if (!(state.pwm_frequency_hz >= info.min_pwm_frequency_hz && state.pwm_frequency_hz <= info.max_pwm_frequency_hz))
      refuse("PWM frequency " + std::to_string(state.pwm_frequency_hz) + " Hz outside [" +
             std::to_string(info.min_pwm_frequency_hz) + ", " + std::to_string(info.max_pwm_frequency_hz) + "] Hz");
  }
}

void validate_sequence(std::span<const LedState> states, const LedControllerInfo& info, const std::string& device) {
  if (states.empty() || static_cast<int>(states.size()) > info.sequence_capacity)
    throw DeviceError(DeviceError::Kind::kInvalidRequest, device, "arm sequence",
                      std::to_string(states.size()) + " states, device holds 1.." +
                          std::to_string(info.sequence_capacity));
  for (const LedState& state : states) validate_state(state, info, device);
}

std::string describe_faults(std::uint32_t faults) {
  std::string text;
  auto add = [&](bool present, const char* name) {
    if (!present) return;
    if (!text.empty()) text += '+';
    text += name;
  };
  add(faults & kLedFaultOverTemperature, "over-temperature");
  add(faults & kLedFaultOpenCircuit, "open circuit");
  add(faults & kLedFaultShortCircuit, "short circuit");
  add(faults & kLedFaultSupply, "supply");
  add(faults & ~0xFu, "unknown bits");
  return text.empty() ? "none" : text;
}

void check_applied_state(const LedState& requested, const LedStatus& status, const std::string& device) {
  std::string faults;
  if (status.controller_faults != kLedFaultNone)
    faults += "controller: " + describe_faults(status.controller_faults);
  for (LedType type : spectral::kAllLedTypes) {
    int i = led_type_index(type);
    if (requested.drive[i] <= 0.0 || status.channel_faults[i] == kLedFaultNone) continue;
    if (!faults.empty()) faults += "; ";
    faults += led_type_name(type);
    faults += ": " + describe_faults(status.channel_faults[i]);
  }
  if (!faults.empty())
    throw DeviceError(DeviceError::Kind::kFault, device, "set state", "applied, but the device reports " + faults);
}

void validate_trigger_pulse(std::uint32_t pulse_width_us, const std::string& device) {
  if (pulse_width_us < kMinTriggerPulseWidthUs || pulse_width_us > kMaxTriggerPulseWidthUs)
    throw DeviceError(DeviceError::Kind::kInvalidRequest, device,
                      "fire trigger pulse of " + std::to_string(pulse_width_us) + " us",
                      "pulse width must be " + std::to_string(kMinTriggerPulseWidthUs) + "-" +
                          std::to_string(kMaxTriggerPulseWidthUs) + " us");
}

}  // namespace chromo::drivers::detail
