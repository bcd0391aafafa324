#include "chromo/daemon/internal/capture/preview_hub.hpp"

#include <algorithm>
#include <stdexcept>

namespace chromo::daemon {

PreviewHub::PreviewHub(DeviceSet& devices, std::function<bool()> busy) : devices_(devices), busy_(std::move(busy)) {}

PreviewHub::~PreviewHub() { stop_free_runs(); }

NamedDevice<drivers::Camera>& PreviewHub::camera(const std::string& name, const std::string& field) {
  if (name.empty()) {
    if (devices_.cameras.size() == 1) return *devices_.cameras.front();
    throw std::invalid_argument(field + ": required (" + std::to_string(devices_.cameras.size()) + " cameras are configured)");
  }
  for (auto& camera : devices_.cameras)
    if (camera->config.name == name) return *camera;
  throw std::invalid_argument(field + ": no camera \"" + name + "\" is configured");
}

PreviewHub::CameraState& PreviewHub::state_locked(const std::string& camera) { return cameras_[camera]; }

LiveSettings PreviewHub::settings_locked(const std::string& name) {
  auto& state = state_locked(name);
  if (!state.settings) {
    LiveSettings initial;
    initial.pixel_format = camera_capture_settings(camera(name).config).pixel_format;
    state.settings = initial;
  }
  return *state.settings;
}

LiveSettings PreviewHub::settings(const std::string& camera) {
  std::lock_guard lock(mutex_);
  return settings_locked(camera);
}

LiveSettings PreviewHub::set_settings(const std::string& name, const LiveSettings& settings) {
  std::lock_guard lock(mutex_);
  if (busy_())
    throw std::logic_error("a session or calibration is running: its plan sets the cameras' exposure and format; "
                           "change them once it has ended (or cancel it)");
  auto& state = state_locked(name);
  settings_locked(name);
  state.settings = settings;
  if (state.free_running) {
    stop_free_run_locked(name);
    start_free_run_locked(name);
  }
  return settings;
}

void PreviewHub::keep_locked(const std::string& camera, std::shared_ptr<HubFrame> frame) {
  auto& state = state_locked(camera);
  frame->serial = ++state.serial;
  state.latest = std::move(frame);
  state.kept_at = std::chrono::steady_clock::now();
  changed_.notify_all();
}

void PreviewHub::offer(const std::string& camera, const drivers::Frame& frame, double exposure_us,
                       const std::string& source) {
  if (frame.status != drivers::FrameStatus::kComplete) return;
  std::lock_guard lock(mutex_);
  auto found = cameras_.find(camera);
  if (found == cameras_.end() || found->second.watchers == 0) return;
  // Copy only when the fastest watcher is due for a frame.
  const double fastest_hz = *found->second.rates_hz.rbegin();
  const auto interval = std::chrono::duration<double>(1.0 / fastest_hz);
  if (std::chrono::steady_clock::now() - found->second.kept_at < interval * 0.9) return;
  auto kept = std::make_shared<HubFrame>();
  kept->frame = frame;
  kept->exposure_us = exposure_us;
  kept->source = source;
  keep_locked(camera, std::move(kept));
}

void PreviewHub::start_free_run_locked(const std::string& name) {
  auto& state = state_locked(name);
  if (state.free_running || state.stopping || state.watchers == 0 || busy_()) return;
  auto& device = camera(name);
  if (!device.device) throw std::runtime_error("camera \"" + name + "\": " + device.open_error);
  const LiveSettings live = settings_locked(name);
  drivers::CameraSettings settings = camera_capture_settings(device.config);
  settings.exposure_us = live.exposure_us;
  settings.pixel_format = live.pixel_format;
  settings.trigger_mode = drivers::TriggerMode::kFreeRun;
  const double rate_hz = *state.rates_hz.rbegin();
  settings.frame_rate_hz = std::min(rate_hz, 1e6 / std::max(live.exposure_us, 1.0));
  std::lock_guard device_lock(device.mutex);
  device.device->configure(settings);
  device.device->start_stream([this, name, exposure_us = live.exposure_us](drivers::Frame&& frame) {
    if (frame.status != drivers::FrameStatus::kComplete) return;
    auto kept = std::make_shared<HubFrame>();
    kept->frame = std::move(frame);
    kept->exposure_us = exposure_us;
    kept->source = "free_run";
    std::lock_guard lock(mutex_);
    keep_locked(name, std::move(kept));
  });
  state.free_running = true;
  state.free_run_rate_hz = rate_hz;
}

void PreviewHub::stop_free_run_locked(const std::string& name) {
  auto& state = state_locked(name);
  if (!state.free_running) return;
  auto& device = camera(name);
  state.free_running = false;
  state.stopping = true;
  // The stream's callback takes mutex_: release it while the driver joins its thread.
  mutex_.unlock();
  try {
    std::lock_guard device_lock(device.mutex);
    device.device->stop_stream();
  } catch (...) {
    mutex_.lock();
    state.stopping = false;
    changed_.notify_all();
    throw;
  }
  mutex_.lock();
  state.stopping = false;
  changed_.notify_all();  // a watcher that found the stop in progress starts the next run
}

void PreviewHub::stop_free_runs() {
  std::lock_guard lock(mutex_);
  std::vector<std::string> names;
  for (const auto& [name, state] : cameras_)
    if (state.free_running) names.push_back(name);
  for (const auto& name : names) stop_free_run_locked(name);
}

PreviewHub::Watch::Watch(PreviewHub& hub, std::string camera, double rate_hz)
    : hub_(hub), camera_(std::move(camera)), rate_hz_(rate_hz) {
  std::lock_guard lock(hub_.mutex_);
  auto& state = hub_.state_locked(camera_);
  ++state.watchers;
  state.rates_hz.insert(rate_hz_);
}

PreviewHub::Watch::~Watch() {
  std::lock_guard lock(hub_.mutex_);
  auto& state = hub_.state_locked(camera_);
  --state.watchers;
  state.rates_hz.erase(state.rates_hz.find(rate_hz_));
  try {
    if (state.watchers == 0) hub_.stop_free_run_locked(camera_);
  } catch (...) {  // a camera that fails to stop is reported by its next use
  }
}

std::shared_ptr<const HubFrame> PreviewHub::Watch::next(std::chrono::milliseconds timeout) {
  std::unique_lock lock(hub_.mutex_);
  auto& state = hub_.state_locked(camera_);
  // A faster watcher than the free run was started for: restart it at the new rate.
  if (state.free_running && *state.rates_hz.rbegin() > state.free_run_rate_hz + 1e-9) hub_.stop_free_run_locked(camera_);
  hub_.start_free_run_locked(camera_);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  const auto fresh = [&] {
    auto& current = hub_.state_locked(camera_);
    return current.latest && current.latest->serial > last_serial_;
  };
  bool arrived = fresh();
  while (!arrived && hub_.changed_.wait_until(lock, deadline) != std::cv_status::timeout) {
    hub_.start_free_run_locked(camera_);  // after a stop that was in progress (no-op when running)
    arrived = fresh();
  }
  arrived = arrived || fresh();
  if (!arrived) return nullptr;
  auto latest = hub_.state_locked(camera_).latest;
  last_serial_ = latest->serial;
  return latest;
}

}  // namespace chromo::daemon
