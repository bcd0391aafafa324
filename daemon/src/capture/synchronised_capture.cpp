// SynchronisedCapture: see synchronised_capture.hpp.
#include "synchronised_capture.hpp"

#include <algorithm>

#include "chromo/drivers/device_error.hpp"

namespace chromo::daemon {

using drivers::DeviceError;

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

// The trigger output's pulse: long enough for any camera's input filter.
constexpr std::uint32_t kTriggerPulseWidthUs = 100;

}  // namespace

// One camera's side of the captures: what it owes (the trigger it was sent
// last, by its own count since its stream started) and what it answered.
// The stream thread fills the answer; the sequencer thread reads it.
struct SynchronisedCapture::CameraCollector {
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
  std::uint64_t missed = 0;          // captures it spoiled (named in the journal)
};

SynchronisedCapture::SynchronisedCapture(RunControl& run) : run_(run), c_(run.context()) {}

void SynchronisedCapture::open_cameras() {
  for (auto* camera : c_.cameras) {
    if (!camera->device) throw std::runtime_error("camera \"" + camera->config.name + "\" is not open: " + camera->open_error);
    auto collector = std::make_unique<CameraCollector>();
    collector->camera = camera;
    collector->hardware_triggered = camera_capture_settings(camera->config).trigger_mode == drivers::TriggerMode::kHardware;
    collectors_.push_back(std::move(collector));
  }
}

SynchronisedCapture::~SynchronisedCapture() = default;

const std::string& SynchronisedCapture::camera_name(std::size_t camera) const {
  return collectors_.at(camera)->camera->config.name;
}

drivers::CameraInfo SynchronisedCapture::camera_info(std::size_t camera) {
  auto& device = *collectors_.at(camera)->camera;
  std::lock_guard lock(device.mutex);
  return device.device->info();
}

double SynchronisedCapture::exposure_us(std::size_t camera) const { return collectors_.at(camera)->exposure_us; }

std::optional<Capture> SynchronisedCapture::take(const session::Step& step, std::size_t step_index,
                                                 std::uint32_t frame_in_step) {
  std::uint32_t attempts = 0;
  while (true) {
    if (c_.control->cancel_requested()) return std::nullopt;
    if (!resync_streams()) return std::nullopt;
    for (auto& collector : collectors_) {
      std::lock_guard lock(collector->mutex);
      collector->awaited_count = ++collector->triggers_sent;
      collector->answered = false;
      collector->answer.reset();
      collector->answer_problem.clear();
    }
    Capture capture;
    capture.trigger_time = std::chrono::steady_clock::now();
    if (!run_.with_led("fire_trigger", [&](drivers::LedController& device) {
          capture.trigger_id = device.fire_trigger(kTriggerPulseWidthUs);
        }))
      return std::nullopt;
    ++triggers_fired_;
    for (auto& collector : collectors_) {
      std::lock_guard lock(collector->mutex);
      collector->trigger_of_count[collector->awaited_count] = capture.trigger_id;
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
    Missed missed;
    for (auto& collector : collectors_) {
      std::unique_lock lock(collector->mutex);
      collector->arrived.wait_until(lock, deadline, [&] { return collector->answered; });
      std::string problem;
      if (!collector->answered) problem = "no_frame";
      else if (!collector->answer_problem.empty()) problem = collector->answer_problem;
      else if (collector->answer_status != drivers::FrameStatus::kComplete) problem = frame_status_reason(collector->answer_status);
      collector->awaited_count = 0;
      if (problem.empty()) capture.frames.push_back(std::move(*collector->answer));
      else missed.emplace_back(collector.get(), problem);
      collector->answer.reset();
    }
    if (missed.empty()) return capture;
    if (!retake(step, step_index, frame_in_step, capture.trigger_id, missed, capture.frames.size(), attempts))
      return std::nullopt;
  }
}

// A capture one camera or more spoiled: named and counted in the journal,
// the other cameras' frames of that trigger discarded; pauses after
// frame_attempts captures in a row. False when cancelled.
bool SynchronisedCapture::retake(const session::Step& step, std::size_t step_index, std::uint32_t frame_in_step,
                                 std::uint32_t trigger_id, const Missed& missed, std::size_t discarded,
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
  run_.report_message("step " + step.name + ": trigger " + std::to_string(trigger_id) + " missed by " + listing +
                      "; capture retaken for every camera");
  run_.report_progress();
  if (++attempts >= c_.frame_attempts) {
    if (!run_.pause_by_daemon("step " + step.name + ": " + listing + " missed " + std::to_string(attempts) +
                              " triggers in a row; resume to retry"))
      return false;
    attempts = 0;
  }
  // Hardware timing: the missed trigger advanced the armed sequence; arm it
  // again from this frame so that the retake's trigger shows its state.
  if (c_.plan.timing == session::Timing::kHardware && !run_.arm_from(step_index, frame_in_step)) return false;
  return true;
}

// Restarts the streams when a camera's trigger count may no longer match
// ours (a trigger it may or may not have counted, a frame answering a
// trigger it was never sent, a reconnect of the driver, which restarts
// acquisition): AcquisitionStart resets the camera's count. False when cancelled.
bool SynchronisedCapture::resync_streams() {
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

bool SynchronisedCapture::ensure_exposure(const std::vector<double>& exposure_us, bool restart) {
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
    if (!run_.pause_by_daemon("camera \"" + failing + "\" does not answer (" + failure + "); resume to retry"))
      return false;
  }
}

void SynchronisedCapture::stop_streams() {
  for (auto& collector : collectors_) {
    if (!collector->streaming) continue;
    std::lock_guard lock(collector->camera->mutex);
    collector->streaming = false;
    collector->camera->device->stop_stream();
  }
}

// Stream thread: files the frame as the answer to the awaited trigger, or
// discards it (a frame of an earlier trigger, counted and journalled).
void SynchronisedCapture::on_frame(CameraCollector& collector, drivers::Frame&& frame) {
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
    } else {  // a count the camera was never sent: its count and ours disagree
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
void SynchronisedCapture::configure_camera(NamedDevice<drivers::Camera>& camera, double exposure_us) {
  drivers::CameraSettings settings = camera_capture_settings(camera.config);
  settings.exposure_us = exposure_us;
  std::lock_guard lock(camera.mutex);
  if (!camera.config.settings.contains("pixel_format") && !camera.device->info().pixel_formats.empty())
    settings.pixel_format = camera.device->info().pixel_formats.front();
  camera.device->configure(settings);
}

void SynchronisedCapture::finish() {
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
}

// The session's trigger counts: one record, after the streams stopped.
void SynchronisedCapture::journal_trigger_summary() {
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

}  // namespace chromo::daemon
