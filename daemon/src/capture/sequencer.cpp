// The steps loop of run_sequence (sequencer.hpp): per step the LED state,
// settle, the blue-light hazard check before the first subject, metering
// (metering_policy.hpp), the step's captures (synchronised_capture.hpp)
// handed to the pipeline, and the journal's step records.
//
// Thread rules: run_sequence and everything here on the session's own
// thread. RunControl, SynchronisedCapture and MeteringPolicy are this
// thread's too (the cameras' stream threads reach only
// SynchronisedCapture's collectors, under their own mutexes).
#include "chromo/daemon/internal/capture/sequencer.hpp"

#include "metering_policy.hpp"
#include "run_control.hpp"
#include "synchronised_capture.hpp"

namespace chromo::daemon {

using drivers::DriveLevels;
using drivers::LedState;

namespace {

class StepsLoop {
 public:
  explicit StepsLoop(SequencerContext& context) : c_(context), run_(context), capture_(run_) {}

  SequencerOutcome run() {
    SequencerOutcome outcome;
    try {
      run_.set_state(session::OperationState::kRunning, "starting");
      capture_.open_cameras();
      metering_.emplace(run_, capture_);
      outcome = steps();
    } catch (const std::exception& error) {
      outcome = {session::OperationState::kFailed, error.what()};
    }
    finish_devices();
    return outcome;
  }

 private:
  SequencerOutcome steps() {
    // Controllers keep their output stage off until told (the LED state is
    // applied but nothing is emitted): switch it on for the session.
    if (!run_.with_led("set_output_enabled", [](drivers::LedController& device) { device.set_output_enabled(true); }))
      return cancelled();
    if (hardware() && !run_.arm_from(0, 0)) return cancelled();
    for (std::size_t index = 0; index < c_.plan.steps.size(); ++index) {
      std::optional<SequencerOutcome> stop = step(c_.plan.steps[index], index);
      if (stop) return *stop;
    }
    return {session::OperationState::kSucceeded, ""};
  }

  // One step to its end: nullopt to go on, else how the session ends.
  std::optional<SequencerOutcome> step(const session::Step& step, std::size_t index) {
    c_.operations->update(c_.id, [&](session::OperationRecord& r) {
      r.step_index = static_cast<int>(index);
      r.message = "step " + step.name;
    });
    if (!step.prompt.empty()) {
      if (!run_.pause_by_daemon(step.prompt)) return cancelled();
    } else if (c_.control->pause_requested()) {
      if (!run_.pause_point("paused by the operator before step " + step.name)) return cancelled();
    }
    if (c_.control->cancel_requested()) return cancelled();
    if (c_.place_in_sphere) c_.place_in_sphere(step.role);
    const DriveLevels levels = run_.resolve(step);
    std::optional<session::FrameLedState> led = light(step, index, levels);
    if (!led) return cancelled();
    if (!c_.control->sleep_unless_cancelled(std::chrono::milliseconds(step.settle_ms))) return cancelled();
    if (step.role == session::StepRole::kSubject && !hazard_checked_) {
      hazard_checked_ = true;
      const std::string refusal = c_.check_hazard ? c_.check_hazard(metering_->known_exposures()) : "";
      if (!refusal.empty()) {
        c_.journal->append({{"type", "hazard_refused"}, {"step", step.name}, {"message", refusal}});
        return SequencerOutcome{session::OperationState::kFailed, refusal};
      }
    }
    if (step.meter_white_share > 0 && !metering_->meter_white(step, index, levels)) return cancelled();
    if (step.subject_fill > 0 && !metering_->meter_subject(step, index)) return cancelled();
    if (!capture_.ensure_exposure(metering_->exposures_of(step))) return cancelled();
    for (std::uint32_t frame = 0; frame < step.frames_per_camera; ++frame) {
      if (c_.control->cancel_requested()) return cancelled();
      std::optional<session::FrameLedState> at_trigger = led_at_trigger(*led);
      if (!at_trigger) return cancelled();
      std::optional<Capture> capture = capture_.take(step, index, frame);
      if (!capture) return cancelled();
      deliver(*capture, step, index, frame, *at_trigger);
      if (auto error = c_.pipeline->storage_error(); !error.empty())
        return SequencerOutcome{session::OperationState::kFailed, error};
      run_.count_frames(c_.cameras.size());
      run_.report_progress();
    }
    c_.pipeline->drain_storage();  // not the estimator: the next step does not wait for its tables
    if (auto error = c_.pipeline->storage_error(); !error.empty())
      return SequencerOutcome{session::OperationState::kFailed, error};
    c_.journal->append({{"type", "step_completed"}, {"step", step.name}, {"index", index},
                        {"frames", step.frames_per_camera * c_.cameras.size()}});
    return std::nullopt;
  }

  // Sets the step's LED state (software timing), reads the controller's
  // status and journals "step_started"; the LED state every frame of the
  // step records, with the temperatures and faults of its own trigger
  // (led_at_trigger). Hardware timing: the controller moves to this step's
  // state on the step's first trigger pulse, so before it the status still
  // shows the previous frame's; the frames are taken under the armed
  // levels. nullopt when cancelled.
  std::optional<session::FrameLedState> light(const session::Step& step, std::size_t index, const DriveLevels& levels) {
    if (!hardware()) {
      LedState state;
      state.drive = levels;
      state.polarisation = driven_polarisation(levels, step.polarisation);
      if (!run_.with_led("set_state", [&](drivers::LedController& device) { device.set_state(state); }))
        return std::nullopt;
    }
    drivers::LedStatus status;
    if (!run_.with_led("read_status", [&](drivers::LedController& device) { status = device.read_status(); }))
      return std::nullopt;
    session::FrameLedState led;
    led.drive = hardware() ? levels : status.applied.drive;
    led.requested_drive = levels;
    led.temperature_C = status.temperature_C;
    led.channel_faults = status.channel_faults;
    led.controller_faults = status.controller_faults;
    led.sequence_position = status.sequence_position;
    led.polarisation = hardware() ? driven_polarisation(levels, step.polarisation) : status.applied.polarisation;
    c_.journal->append({{"type", "step_started"}, {"step", step.name}, {"index", index}, {"led", session::to_json(led)},
                        {"exposure_us", step.exposure_us}, {"settle_ms", step.settle_ms},
                        {"timing", session::timing_name(c_.plan.timing)}});
    return led;
  }

  // The step's LED state with the temperatures and faults the controller
  // reports just before this capture's trigger: a junction warms or cools
  // through a step (its metering frames, its settle), so the step's first
  // reading is not the frames' (docs/formats/session.md, `led`). Drive,
  // polarisation and sequence position stay the step's. nullopt when
  // cancelled.
  std::optional<session::FrameLedState> led_at_trigger(const session::FrameLedState& step_led) {
    drivers::LedStatus status;
    if (!run_.with_led("read_status", [&](drivers::LedController& device) { status = device.read_status(); }))
      return std::nullopt;
    session::FrameLedState led = step_led;
    led.temperature_C = status.temperature_C;
    led.channel_faults = status.channel_faults;
    led.controller_faults = status.controller_faults;
    return led;
  }

  // A complete capture of the step: each camera's frame to the pipeline
  // with its record (a dark step's frames also to the metering's dark level).
  void deliver(Capture& capture, const session::Step& step, std::size_t index, std::uint32_t frame_in_step,
               const session::FrameLedState& led) {
    for (std::size_t k = 0; k < capture.frames.size(); ++k) {
      drivers::Frame& frame = capture.frames[k];
      if (step.role == session::StepRole::kDark) metering_->observe_dark(k, frame);
      CapturedFrame captured;
      captured.trigger_time = capture.trigger_time;
      session::FrameRecord& r = captured.record;
      r.step = step.name;
      r.step_index = static_cast<int>(index);
      r.role = step.role;
      r.frame_in_step = frame_in_step;
      r.led = led;
      r.camera = capture_.camera_name(k);
      r.exposure_us = capture_.exposure_us(k);
      r.sequence = frame.sequence;
      r.camera_frame_id = frame.camera_frame_id;
      r.camera_timestamp_ns = frame.camera_timestamp_ns;
      r.trigger_id = capture.trigger_id;
      r.camera_trigger_count = frame.trigger_count.value_or(0);
      r.host_timestamp_ns =
          std::chrono::duration_cast<std::chrono::nanoseconds>(frame.host_timestamp.time_since_epoch()).count();
      r.width = frame.width;
      r.height = frame.height;
      r.pixel_format = frame.pixel_format;
      captured.samples = std::move(frame.data);
      c_.pipeline->submit(std::move(captured));
    }
  }

  // The cameras' streams stopped (and the trigger summary journalled), the
  // LEDs dark (the hardware sequence disarmed), storage drained; the
  // estimator may go on: the daemon drains it.
  void finish_devices() {
    capture_.finish();
    if (c_.led && c_.led->device) {
      try {
        std::lock_guard lock(c_.led->mutex);
        if (hardware()) c_.led->device->disarm_sequence();
        c_.led->device->set_state(LedState{});
      } catch (const std::exception&) {
        // The controller is gone; nothing more to switch off from here.
      }
    }
    c_.pipeline->drain_storage();
  }

  bool hardware() const { return c_.plan.timing == session::Timing::kHardware; }
  static SequencerOutcome cancelled() { return {session::OperationState::kCancelled, ""}; }

  SequencerContext& c_;
  RunControl run_;
  SynchronisedCapture capture_;
  std::optional<MeteringPolicy> metering_;  // once the cameras are open
  bool hazard_checked_ = false;
};

}  // namespace

SequencerOutcome run_sequence(SequencerContext& context) { return StepsLoop(context).run(); }

}  // namespace chromo::daemon
