// RunControl: see run_control.hpp.
#include "run_control.hpp"

#include "chromo/daemon/internal/operations/operation_runner.hpp"
#include "chromo/drivers/device_error.hpp"

namespace chromo::daemon {

using drivers::DeviceError;
using drivers::DriveLevels;
using drivers::LedState;

drivers::PolarisationPerType driven_polarisation(const DriveLevels& levels, drivers::Polarisation polarisation) {
  drivers::PolarisationPerType per_type{};
  for (std::size_t i = 0; i < levels.size(); ++i)
    if (levels[i] > 0) per_type[i] = polarisation;
  return per_type;
}

RunControl::RunControl(SequencerContext& context)
    : c_(context),
      start_(std::chrono::steady_clock::now()),
      expected_(context.plan.frames_per_camera_total() * context.cameras.size()) {}

void RunControl::update(const std::function<void(session::OperationRecord&)>& change) {
  c_.operations->update(c_.id, change);
}

void RunControl::set_state(session::OperationState state, const std::string& message) {
  update([&](session::OperationRecord& r) {
    r.state = state;
    r.message = message;
  });
}

void RunControl::report_message(const std::string& message) {
  update([&](session::OperationRecord& r) { r.message = message; });
}

void RunControl::report_progress() {
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double progress = expected_ ? static_cast<double>(frames_done_) / static_cast<double>(expected_) : 1.0;
  update([&](session::OperationRecord& r) {
    r.progress = progress;
    r.eta_seconds = remaining_seconds(progress, elapsed_s);
    r.counters = c_.pipeline->counters();
  });
}

bool RunControl::pause_point(const std::string& message) {
  set_state(session::OperationState::kPaused, message);
  c_.journal->append({{"type", "state"}, {"state", "paused"}, {"message", message}});
  if (!c_.control->wait_while_paused()) return false;
  set_state(session::OperationState::kRunning, "resumed");
  c_.journal->append({{"type", "state"}, {"state", "running"}, {"message", "resumed"}});
  return true;
}

bool RunControl::pause_by_daemon(const std::string& message) {
  c_.control->pause_by_daemon();
  return pause_point(message);
}

bool RunControl::with_led(const char* request, const std::function<void(drivers::LedController&)>& call) {
  while (true) {
    if (c_.control->cancel_requested()) return false;
    if (!c_.led->device)
      throw std::runtime_error("LED controller \"" + c_.led->config.name + "\" is not open: " + c_.led->open_error);
    try {
      std::lock_guard lock(c_.led->mutex);
      call(*c_.led->device);
      return true;
    } catch (const DeviceError& error) {
      if (error.kind() != DeviceError::Kind::kTimeout && error.kind() != DeviceError::Kind::kDisconnected) throw;
      c_.journal->append({{"type", "device_error"}, {"device", c_.led->config.name}, {"request", request},
                          {"error", error.what()}});
      if (!pause_by_daemon("LED controller \"" + c_.led->config.name + "\" stopped answering (" + request + ": " +
                           error.answer() + "); resume to retry"))
        return false;
    }
  }
}

DriveLevels RunControl::resolve(const session::Step& step) const {
  switch (step.illumination.kind) {
    case session::Illumination::Kind::kDark: return DriveLevels{};
    case session::Illumination::Kind::kWeights: return step.illumination.weights;
    case session::Illumination::Kind::kMix: return c_.resolve_mix(step.illumination.mix, step.polarisation);
  }
  return DriveLevels{};
}

bool RunControl::arm_from(std::size_t step_index, std::uint32_t frame) {
  std::vector<LedState> states(1);
  for (std::size_t s = step_index; s < c_.plan.steps.size(); ++s) {
    LedState state;
    state.drive = resolve(c_.plan.steps[s]);
    state.polarisation = driven_polarisation(state.drive, c_.plan.steps[s].polarisation);
    for (std::uint32_t f = (s == step_index ? frame : 0); f < c_.plan.steps[s].frames_per_camera; ++f)
      states.push_back(state);
  }
  return with_led("arm_sequence", [&](drivers::LedController& device) {
    device.arm_sequence(states, drivers::SequenceTrigger::kTriggerOutput);
  });
}

}  // namespace chromo::daemon
