#pragma once
// Rules shared by every LED controller backend: what the driver refuses to
// send (kInvalidRequest) and what it reports after a state was applied
// (kFault when the device reports a fault on a driven channel).

#include <span>
#include <string>

#include "chromo/drivers/led_controller.hpp"

namespace chromo::drivers::detail {

void validate_state(const LedState& state, const LedControllerInfo& info, const std::string& device);
// 1..sequence_capacity states, each valid.
void validate_sequence(std::span<const LedState> states, const LedControllerInfo& info, const std::string& device);
// After set_state: throws DeviceError(kFault) if the controller reports a
// controller fault, or a fault on a channel the state drives above zero.
void check_applied_state(const LedState& requested, const LedStatus& status, const std::string& device);
std::string describe_faults(std::uint32_t faults);
// fire_trigger's width within [kMinTriggerPulseWidthUs, kMaxTriggerPulseWidthUs].
void validate_trigger_pulse(std::uint32_t pulse_width_us, const std::string& device);

}  // namespace chromo::drivers::detail
