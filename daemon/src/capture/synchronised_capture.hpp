#pragma once
// SynchronisedCapture: one capture is every camera's frame of one trigger
// (sequencer.hpp, "Synchronised capture"; docs/camera.md). It owns each
// camera's side of the captures (CameraCollector: the triggers it was sent,
// by its own count since its stream started, and what it answered), the
// cameras' configuration and streams, and the trigger bookkeeping: the LED
// controller fires a pulse, the other cameras are software-triggered with
// the same trigger id, and a capture counts only when every camera answered
// that trigger; else it is retaken for all ("frame_lost", "capture_retaken"
// records), pausing after frame_attempts spoiled captures in a row.
//
// Thread rules: every member function on the session's thread (the
// sequencer's). The cameras' stream threads call only on_frame, which fills
// a collector's answer under the collector's own mutex and wakes take();
// the sequencer thread reads it under the same mutex. The camera devices are
// called under their NamedDevice mutex.

#include <chrono>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "run_control.hpp"

namespace chromo::daemon {

// One capture, complete: every camera's frame of one trigger, in camera
// order (SequencerContext::cameras).
struct Capture {
  std::uint32_t trigger_id = 0;  // the LED controller's number of the pulse
  std::chrono::steady_clock::time_point trigger_time;
  std::vector<drivers::Frame> frames;
};

class SynchronisedCapture {
 public:
  explicit SynchronisedCapture(RunControl& run);
  ~SynchronisedCapture();

  // Takes on the context's cameras in order; std::runtime_error naming the
  // first that is not open (those before it are kept, for finish()).
  void open_cameras();

  std::size_t camera_count() const { return collectors_.size(); }
  const std::string& camera_name(std::size_t camera) const;
  drivers::CameraInfo camera_info(std::size_t camera);  // under the camera's lock
  double exposure_us(std::size_t camera) const;         // as configured (-1 before)

  // Cameras take settings only while they do not stream (AravisCamera): when
  // a camera's exposure differs from the one configured, the streams stop,
  // the cameras are configured (the configuration's pixel format, ROI, gain,
  // trigger, and this exposure), the streams start again. A camera that does
  // not answer pauses the session naming it; resume retries. exposure_us:
  // one per camera; restart: restart the streams even when unchanged. False
  // when cancelled.
  bool ensure_exposure(const std::vector<double>& exposure_us, bool restart = false);

  // One capture for frame `frame_in_step` of step `step_index`, retaken
  // until every camera answered one trigger; nullopt when cancelled.
  std::optional<Capture> take(const session::Step& step, std::size_t step_index, std::uint32_t frame_in_step);

  // Stops the streams, adds the cameras' resent packets to the pipeline's
  // counters, journals the "trigger_summary" record. Never throws.
  void finish();

 private:
  struct CameraCollector;
  using Missed = std::vector<std::pair<CameraCollector*, std::string>>;
  bool resync_streams();
  bool retake(const session::Step& step, std::size_t step_index, std::uint32_t frame_in_step,
              std::uint32_t trigger_id, const Missed& missed, std::size_t discarded, std::uint32_t& attempts);
  void stop_streams();
  void on_frame(CameraCollector& collector, drivers::Frame&& frame);  // stream thread
  void configure_camera(NamedDevice<drivers::Camera>& camera, double exposure_us);
  void journal_trigger_summary();

  RunControl& run_;
  SequencerContext& c_;
  std::vector<std::unique_ptr<CameraCollector>> collectors_;
  std::uint64_t triggers_fired_ = 0, retakes_ = 0, discarded_frames_ = 0;
};

}  // namespace chromo::daemon
