#include "chromo/daemon/internal/capture/sequencer.hpp"

#include <algorithm>
#include <condition_variable>
#include <map>
#include <optional>
#include <thread>

#include "chromo/daemon/internal/capture/exposure_metering.hpp"
#include "chromo/drivers/device_error.hpp"
#include "chromo/session/method_measurement.hpp"  // session::subject_exposure_ratio

namespace chromo::daemon {

using drivers::DeviceError;
using drivers::DriveLevels;
using drivers::LedState;

namespace {

// A step's polarisation on the LED types it drives; undriven types stay
// unpolarised (a type without polariser banks may then sit out a cross step).
drivers::PolarisationPerType driven_polarisation(const DriveLevels& levels, drivers::Polarisation polarisation) {
  drivers::PolarisationPerType per_type{};
  for (std::size_t i = 0; i < levels.size(); ++i)
    if (levels[i] > 0) per_type[i] = polarisation;
  return per_type;
}

std::string frame_status_reason(drivers::FrameStatus status) {
  switch (status) {
    case drivers::FrameStatus::kMissingPackets: return "missing_packets";
    case drivers::FrameStatus::kTimeout: return "timeout";
    case drivers::FrameStatus::kAborted: return "aborted";
    case drivers::FrameStatus::kError: return "error";
    case drivers::FrameStatus::kComplete: return "complete";
  }
  return "error";
}

bool is_unanswered(const DeviceError& error) {
  return error.kind() == DeviceError::Kind::kTimeout || error.kind() == DeviceError::Kind::kDisconnected;
}

// The trigger output's pulse: long enough for any camera's input filter.
constexpr std::uint32_t kTriggerPulseWidthUs = 100;

// One camera's side of the captures: what it owes (the trigger it was sent
// last, by its own count since its stream started) and what it answered.
// The stream thread fills the answer; the sequencer thread reads it.
struct CameraCollector {
  NamedDevice<drivers::Camera>* camera = nullptr;
  bool hardware_triggered = false;  // its trigger input is wired to the LED controller's output (const)
  std::mutex mutex;
  std::condition_variable arrived;
  // Guarded by mutex:
  std::uint64_t triggers_sent = 0;   // the camera's count of the last trigger it was sent (0 after a stream start)
  std::map<std::uint64_t, std::uint64_t> trigger_of_count;  // camera count -> trigger id (the controller's pulse)
  std::uint64_t awaited_count = 0;   // the trigger a capture waits for, by the camera's count; 0 = none
  bool answered = false;             // the camera answered the awaited trigger (complete, failed or mismatched)
  drivers::FrameStatus answer_status = drivers::FrameStatus::kComplete;
  std::string answer_problem;        // why an answer does not count ("" when it does)
  std::optional<drivers::Frame> answer;  // the complete frame of the awaited trigger
  std::uint64_t late_frames = 0;     // complete frames of earlier triggers, discarded
  std::uint64_t failed_frames = 0;   // failed frames of no awaited trigger, discarded (lost)
  // Sequencer thread only:
  bool streaming = false;
  bool resync = false;               // its count may disagree with triggers_sent: restart its stream
  std::uint64_t reconnects_at_start = 0;
  double exposure_us = -1;           // configured
  FrameLevels metered;               // levels of the last white metering frame
  SubjectLevels subject_seen;        // levels of the last subject metering frame
  std::array<double, 3> white_like_from{};  // its subject_levels ceiling per channel (share of full scale)
  std::array<double, 3> dark{};      // mean dark level per channel (share of full scale), from the dark step's frames
  std::uint32_t dark_frames = 0;
  std::uint64_t missed = 0;          // captures it spoiled (named in the journal)
};

class Run {
 public:
  explicit Run(SequencerContext& context) : c_(context) {}

  SequencerOutcome run() {
    start_ = std::chrono::steady_clock::now();
    expected_ = c_.plan.frames_per_camera_total() * c_.cameras.size();
    try {
      set_state(session::OperationState::kRunning, "starting");
      create_collectors();
      SequencerOutcome outcome = steps();
      finish_devices();
      return outcome;
    } catch (const std::exception& error) {
      finish_devices();
      return {session::OperationState::kFailed, error.what()};
    }
  }

 private:
  SequencerOutcome steps() {
    const bool hardware = c_.plan.timing == session::Timing::kHardware;
    // Controllers keep their output stage off until told (the LED state is
    // applied but nothing is emitted): switch it on for the session.
    if (!with_led("set_output_enabled", [](drivers::LedController& device) { device.set_output_enabled(true); }))
      return cancelled();
    if (hardware && !arm_from(0, 0)) return cancelled();
    for (std::size_t index = 0; index < c_.plan.steps.size(); ++index) {
      const session::Step& step = c_.plan.steps[index];
      update([&](session::OperationRecord& r) {
        r.step_index = static_cast<int>(index);
        r.message = "step " + step.name;
      });
      if (!step.prompt.empty()) {
        c_.control->pause_by_daemon();
        if (!pause_point(step.prompt)) return cancelled();
      } else if (c_.control->pause_requested()) {
        if (!pause_point("paused by the operator before step " + step.name)) return cancelled();
      }
      if (c_.control->cancel_requested()) return cancelled();
      if (c_.place_in_sphere) c_.place_in_sphere(step.role);
      DriveLevels levels = resolve(step);
      if (!hardware) {
        LedState state;
        state.drive = levels;
        state.polarisation = driven_polarisation(levels, step.polarisation);
        if (!with_led("set_state", [&](drivers::LedController& device) { device.set_state(state); })) return cancelled();
      }
      drivers::LedStatus status;
      if (!with_led("read_status", [&](drivers::LedController& device) { status = device.read_status(); }))
        return cancelled();
      // Hardware timing: the controller moves to this step's state on the
      // step's first trigger pulse, so before it the status still shows the state
      // of the previous frame; the frames were taken under the armed levels.
      session::FrameLedState led;
      led.drive = hardware ? levels : status.applied.drive;
      led.requested_drive = levels;
      led.temperature_C = status.temperature_C;
      led.channel_faults = status.channel_faults;
      led.controller_faults = status.controller_faults;
      led.sequence_position = status.sequence_position;
      led.polarisation = hardware ? driven_polarisation(levels, step.polarisation) : status.applied.polarisation;
      c_.journal->append({{"type", "step_started"}, {"step", step.name}, {"index", index}, {"led", session::to_json(led)},
                          {"exposure_us", step.exposure_us}, {"settle_ms", step.settle_ms},
                          {"timing", session::timing_name(c_.plan.timing)}});
      if (!c_.control->sleep_unless_cancelled(std::chrono::milliseconds(step.settle_ms))) return cancelled();
      if (step.role == session::StepRole::kSubject && !hazard_checked_) {
        hazard_checked_ = true;
        if (c_.check_hazard) {
          const std::string refusal = c_.check_hazard(known_exposures());
          if (!refusal.empty()) {
            c_.journal->append({{"type", "hazard_refused"}, {"step", step.name}, {"message", refusal}});
            return {session::OperationState::kFailed, refusal};
          }
        }
      }
      if (step.meter_white_share > 0 && !meter(step, static_cast<int>(index), levels)) return cancelled();
      if (step.subject_fill > 0 && !meter_subject(step, static_cast<int>(index))) return cancelled();
      if (!ensure_exposure(exposures_of(step))) return cancelled();
      for (std::uint32_t frame = 0; frame < step.frames_per_camera; ++frame) {
        if (c_.control->cancel_requested()) return cancelled();
        session::FrameRecord pending;
        pending.step = step.name;
        pending.step_index = static_cast<int>(index);
        pending.role = step.role;
        pending.frame_in_step = frame;
        pending.exposure_us = step.exposure_us;
        pending.led = led;
        if (!take_frame(step, static_cast<int>(index), frame, pending, false)) return cancelled();
        if (auto error = c_.pipeline->storage_error(); !error.empty()) return {session::OperationState::kFailed, error};
        frames_done_ += c_.cameras.size();
        report_progress();
      }
      c_.pipeline->drain_storage();  // not the estimator: the next step does not wait for its tables
      if (auto error = c_.pipeline->storage_error(); !error.empty()) return {session::OperationState::kFailed, error};
      c_.journal->append({{"type", "step_completed"}, {"step", step.name}, {"index", index},
                          {"frames", step.frames_per_camera * c_.cameras.size()}});
    }
    return {session::OperationState::kSucceeded, ""};
  }

  // One capture: every camera's frame of one trigger (see sequencer.hpp,
  // "Synchronised capture"). The LED controller fires a pulse (the hardware-
  // triggered cameras expose on it, a kTriggerOutput sequence shows the
  // frame's state before it), the other cameras are software-triggered with
  // the same trigger id; the capture counts only when every camera answered
  // that trigger, else it is retaken for all. False when cancelled.
  bool take_frame(const session::Step& step, int index, std::uint32_t frame_in_step, const session::FrameRecord& pending,
                  bool metering) {
    std::uint32_t attempts = 0;
    while (true) {
      if (c_.control->cancel_requested()) return false;
      if (!resync_streams()) return false;
      for (auto& collector : collectors_) {
        std::lock_guard lock(collector->mutex);
        collector->awaited_count = ++collector->triggers_sent;
        collector->answered = false;
        collector->answer.reset();
        collector->answer_problem.clear();
      }
      const auto trigger_time = std::chrono::steady_clock::now();
      std::uint32_t trigger_id = 0;
      if (!with_led("fire_trigger", [&](drivers::LedController& device) {
            trigger_id = device.fire_trigger(kTriggerPulseWidthUs);
          }))
        return false;
      ++triggers_fired_;
      for (auto& collector : collectors_) {
        std::lock_guard lock(collector->mutex);
        collector->trigger_of_count[collector->awaited_count] = trigger_id;
        while (collector->trigger_of_count.size() > 256) collector->trigger_of_count.erase(collector->trigger_of_count.begin());
      }
      for (auto& collector : collectors_) {
        if (collector->hardware_triggered) continue;
        try {
          std::lock_guard device_lock(collector->camera->mutex);
          collector->camera->device->software_trigger();
        } catch (const DeviceError& error) {
          collector->resync = true;  // whether the camera counted that trigger is unknown
          std::lock_guard lock(collector->mutex);
          collector->answered = true;
          collector->answer_status = drivers::FrameStatus::kError;
          collector->answer_problem = std::string("camera_unreachable: ") + error.what();
        }
      }
      double longest_exposure_us = 0;
      for (const auto& collector : collectors_) longest_exposure_us = std::max(longest_exposure_us, collector->exposure_us);
      const auto deadline = std::chrono::steady_clock::now() +
                            std::chrono::microseconds(static_cast<long long>(longest_exposure_us)) +
                            std::chrono::milliseconds(c_.frame_timeout_ms);
      // Judge each camera's answer and stop waiting for it, in one step: a
      // frame arriving after this is late and discarded.
      std::vector<std::pair<CameraCollector*, std::string>> missed;
      std::vector<drivers::Frame> frames;
      for (auto& collector : collectors_) {
        std::unique_lock lock(collector->mutex);
        collector->arrived.wait_until(lock, deadline, [&] { return collector->answered; });
        std::string problem;
        if (!collector->answered) problem = "no_frame";
        else if (!collector->answer_problem.empty()) problem = collector->answer_problem;
        else if (collector->answer_status != drivers::FrameStatus::kComplete) problem = frame_status_reason(collector->answer_status);
        collector->awaited_count = 0;
        if (problem.empty()) frames.push_back(std::move(*collector->answer));
        else missed.emplace_back(collector.get(), problem);
        collector->answer.reset();
      }
      if (missed.empty()) {
        deliver_capture(frames, pending, trigger_id, trigger_time, metering);
        return true;
      }
      if (!retake(step, static_cast<std::size_t>(index), frame_in_step, trigger_id, missed, frames.size(), attempts))
        return false;
    }
  }

  // A capture one camera or more spoiled: named and counted in the journal,
  // the other cameras' frames of that trigger discarded; pauses after
  // frame_attempts captures in a row. False when cancelled.
  bool retake(const session::Step& step, std::size_t index, std::uint32_t frame_in_step, std::uint32_t trigger_id,
              const std::vector<std::pair<CameraCollector*, std::string>>& missed, std::size_t discarded,
              std::uint32_t& attempts) {
    ++retakes_;
    discarded_frames_ += discarded;
    nlohmann::json names = nlohmann::json::array();
    std::string listing;
    for (const auto& [collector, problem] : missed) {
      ++collector->missed;
      const std::string& name = collector->camera->config.name;
      names.push_back(name);
      listing += (listing.empty() ? "" : ", ") + ("camera \"" + name + "\" (" + problem + ")");
      const std::string reason = problem.substr(0, problem.find(':'));
      c_.pipeline->record_lost(reason);
      c_.journal->append({{"type", "frame_lost"}, {"step", step.name}, {"camera", name}, {"trigger_id", trigger_id},
                          {"reason", reason}, {"detail", problem}});
      if (reason == "trigger_mismatch") collector->resync = true;
    }
    c_.journal->append({{"type", "capture_retaken"}, {"step", step.name}, {"trigger_id", trigger_id},
                        {"cameras", names}, {"discarded_frames", discarded}, {"retakes", retakes_}});
    report_message("step " + step.name + ": trigger " + std::to_string(trigger_id) + " missed by " + listing +
                   "; capture retaken for every camera");
    report_progress();
    if (++attempts >= c_.frame_attempts) {
      c_.control->pause_by_daemon();
      if (!pause_point("step " + step.name + ": " + listing + " missed " + std::to_string(attempts) +
                       " triggers in a row; resume to retry"))
        return false;
      attempts = 0;
    }
    // Hardware timing: the missed trigger advanced the armed sequence; arm it
    // again from this frame so that the retake's trigger shows its state.
    if (c_.plan.timing == session::Timing::kHardware && !arm_from(index, frame_in_step)) return false;
    return true;
  }

  // Every camera answered trigger_id: the frames become the capture
  // (metering levels, or the pipeline with their records).
  void deliver_capture(std::vector<drivers::Frame>& frames, const session::FrameRecord& pending, std::uint32_t trigger_id,
                       std::chrono::steady_clock::time_point trigger_time, bool metering) {
    for (std::size_t k = 0; k < collectors_.size(); ++k) {
      CameraCollector& collector = *collectors_[k];
      drivers::Frame& frame = frames[k];
      if (metering) {
        try {
          if (subject_percentile_ > 0)
            collector.subject_seen = subject_levels(frame.data, frame.width, frame.height, frame.pixel_format,
                                                    subject_percentile_, collector.white_like_from);
          else
            collector.metered = frame_levels(frame.data, frame.width, frame.height, frame.pixel_format, FrameRegion::kLit);
        } catch (const std::exception& failure) {
          throw std::runtime_error("camera \"" + collector.camera->config.name + "\": " + failure.what());
        }
        continue;
      }
      if (pending.role == session::StepRole::kDark) {
        try {  // the dark level the metering subtracts (the mean over the dark step's frames)
          const FrameLevels levels = frame_levels(frame.data, frame.width, frame.height, frame.pixel_format);
          const double n = collector.dark_frames++;
          for (int c = 0; c < 3; ++c) collector.dark[c] = (collector.dark[c] * n + levels.mean[c]) / (n + 1);
        } catch (const std::exception&) {
          // A frame the pipeline will refuse anyway; the metering then assumes no dark level.
        }
      }
      CapturedFrame captured;
      captured.trigger_time = trigger_time;
      session::FrameRecord& r = captured.record;
      r = pending;
      r.camera = collector.camera->config.name;
      r.exposure_us = collector.exposure_us;
      r.sequence = frame.sequence;
      r.camera_frame_id = frame.camera_frame_id;
      r.camera_timestamp_ns = frame.camera_timestamp_ns;
      r.trigger_id = trigger_id;
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

  // Restarts the streams when a camera's trigger count may no longer match
  // the sequencer's (a trigger it may or may not have counted, a frame
  // answering a trigger it was never sent, a reconnect of the driver, which
  // restarts acquisition): AcquisitionStart resets the camera's count.
  // False when cancelled.
  bool resync_streams() {
    bool needed = false;
    for (auto& collector : collectors_) {
      std::lock_guard lock(collector->camera->mutex);
      needed = needed || collector->resync ||
               collector->camera->device->statistics().reconnects != collector->reconnects_at_start;
    }
    if (!needed) return true;
    std::vector<double> exposure;
    for (const auto& collector : collectors_) exposure.push_back(collector->exposure_us);
    return ensure_exposure(exposure, true);
  }

  // Calls the LED controller; when it does not answer, pauses with a clear
  // message and retries after resume. False when cancelled.
  bool with_led(const char* request, const std::function<void(drivers::LedController&)>& call) {
    while (true) {
      if (c_.control->cancel_requested()) return false;
      if (!c_.led->device) throw std::runtime_error("LED controller \"" + c_.led->config.name + "\" is not open: " + c_.led->open_error);
      try {
        std::lock_guard lock(c_.led->mutex);
        call(*c_.led->device);
        return true;
      } catch (const DeviceError& error) {
        if (!is_unanswered(error)) throw;
        c_.journal->append({{"type", "device_error"}, {"device", c_.led->config.name}, {"request", request},
                            {"error", error.what()}});
        c_.control->pause_by_daemon();
        if (!pause_point("LED controller \"" + c_.led->config.name + "\" stopped answering (" + request + ": " +
                         error.answer() + "); resume to retry"))
          return false;
      }
    }
  }

  // Arms the hardware sequence from (step, frame) to the end. State 0 is the
  // resting state (LEDs dark) shown until the first trigger: the controller
  // advances on each pulse of its own trigger output before the pulse leaves,
  // so the capture of pulse k is taken under state k.
  bool arm_from(std::size_t step_index, std::uint32_t frame) {
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

  bool pause_point(const std::string& message) {
    set_state(session::OperationState::kPaused, message);
    c_.journal->append({{"type", "state"}, {"state", "paused"}, {"message", message}});
    bool resumed = c_.control->wait_while_paused();
    if (!resumed) return false;
    set_state(session::OperationState::kRunning, "resumed");
    c_.journal->append({{"type", "state"}, {"state", "running"}, {"message", "resumed"}});
    return true;
  }

  DriveLevels resolve(const session::Step& step) {
    switch (step.illumination.kind) {
      case session::Illumination::Kind::kDark: return DriveLevels{};
      case session::Illumination::Kind::kWeights: return step.illumination.weights;
      case session::Illumination::Kind::kMix: return c_.resolve_mix(step.illumination.mix, step.polarisation);
    }
    return DriveLevels{};
  }

  void create_collectors() {
    for (auto* camera : c_.cameras) {
      if (!camera->device) throw std::runtime_error("camera \"" + camera->config.name + "\" is not open: " + camera->open_error);
      auto collector = std::make_unique<CameraCollector>();
      collector->camera = camera;
      collector->hardware_triggered = camera_capture_settings(camera->config).trigger_mode == drivers::TriggerMode::kHardware;
      collectors_.push_back(std::move(collector));
    }
  }

  // Cameras take settings only while they do not stream (AravisCamera): when
  // a camera's exposure differs from the one configured, the streams stop, the
  // cameras are configured, the streams start again. A camera that does not
  // answer pauses the session naming it; resume retries. False when cancelled.
  // exposure_us: one per camera (collectors_ order).
  // restart: restart the streams even when the exposures are unchanged.
  bool ensure_exposure(const std::vector<double>& exposure_us, bool restart = false) {
    bool same = !restart;
    for (std::size_t k = 0; k < collectors_.size(); ++k) same = same && collectors_[k]->exposure_us == exposure_us[k];
    if (same) return true;
    while (true) {
      if (c_.control->cancel_requested()) return false;
      std::string failing, failure;
      try {
        stop_streams();
        for (std::size_t k = 0; k < collectors_.size(); ++k) {
          failing = collectors_[k]->camera->config.name;
          collectors_[k]->exposure_us = -1;
          configure_camera(*collectors_[k]->camera, exposure_us[k]);
          collectors_[k]->exposure_us = exposure_us[k];
        }
        for (auto& collector : collectors_) {
          failing = collector->camera->config.name;
          CameraCollector* raw = collector.get();
          std::lock_guard lock(collector->camera->mutex);
          {
            std::lock_guard counts(collector->mutex);  // AcquisitionStart resets the camera's trigger count
            collector->triggers_sent = 0;
            collector->trigger_of_count.clear();
            collector->awaited_count = 0;
          }
          collector->reconnects_at_start = collector->camera->device->statistics().reconnects;
          collector->camera->device->start_stream([this, raw](drivers::Frame&& frame) { on_frame(*raw, std::move(frame)); });
          collector->streaming = true;
          collector->resync = false;
        }
        return true;
      } catch (const DeviceError& error) {
        if (!is_unanswered(error)) throw;
        failure = error.what();
      }
      c_.journal->append({{"type", "device_error"}, {"device", failing}, {"request", "configure"}, {"error", failure}});
      c_.control->pause_by_daemon();
      if (!pause_point("camera \"" + failing + "\" does not answer (" + failure + "); resume to retry")) return false;
    }
  }

  // The exposure of each camera for a step: metered (its own or exposure_from's), else the plan's;
  // a subject-metered step's multiplied by its ratio once metered (before: its white's, the metering frame's).
  std::vector<double> exposures_of(const session::Step& step) const {
    if (!step.linearity_of.empty()) return linearity_exposures(step);
    const std::string& metered_at = step.meter_white_share > 0 ? step.name : step.exposure_from;
    if (!metered_at.empty()) {
      auto found = metered_.find(metered_at);
      if (found == metered_.end())
        throw std::logic_error("step " + step.name + ": no exposure metered at step " + metered_at);
      std::vector<double> exposure = found->second;
      const std::string& ratio_at = subject_ratio_step(step);
      if (auto ratio = subject_ratio_.find(ratio_at); !ratio_at.empty() && ratio != subject_ratio_.end())
        for (std::size_t k = 0; k < exposure.size(); ++k) exposure[k] *= ratio->second[k];
      return exposure;
    }
    return std::vector<double>(collectors_.size(), step.exposure_us);
  }

  // Every step's exposure as far as known (metered steps: the longest over the
  // cameras; a subject-metered step not yet metered at its maximum ratio: the
  // hazard check before the first subject bounds the dose the metering may reach).
  std::map<std::string, double> known_exposures() const {
    std::map<std::string, double> out;
    for (const auto& step : c_.plan.steps) {
      if (!step.linearity_of.empty()) {  // once metered; before, its subject's bound (≥ its white's: g ≥ 1)
        try {
          const std::vector<double> exposure = linearity_exposures(step);
          out[step.name] = *std::max_element(exposure.begin(), exposure.end());
        } catch (const std::logic_error&) {
          if (auto subject = out.find(step.linearity_of); subject != out.end()) out[step.name] = subject->second;
        }
        continue;
      }
      const std::string& metered_at = step.meter_white_share > 0 ? step.name : step.exposure_from;
      auto found = metered_.find(metered_at);
      if (metered_at.empty() || found == metered_.end()) continue;
      const std::vector<double> exposure = exposures_of(step);
      double longest = *std::max_element(exposure.begin(), exposure.end());
      const std::string& ratio_at = subject_ratio_step(step);
      if (!ratio_at.empty() && !subject_ratio_.count(ratio_at)) longest *= max_subject_ratio(step);
      out[step.name] = longest;
    }
    return out;
  }

  // The step whose metered subject/white ratio g a step's exposure takes: its
  // own when it meters the subject, else its subject_ratio_from ("" for none).
  static const std::string& subject_ratio_step(const session::Step& step) {
    return step.subject_fill > 0 ? step.name : step.subject_ratio_from;
  }

  // A linearity white (Step::linearity_of): its subject's white's exposure ÷
  // that subject's g, per camera (the subject metered before it).
  std::vector<double> linearity_exposures(const session::Step& step) const {
    const auto subject = std::find_if(c_.plan.steps.begin(), c_.plan.steps.end(),
                                      [&](const session::Step& s) { return s.name == step.linearity_of; });
    if (subject == c_.plan.steps.end())
      throw std::logic_error("step " + step.name + ": no step " + step.linearity_of + " to check the linearity of");
    const std::string& ratio_at = subject_ratio_step(*subject);
    const auto ratio = subject_ratio_.find(ratio_at);
    const auto white = metered_.find(subject->exposure_from);
    if (ratio == subject_ratio_.end() || white == metered_.end())
      throw std::logic_error("step " + step.name + ": " + step.linearity_of + " is not metered yet");
    std::vector<double> exposure = white->second;
    for (std::size_t k = 0; k < exposure.size(); ++k) exposure[k] /= ratio->second[k];
    return exposure;
  }

  double max_subject_ratio(const session::Step& step) const {
    if (step.subject_fill > 0) return step.max_subject_exposure_ratio;
    for (const auto& s : c_.plan.steps)
      if (s.name == step.subject_ratio_from) return s.max_subject_exposure_ratio;
    return 1;
  }

  // Meters the subject of a step (Step::subject_fill): one frame of the
  // subject at its white's exposure; per camera, the subject_percentile of
  // each channel over the samples below kSubjectWhiteLikeShare of the white's
  // signal (subject_levels: the white target or a reference strip in view is
  // not the subject), and the ratio g that puts the brightest channel's at
  // subject_fill of full scale (session::subject_exposure_ratio, the dark
  // level subtracted); sets subject_ratio_[step.name].
  bool meter_subject(const session::Step& step, int index) {
    const std::vector<double> white = exposures_of(step);
    if (!ensure_exposure(white)) return false;
    const std::vector<std::array<double, 3>>& white_level = white_level_.at(step.exposure_from);
    for (std::size_t k = 0; k < collectors_.size(); ++k)
      for (int c = 0; c < 3; ++c) {
        const double dark = collectors_[k]->dark[c];
        collectors_[k]->white_like_from[c] = dark + kSubjectWhiteLikeShare * (white_level[k][c] - dark);
      }
    session::FrameRecord pending;
    pending.step = step.name;
    pending.step_index = index;
    pending.role = step.role;
    subject_percentile_ = step.subject_percentile;
    const bool taken = take_frame(step, index, 0, pending, true);
    subject_percentile_ = 0;
    if (!taken) return false;
    std::vector<double> ratio(collectors_.size(), 1.0);
    for (std::size_t k = 0; k < collectors_.size(); ++k) {
      const SubjectLevels& seen = collectors_[k]->subject_seen;
      const std::array<double, 3>& dark = collectors_[k]->dark;
      int brightest = 0;
      for (int c = 1; c < 3; ++c)
        if (seen.level[c] - dark[c] > seen.level[brightest] - dark[brightest]) brightest = c;
      ratio[k] = session::subject_exposure_ratio(seen.level[brightest], dark[brightest], step.subject_fill,
                                                 step.max_subject_exposure_ratio);
      c_.journal->append({{"type", "subject_metered"},
                          {"step", step.name},
                          {"camera", collectors_[k]->camera->config.name},
                          {"white_exposure_us", white[k]},
                          {"exposure_us", white[k] * ratio[k]},
                          {"exposure_ratio", ratio[k]},
                          {"capped", ratio[k] >= step.max_subject_exposure_ratio},
                          {"channel", brightest},
                          {"percentile", step.subject_percentile},
                          {"level", seen.level[brightest]},
                          {"white_like_from", collectors_[k]->white_like_from[brightest]},
                          {"white_like_share", seen.white_like_share},
                          {"target_fill", step.subject_fill}});
    }
    subject_ratio_[step.name] = ratio;
    return true;
  }

  // Meters the white of a step (see sequencer.hpp): sets metered_[step.name].
  bool meter(const session::Step& step, int index, const DriveLevels& levels) {
    constexpr int kMaxMeteringFrames = 6;
    const std::optional<std::array<double, 3>> predicted =
        c_.predict_white_rgb ? c_.predict_white_rgb(levels) : std::nullopt;
    std::vector<double> exposure(collectors_.size(), step.exposure_us);
    std::vector<MeteringTarget> targets(collectors_.size());
    for (std::size_t k = 0; k < collectors_.size(); ++k) {
      auto& camera = *collectors_[k]->camera;
      drivers::CameraInfo info;
      {
        std::lock_guard lock(camera.mutex);
        info = camera.device->info();
      }
      targets[k].white_share = step.meter_white_share;
      targets[k].dark = collectors_[k]->dark;
      if (info.exposure_min_us > 0) targets[k].min_exposure_us = info.exposure_min_us;
      targets[k].max_exposure_us = info.exposure_max_us > 0 ? std::min(info.exposure_max_us, session::kMaxExposureUs)
                                                            : session::kMaxExposureUs;
      if (predicted && last_metered_prediction_ && !last_metered_exposure_.empty()) {
        const double now = *std::max_element(predicted->begin(), predicted->end());
        const double before = *std::max_element(last_metered_prediction_->begin(), last_metered_prediction_->end());
        if (now > 0 && before > 0)
          exposure[k] = last_metered_exposure_[k] * (before / now) * (step.meter_white_share / last_metered_share_);
      }
      exposure[k] = std::clamp(exposure[k], targets[k].min_exposure_us, targets[k].max_exposure_us);
    }
    const std::vector<double> first_guess = exposure;
    std::vector<bool> done(collectors_.size(), false), at_limit(collectors_.size(), false);
    std::vector<int> frames(collectors_.size(), 0);
    std::vector<double> reached(collectors_.size(), 0), measured_at(collectors_.size(), 0);
    for (int attempt = 0; attempt < kMaxMeteringFrames; ++attempt) {
      if (!ensure_exposure(exposure)) return false;
      session::FrameRecord pending;
      pending.step = step.name;
      pending.step_index = index;
      pending.role = step.role;
      if (!take_frame(step, index, 0, pending, true)) return false;
      bool all_done = true;
      for (std::size_t k = 0; k < collectors_.size(); ++k) {
        if (done[k]) continue;
        ++frames[k];
        const FrameLevels& seen = collectors_[k]->metered;
        reached[k] = seen.mean[seen.brightest_channel()];
        const MeteringDecision d = next_metering_exposure(exposure[k], seen, targets[k]);
        if (d.at_limit) at_limit[k] = true;
        measured_at[k] = exposure[k];
        done[k] = d.done;
        // Within the tolerance: the last small correction is applied too.
        if (!d.at_limit) exposure[k] = d.next_exposure_us;
        all_done = all_done && done[k];
      }
      if (all_done) break;
    }
    for (std::size_t k = 0; k < collectors_.size(); ++k) {
      c_.journal->append({{"type", "exposure_metered"},
                          {"step", step.name},
                          {"camera", collectors_[k]->camera->config.name},
                          {"exposure_us", exposure[k]},
                          {"first_guess_us", first_guess[k]},
                          {"white_share", reached[k]},
                          {"white_share_measured_at_us", measured_at[k]},
                          {"target_share", step.meter_white_share},
                          {"metering_frames", frames[k]},
                          {"converged", static_cast<bool>(done[k])},
                          {"at_limit", static_cast<bool>(at_limit[k])}});
      if (at_limit[k])
        report_message("step " + step.name + ": camera \"" + collectors_[k]->camera->config.name +
                       "\": the white reaches " + std::to_string(reached[k]) + " of full scale at the exposure limit " +
                       std::to_string(exposure[k]) + " us (target " + std::to_string(step.meter_white_share) + ")");
    }
    metered_[step.name] = exposure;
    std::vector<std::array<double, 3>>& white_level = white_level_[step.name];
    white_level.assign(collectors_.size(), {});
    for (std::size_t k = 0; k < collectors_.size(); ++k) {  // the last frame's levels, on the exposure set
      const double scale = measured_at[k] > 0 ? exposure[k] / measured_at[k] : 1.0;
      for (int c = 0; c < 3; ++c) {
        const double dark = collectors_[k]->dark[c];
        white_level[k][c] = dark + scale * (collectors_[k]->metered.mean[c] - dark);
      }
    }
    last_metered_exposure_ = exposure;
    last_metered_prediction_ = predicted;
    last_metered_share_ = step.meter_white_share;
    return true;
  }

  void report_message(const std::string& message) {
    update([&](session::OperationRecord& r) { r.message = message; });
  }

  void stop_streams() {
    for (auto& collector : collectors_) {
      if (!collector->streaming) continue;
      std::lock_guard lock(collector->camera->mutex);
      collector->streaming = false;
      collector->camera->device->stop_stream();
    }
  }

  // Stream thread: files the frame as the answer to the awaited trigger, or
  // discards it (a frame of an earlier trigger, counted and journalled).
  void on_frame(CameraCollector& collector, drivers::Frame&& frame) {
    const std::string& camera = collector.camera->config.name;
    const bool complete = frame.status == drivers::FrameStatus::kComplete;
    if (complete && c_.on_frame_seen) c_.on_frame_seen(camera, frame, collector.exposure_us);
    nlohmann::json discarded;
    {
      std::lock_guard lock(collector.mutex);
      const bool awaiting = collector.awaited_count != 0 && !collector.answered;
      if (!complete) {
        if (awaiting) {  // the awaited trigger's frame, failed (a failed frame carries no count)
          collector.answered = true;
          collector.answer_status = frame.status;
        } else {
          discarded = {{"reason", frame_status_reason(frame.status)}};
          ++collector.failed_frames;
        }
      } else if (!frame.trigger_count) {  // a camera that sends no count: taken as the awaited trigger's
        if (awaiting) {
          collector.answered = true;
          collector.answer_status = drivers::FrameStatus::kComplete;
          collector.answer = std::move(frame);
        } else {
          discarded = {{"reason", "late"}};
          ++collector.late_frames;
        }
      } else if (awaiting && *frame.trigger_count == collector.awaited_count) {
        collector.answered = true;
        collector.answer_status = drivers::FrameStatus::kComplete;
        collector.answer = std::move(frame);
      } else if (*frame.trigger_count <= collector.triggers_sent &&
                 (collector.awaited_count == 0 || *frame.trigger_count < collector.awaited_count)) {
        const auto found = collector.trigger_of_count.find(*frame.trigger_count);
        discarded = {{"reason", "late"}, {"camera_trigger_count", *frame.trigger_count}};
        if (found != collector.trigger_of_count.end()) discarded["trigger_id"] = found->second;
        ++collector.late_frames;
      } else {  // a count the camera was never sent: its count and the sequencer's disagree
        discarded = {{"reason", "trigger_mismatch"}, {"camera_trigger_count", *frame.trigger_count}};
        if (awaiting) {
          collector.answered = true;
          collector.answer_status = drivers::FrameStatus::kComplete;
          collector.answer_problem = "trigger_mismatch: the frame answers the camera's trigger " +
                                     std::to_string(*frame.trigger_count) + ", expected " +
                                     std::to_string(collector.awaited_count);
        }
      }
      collector.arrived.notify_all();
    }
    if (discarded.is_null()) return;
    // A failed frame of no awaited trigger is lost (as every failed frame);
    // a complete one answered an earlier trigger, or one the camera was
    // never sent: discarded (the awaited trigger's loss is the capture's).
    const bool lost = discarded["reason"] != "late" && discarded["reason"] != "trigger_mismatch";
    if (lost) c_.pipeline->record_lost(discarded["reason"]);
    try {
      discarded["type"] = lost ? "frame_lost" : "frame_discarded";
      discarded["camera"] = camera;
      discarded["sequence"] = frame.sequence;
      c_.journal->append(discarded);
    } catch (const std::exception&) {
      // Storage is failing: the pipeline reports it and the sequencer stops.
    }
  }

  // The configuration's pixel format, ROI, gain and trigger (validated when
  // the device was opened; the device's first format when none is
  // configured; hardware trigger on trigger_input, else software), this exposure.
  void configure_camera(NamedDevice<drivers::Camera>& camera, double exposure_us) {
    drivers::CameraSettings settings = camera_capture_settings(camera.config);
    settings.exposure_us = exposure_us;
    std::lock_guard lock(camera.mutex);
    if (!camera.config.settings.contains("pixel_format") && !camera.device->info().pixel_formats.empty())
      settings.pixel_format = camera.device->info().pixel_formats.front();
    camera.device->configure(settings);
  }

  void finish_devices() {
    for (auto& collector : collectors_) {
      try {
        std::lock_guard lock(collector->camera->mutex);
        if (collector->streaming) collector->camera->device->stop_stream();
        collector->streaming = false;
        c_.pipeline->add_resent_packets(collector->camera->device->statistics().resent_packets);
      } catch (const std::exception&) {
      }
    }
    journal_trigger_summary();
    if (c_.led && c_.led->device) {
      try {
        std::lock_guard lock(c_.led->mutex);
        if (c_.plan.timing == session::Timing::kHardware) c_.led->device->disarm_sequence();
        c_.led->device->set_state(LedState{});
      } catch (const std::exception&) {
        // The controller is gone; nothing more to switch off from here.
      }
    }
    c_.pipeline->drain_storage();  // the estimator may go on: the daemon drains it
  }

  // The session's trigger counts: one record, after the streams stopped.
  void journal_trigger_summary() {
    nlohmann::json cameras = nlohmann::json::object();
    for (const auto& collector : collectors_) {
      std::lock_guard lock(collector->mutex);
      cameras[collector->camera->config.name] = {{"missed", collector->missed},
                                                 {"late_frames_discarded", collector->late_frames},
                                                 {"failed_frames_discarded", collector->failed_frames},
                                                 {"trigger", collector->hardware_triggered ? "hardware" : "software"}};
    }
    try {
      c_.journal->append({{"type", "trigger_summary"}, {"triggers", triggers_fired_}, {"retakes", retakes_},
                          {"discarded_frames", discarded_frames_}, {"cameras", cameras}});
    } catch (const std::exception&) {
      // Storage is failing: the outcome says so already.
    }
  }

  SequencerOutcome cancelled() { return {session::OperationState::kCancelled, ""}; }

  void report_progress() {
    auto elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    double progress = expected_ ? static_cast<double>(frames_done_) / static_cast<double>(expected_) : 1.0;
    update([&](session::OperationRecord& r) {
      r.progress = progress;
      r.eta_seconds = progress > 0 ? elapsed * (1 - progress) / progress : -1;
      r.counters = c_.pipeline->counters();
    });
  }

  void set_state(session::OperationState state, const std::string& message) {
    update([&](session::OperationRecord& r) {
      r.state = state;
      r.message = message;
    });
  }

  void update(const std::function<void(session::OperationRecord&)>& change) { c_.operations->update(c_.id, change); }

  SequencerContext& c_;
  std::vector<std::unique_ptr<CameraCollector>> collectors_;
  std::chrono::steady_clock::time_point start_;
  std::uint64_t expected_ = 0, frames_done_ = 0;
  std::uint64_t triggers_fired_ = 0, retakes_ = 0, discarded_frames_ = 0;
  std::map<std::string, std::vector<double>> metered_;  // metered white step → exposure per camera
  // metered white step → per camera the white's level per channel at its metered exposure (share of full scale)
  std::map<std::string, std::vector<std::array<double, 3>>> white_level_;
  std::map<std::string, std::vector<double>> subject_ratio_;  // subject-metered step → g per camera
  double subject_percentile_ = 0;  // > 0: the next metering frame is a subject's (subject_levels)
  std::vector<double> last_metered_exposure_;
  std::optional<std::array<double, 3>> last_metered_prediction_;
  double last_metered_share_ = 1;
  bool hazard_checked_ = false;
};

}  // namespace

SequencerOutcome run_sequence(SequencerContext& context) { return Run(context).run(); }

}  // namespace chromo::daemon
