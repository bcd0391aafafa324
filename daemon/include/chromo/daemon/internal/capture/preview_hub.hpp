#pragma once
// PreviewHub: the latest frame of each camera for the live view
// (CameraService.StreamPreview, docs/web.md), from one of two sources:
//
//   - between sessions, a free run the hub starts on the camera while anyone
//     watches it (TriggerMode::kFreeRun at the fastest rate asked for, with
//     the live view's exposure and pixel format: settings()/set_settings());
//   - during a session, the session's own frames, offered by the sequencer
//     (offer(); copied only when a watcher is due for one).
//
// The hub keeps the frame as the camera sent it; each watcher converts it at
// its own width (preview_image.hpp) on its own thread. A session or
// calibration stops the free runs before it uses the cameras
// (stop_free_runs()); the hub starts one only while `busy()` is false, both
// under the hub's mutex, so a free run never overlaps a session.
//
// Thread rules: every member is thread-safe. offer() runs on a camera's
// stream thread and returns quickly. Lifetime: the destructor stops the free
// runs; the DeviceSet must outlive the hub.

#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>

#include "chromo/daemon/internal/devices/device_set.hpp"

namespace chromo::daemon {

struct HubFrame {
  drivers::Frame frame;
  double exposure_us = 0;
  std::string source;       // "free_run" or "session:<id>"
  std::uint64_t serial = 0; // the hub's count of frames of this camera, from 1
};

// The live view's settings of a camera between sessions.
struct LiveSettings {
  double exposure_us = 10000;
  drivers::PixelFormat pixel_format = drivers::PixelFormat::kMono8;
};

class PreviewHub {
 public:
  PreviewHub(DeviceSet& devices, std::function<bool()> busy);
  ~PreviewHub();
  PreviewHub(const PreviewHub&) = delete;
  PreviewHub& operator=(const PreviewHub&) = delete;

  // The camera by name (empty: the only one); std::invalid_argument naming
  // `field` when unknown or ambiguous.
  NamedDevice<drivers::Camera>& camera(const std::string& name, const std::string& field = "camera");

  // A watcher of a camera at a rate, for as long as the Watch lives.
  class Watch {
   public:
    Watch(PreviewHub& hub, std::string camera, double rate_hz);
    ~Watch();
    Watch(const Watch&) = delete;
    Watch& operator=(const Watch&) = delete;
    // The camera's frame newer than the last one returned, waiting up to
    // `timeout`; null on timeout. Starts the camera's free run first when
    // nothing else runs (throws drivers::DeviceError when the camera fails).
    std::shared_ptr<const HubFrame> next(std::chrono::milliseconds timeout);

   private:
    PreviewHub& hub_;
    std::string camera_;
    double rate_hz_;
    std::uint64_t last_serial_ = 0;
  };

  // A session's frame (sequencer): kept when a watcher of the camera is due.
  void offer(const std::string& camera, const drivers::Frame& frame, double exposure_us, const std::string& source);
  // Stops every free run (a session or calibration is about to use the cameras).
  void stop_free_runs();
  LiveSettings settings(const std::string& camera);
  // Stores the live view's settings; a running free run restarts with them.
  // std::logic_error while busy() (a session's plan sets the exposure).
  LiveSettings set_settings(const std::string& camera, const LiveSettings& settings);

 private:
  struct CameraState {
    int watchers = 0;
    std::multiset<double> rates_hz;
    bool free_running = false;
    // A stop is joining the camera's stream with the hub's mutex released: no
    // start until it ends (a start would hold the mutex the stream's last
    // callback waits for, while waiting for the device the stop holds).
    bool stopping = false;
    double free_run_rate_hz = 0;
    std::optional<LiveSettings> settings;
    std::shared_ptr<const HubFrame> latest;
    std::uint64_t serial = 0;
    std::chrono::steady_clock::time_point kept_at{};
  };
  CameraState& state_locked(const std::string& camera);
  LiveSettings settings_locked(const std::string& camera);
  void start_free_run_locked(const std::string& camera);
  void stop_free_run_locked(const std::string& camera);
  void keep_locked(const std::string& camera, std::shared_ptr<HubFrame> frame);

  DeviceSet& devices_;
  std::function<bool()> busy_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::string, CameraState> cameras_;
};

}  // namespace chromo::daemon
