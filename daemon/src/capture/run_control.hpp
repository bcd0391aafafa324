#pragma once
// RunControl: a running session's link to its operation and to its LED
// controller, shared by the steps loop (sequencer.cpp), synchronised capture
// (synchronised_capture.hpp) and the metering policy (metering_policy.hpp):
// the operation's state and message, pauses (journalled), the one progress
// and ETA of the capture, and LED controller calls that pause the session
// while the controller does not answer.
//
// Thread rules: the session's own thread only (the sequencer's). What it
// calls (registry, control, journal, pipeline counters) is thread-safe.

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

#include "chromo/daemon/internal/capture/sequencer.hpp"

namespace chromo::daemon {

class RunControl {
 public:
  // Starts the clock of the ETA; the plan's frames (every camera) are the whole.
  explicit RunControl(SequencerContext& context);

  SequencerContext& context() { return c_; }
  const SequencerContext& context() const { return c_; }

  void set_state(session::OperationState state, const std::string& message);
  void report_message(const std::string& message);
  // `frames` more frames are stored (the capture's progress).
  void count_frames(std::uint64_t frames) { frames_done_ += frames; }
  // The operation's progress (frames stored ÷ the plan's), its ETA
  // (remaining_seconds) and the pipeline's counters.
  void report_progress();

  // PAUSED with `message` (journalled) until resumed: true, RUNNING again;
  // false when cancelled instead.
  bool pause_point(const std::string& message);
  // The daemon pauses the session itself (a prompt, a device that stopped
  // answering), then as pause_point.
  bool pause_by_daemon(const std::string& message);

  // Calls the LED controller under its lock; when it does not answer
  // (DeviceError timeout/disconnected), journals "device_error", pauses with
  // a message naming it and the request, and retries after resume. False
  // when cancelled; other errors propagate (std::runtime_error when the
  // controller is not open).
  bool with_led(const char* request, const std::function<void(drivers::LedController&)>& call);

  // A step's drive levels: dark, its weights, or its mix resolved for its
  // polarisation state (SequencerContext::resolve_mix).
  drivers::DriveLevels resolve(const session::Step& step) const;
  // Hardware timing: arms the sequence from (step, frame) to the end. State
  // 0 is the resting state (LEDs dark) shown until the first trigger: the
  // controller advances on each pulse of its own trigger output before the
  // pulse leaves, so the capture of pulse k is taken under state k. False
  // when cancelled.
  bool arm_from(std::size_t step_index, std::uint32_t frame);

 private:
  void update(const std::function<void(session::OperationRecord&)>& change);

  SequencerContext& c_;
  std::chrono::steady_clock::time_point start_;
  std::uint64_t expected_ = 0, frames_done_ = 0;
};

// A step's polarisation on the LED types it drives; undriven types stay
// unpolarised (a type without polariser banks may then sit out a cross step).
drivers::PolarisationPerType driven_polarisation(const drivers::DriveLevels& levels,
                                                 drivers::Polarisation polarisation);

}  // namespace chromo::daemon
