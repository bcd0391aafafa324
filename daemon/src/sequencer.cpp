#include "chromo/daemon/sequencer.hpp"

#include <algorithm>
#include <condition_variable>
#include <thread>

#include "chromo/daemon/exposure_metering.hpp"
#include "chromo/drivers/device_error.hpp"

namespace chromo::daemon {

using drivers::DeviceError;
using drivers::DriveLevels;
using drivers::LedState;

namespace {

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

// One camera's frames as they arrive, routed to the pipeline with the
// metadata of the frame being taken.
struct CameraCollector {
  NamedDevice<drivers::Camera>* camera = nullptr;
  std::mutex mutex;
  std::condition_variable arrived;
  std::uint64_t delivered = 0;  // frames (complete or not) since start
  drivers::FrameStatus last_status = drivers::FrameStatus::kComplete;
  session::FrameRecord pending;  // the frame being taken: step, LED state, exposure (camera fields come with it)
  std::chrono::steady_clock::time_point trigger_time;
  bool streaming = false;  // sequencer thread only
  double exposure_us = -1;  // configured (sequencer thread only)
  bool metering = false;    // the frame being taken is a metering frame: kept here, not stored
  FrameLevels metered;      // levels of the last metering frame
  std::string metering_error;
  std::array<double, 3> dark{};  // mean dark level per channel (share of full scale), from the dark step's frames
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
        if (!with_led("set_state", [&](drivers::LedController& device) { device.set_state(state); })) return cancelled();
      }
      drivers::LedStatus status;
      if (!with_led("read_status", [&](drivers::LedController& device) { status = device.read_status(); }))
        return cancelled();
      // Hardware timing: the controller moves to this step's state on the
      // first exposure edge, so before it the status still shows the state
      // of the previous frame; the frames were taken under the armed levels.
      session::FrameLedState led;
      led.drive = hardware ? levels : status.applied.drive;
      led.requested_drive = levels;
      led.temperature_C = status.temperature_C;
      led.channel_faults = status.channel_faults;
      led.controller_faults = status.controller_faults;
      led.sequence_position = status.sequence_position;
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

  // Triggers every camera and waits for one complete frame from each;
  // retries failed frames. False when cancelled.
  bool take_frame(const session::Step& step, int index, std::uint32_t frame_in_step, const session::FrameRecord& pending,
                  bool metering) {
    for (auto& collector : collectors_) {
      std::uint32_t attempts = 0;
      while (true) {
        if (c_.control->cancel_requested()) return false;
        std::uint64_t before;
        {
          std::lock_guard lock(collector->mutex);
          collector->pending = pending;
          collector->pending.camera = collector->camera->config.name;
          collector->pending.exposure_us = collector->exposure_us;
          collector->metering = metering;
          collector->metering_error.clear();
          collector->trigger_time = std::chrono::steady_clock::now();
          before = collector->delivered;
        }
        std::string failure;
        try {
          std::lock_guard device_lock(collector->camera->mutex);
          collector->camera->device->software_trigger();
        } catch (const DeviceError& error) {
          failure = error.what();
        }
        if (failure.empty()) {
          std::unique_lock lock(collector->mutex);
          auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::microseconds(static_cast<long long>(collector->exposure_us)) +
                          std::chrono::milliseconds(c_.frame_timeout_ms);
          bool got = collector->arrived.wait_until(lock, deadline, [&] { return collector->delivered > before; });
          if (got && collector->last_status == drivers::FrameStatus::kComplete) {
            if (metering && !collector->metering_error.empty())
              throw std::runtime_error("camera \"" + collector->camera->config.name + "\": " + collector->metering_error);
            break;
          }
          failure = got ? frame_status_reason(collector->last_status) : "no frame within the timeout";
          if (!got) {
            lock.unlock();
            c_.pipeline->record_lost("timeout");
            c_.journal->append({{"type", "frame_lost"}, {"step", step.name}, {"camera", collector->camera->config.name},
                                {"reason", "timeout"}});
          }
        } else {
          c_.pipeline->record_lost("camera_unreachable");
          c_.journal->append({{"type", "frame_lost"}, {"step", step.name}, {"camera", collector->camera->config.name},
                              {"reason", "camera_unreachable"}, {"detail", failure}});
        }
        report_progress();
        if (++attempts < c_.frame_attempts) {
          if (c_.plan.timing == session::Timing::kHardware && !arm_from(static_cast<std::size_t>(index), frame_in_step)) return false;
          continue;
        }
        c_.control->pause_by_daemon();
        if (!pause_point("camera \"" + collector->camera->config.name + "\" delivered no complete frame in " +
                         std::to_string(attempts) + " attempts (last: " + failure + "); resume to retry"))
          return false;
        attempts = 0;
        if (c_.plan.timing == session::Timing::kHardware && !arm_from(static_cast<std::size_t>(index), frame_in_step)) return false;
      }
    }
    return true;
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
  // resting state (LEDs dark) shown until the first exposure: the controller
  // advances on each exposure's rising edge, so frame k is taken under state k.
  bool arm_from(std::size_t step_index, std::uint32_t frame) {
    std::vector<LedState> states(1);
    for (std::size_t s = step_index; s < c_.plan.steps.size(); ++s) {
      LedState state;
      state.drive = resolve(c_.plan.steps[s]);
      for (std::uint32_t f = (s == step_index ? frame : 0); f < c_.plan.steps[s].frames_per_camera; ++f)
        states.push_back(state);
    }
    return with_led("arm_sequence", [&](drivers::LedController& device) {
      device.arm_sequence(states, drivers::SequenceTrigger::kHardwareRisingEdge);
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
      case session::Illumination::Kind::kMix: return c_.resolve_mix(step.illumination.mix);
    }
    return DriveLevels{};
  }

  void create_collectors() {
    for (auto* camera : c_.cameras) {
      if (!camera->device) throw std::runtime_error("camera \"" + camera->config.name + "\" is not open: " + camera->open_error);
      auto collector = std::make_unique<CameraCollector>();
      collector->camera = camera;
      collector->pending.camera = camera->config.name;
      collectors_.push_back(std::move(collector));
    }
  }

  // Cameras take settings only while they do not stream (AravisCamera): when
  // a camera's exposure differs from the one configured, the streams stop, the
  // cameras are configured, the streams start again. A camera that does not
  // answer pauses the session naming it; resume retries. False when cancelled.
  // exposure_us: one per camera (collectors_ order).
  bool ensure_exposure(const std::vector<double>& exposure_us) {
    bool same = true;
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
          collector->camera->device->start_stream([this, raw](drivers::Frame&& frame) { on_frame(*raw, std::move(frame)); });
          collector->streaming = true;
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

  // The exposure of each camera for a step: metered (its own or exposure_from's), else the plan's.
  std::vector<double> exposures_of(const session::Step& step) const {
    const std::string& metered_at = step.meter_white_share > 0 ? step.name : step.exposure_from;
    if (!metered_at.empty()) {
      auto found = metered_.find(metered_at);
      if (found == metered_.end())
        throw std::logic_error("step " + step.name + ": no exposure metered at step " + metered_at);
      return found->second;
    }
    return std::vector<double>(collectors_.size(), step.exposure_us);
  }

  // Every step's exposure as far as known (metered steps: the longest over the cameras).
  std::map<std::string, double> known_exposures() const {
    std::map<std::string, double> out;
    for (const auto& step : c_.plan.steps) {
      const std::string& metered_at = step.meter_white_share > 0 ? step.name : step.exposure_from;
      auto found = metered_.find(metered_at);
      if (!metered_at.empty() && found != metered_.end())
        out[step.name] = *std::max_element(found->second.begin(), found->second.end());
    }
    return out;
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

  void on_frame(CameraCollector& collector, drivers::Frame&& frame) {
    CapturedFrame captured;
    const bool complete = frame.status == drivers::FrameStatus::kComplete;
    {
      std::lock_guard lock(collector.mutex);
      captured.record = collector.pending;
      captured.trigger_time = collector.trigger_time;
    }
    bool metering = false;
    {
      std::lock_guard lock(collector.mutex);
      metering = collector.metering;
    }
    if (complete && metering) {
      FrameLevels levels;
      std::string error;
      try {
        levels = frame_levels(frame.data, frame.width, frame.height, frame.pixel_format);
      } catch (const std::exception& failure) {
        error = failure.what();
      }
      std::lock_guard lock(collector.mutex);
      collector.metered = levels;
      collector.metering_error = error;
      collector.last_status = drivers::FrameStatus::kComplete;
      ++collector.delivered;
      collector.arrived.notify_all();
      return;
    }
    if (complete && captured.record.role == session::StepRole::kDark) {
      try {  // the dark level the metering subtracts (the mean over the dark step's frames)
        const FrameLevels levels = frame_levels(frame.data, frame.width, frame.height, frame.pixel_format);
        std::lock_guard lock(collector.mutex);
        const double n = static_cast<double>(captured.record.frame_in_step);
        for (int c = 0; c < 3; ++c) collector.dark[c] = (collector.dark[c] * n + levels.mean[c]) / (n + 1);
      } catch (const std::exception&) {
        // A frame the pipeline will refuse anyway; the metering then assumes no dark level.
      }
    }
    if (complete) {
      session::FrameRecord& r = captured.record;
      r.sequence = frame.sequence;
      r.camera_frame_id = frame.camera_frame_id;
      r.camera_timestamp_ns = frame.camera_timestamp_ns;
      r.host_timestamp_ns =
          std::chrono::duration_cast<std::chrono::nanoseconds>(frame.host_timestamp.time_since_epoch()).count();
      r.width = frame.width;
      r.height = frame.height;
      r.pixel_format = frame.pixel_format;
      captured.samples = std::move(frame.data);
      c_.pipeline->submit(std::move(captured));
    } else {
      const std::string reason = frame_status_reason(frame.status);
      c_.pipeline->record_lost(reason);
      try {
        c_.journal->append({{"type", "frame_lost"}, {"step", captured.record.step}, {"camera", captured.record.camera},
                            {"reason", reason}, {"sequence", frame.sequence}});
      } catch (const std::exception&) {
        // Storage is failing: the pipeline reports it and the sequencer stops.
      }
    }
    std::lock_guard lock(collector.mutex);
    collector.last_status = complete ? drivers::FrameStatus::kComplete : frame.status;
    ++collector.delivered;
    collector.arrived.notify_all();
  }

  // The configuration's pixel format, ROI and gain (validated when the
  // device was opened; the device's first format when none is configured),
  // this exposure, software trigger.
  void configure_camera(NamedDevice<drivers::Camera>& camera, double exposure_us) {
    drivers::CameraSettings settings = camera_capture_settings(camera.config);
    settings.exposure_us = exposure_us;
    settings.trigger_mode = drivers::TriggerMode::kSoftware;
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
  std::map<std::string, std::vector<double>> metered_;  // metered white step → exposure per camera
  std::vector<double> last_metered_exposure_;
  std::optional<std::array<double, 3>> last_metered_prediction_;
  double last_metered_share_ = 1;
  bool hazard_checked_ = false;
};

}  // namespace

SequencerOutcome run_sequence(SequencerContext& context) { return Run(context).run(); }

}  // namespace chromo::daemon
