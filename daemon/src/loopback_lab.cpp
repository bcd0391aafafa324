#include "chromo/daemon/loopback_lab.hpp"

#include <condition_variable>
#include <deque>
#include <cstring>
#include <thread>

#include "chromo/daemon/image_files.hpp"
#include "chromo/drivers/device_error.hpp"

namespace chromo::daemon {

using namespace chromo::drivers;

DriveLevels LoopbackLab::emitted() const {
  std::lock_guard lock(mutex_);
  return emitted_;
}
void LoopbackLab::set_emitted(const DriveLevels& levels) {
  std::lock_guard lock(mutex_);
  emitted_ = levels;
}
void LoopbackLab::exposure_edge() {
  std::lock_guard lock(mutex_);
  if (position_ >= 0 && trigger_ == SequenceTrigger::kHardwareRisingEdge &&
      position_ + 1 < static_cast<int>(sequence_.size())) {
    ++position_;
    emitted_ = sequence_[static_cast<std::size_t>(position_)].drive;
  }
}
void LoopbackLab::arm(std::vector<LedState> states, SequenceTrigger trigger) {
  std::lock_guard lock(mutex_);
  sequence_ = std::move(states);
  trigger_ = trigger;
  position_ = sequence_.empty() ? -1 : 0;
  if (!sequence_.empty()) emitted_ = sequence_.front().drive;
}
void LoopbackLab::disarm() {
  std::lock_guard lock(mutex_);
  sequence_.clear();
  position_ = -1;
}
int LoopbackLab::sequence_position() const {
  std::lock_guard lock(mutex_);
  return position_;
}

namespace {

class LoopbackLed : public LedController {
 public:
  LoopbackLed(std::shared_ptr<LoopbackLab> lab, std::string name) : lab_(std::move(lab)), name_(std::move(name)) {}
  LedControllerInfo info() const override {
    return {"loopback LED controller", name_, "0", DriveMode::kPwmDuty, 1, 4096, 100, 100000};
  }
  void set_state(const LedState& state) override {
    check("set_state");
    for (double level : state.drive)
      if (!(level >= 0 && level <= 1)) throw DeviceError(DeviceError::Kind::kInvalidRequest, name_, "set_state", "level outside [0, 1]");
    lab_->set_emitted(state.drive);
    applied_ = state;
  }
  LedStatus read_status() override {
    check("read_status");
    LedStatus status;
    status.applied = applied_;
    status.applied.drive = lab_->emitted();
    status.output_enabled = enabled_;
    for (std::size_t i = 0; i < status.temperature_C.size(); ++i) status.temperature_C[i] = 25.0 + 10.0 * status.applied.drive[i];
    status.sequence_position = lab_->sequence_position();
    return status;
  }
  void set_output_enabled(bool enabled) override {
    check("set_output_enabled");
    enabled_ = enabled;
    if (!enabled) lab_->set_emitted({});
  }
  void arm_sequence(std::span<const LedState> states, SequenceTrigger trigger) override {
    check("arm_sequence");
    if (states.size() > 4096) throw DeviceError(DeviceError::Kind::kInvalidRequest, name_, "arm_sequence", "more than 4096 states");
    lab_->arm({states.begin(), states.end()}, trigger);
  }
  void advance_sequence() override {
    check("advance_sequence");
    lab_->exposure_edge();
  }
  void disarm_sequence() override {
    check("disarm_sequence");
    lab_->disarm();
  }

 private:
  void check(const char* request) const {
    if (!lab_->led_responding)
      throw DeviceError(DeviceError::Kind::kTimeout, name_, request, "no answer within 300 ms");
  }
  std::shared_ptr<LoopbackLab> lab_;
  std::string name_;
  LedState applied_;
  bool enabled_ = true;
};

PixelFormat parse_format(const std::string& name) {
  for (auto format : {PixelFormat::kMono8, PixelFormat::kMono12, PixelFormat::kMono16, PixelFormat::kBayerRG8,
                      PixelFormat::kBayerRG12, PixelFormat::kBayerRG16, PixelFormat::kRgb8})
    if (pixel_format_name(format) == name) return format;
  throw std::invalid_argument("pixel_format \"" + name + "\" unknown");
}

class LoopbackCamera : public Camera {
 public:
  LoopbackCamera(std::shared_ptr<LoopbackLab> lab, const DeviceConfig& config) : lab_(std::move(lab)), name_(config.name) {
    width_ = config.settings.value("width", 64);
    height_ = config.settings.value("height", 48);
    settings_.pixel_format = parse_format(config.settings.value("pixel_format", std::string("Mono16")));
  }
  ~LoopbackCamera() override { stop_stream(); }
  CameraInfo info() const override {
    return {"loopback", "loopback camera", name_, "in-process", width_, height_, {settings_.pixel_format}};
  }
  void configure(const CameraSettings& settings) override {
    std::lock_guard lock(mutex_);
    settings_ = settings;
  }
  void start_stream(FrameCallback on_frame) override {
    stop_stream();
    std::lock_guard lock(mutex_);
    callback_ = std::move(on_frame);
    running_ = true;
    sequence_ = 0;
    worker_ = std::thread([this] { run(); });
  }
  void stop_stream() override {
    {
      std::lock_guard lock(mutex_);
      if (!running_) return;
      running_ = false;
    }
    wake_.notify_all();
    if (worker_.joinable()) worker_.join();
  }
  void software_trigger() override {
    if (!lab_->camera_present) throw DeviceError(DeviceError::Kind::kDisconnected, name_, "software_trigger", "camera gone");
    std::lock_guard lock(mutex_);
    pending_.push_back({lab_->emitted(), std::chrono::steady_clock::now()});
    wake_.notify_all();
  }
  StreamStatistics statistics() const override {
    std::lock_guard lock(mutex_);
    return stats_;
  }

 private:
  struct Pending {
    DriveLevels levels;
    std::chrono::steady_clock::time_point trigger;
  };
  void run() {
    std::unique_lock lock(mutex_);
    while (true) {
      wake_.wait(lock, [&] { return !running_ || !pending_.empty(); });
      if (!running_) return;
      Pending pending = pending_.front();
      pending_.pop_front();
      auto exposure = std::chrono::microseconds(static_cast<long long>(settings_.exposure_us));
      lock.unlock();
      std::this_thread::sleep_until(pending.trigger + exposure);
      lab_->exposure_edge();
      Frame frame = render(pending.levels);
      lock.lock();
      frame.sequence = sequence_++;
      frame.camera_frame_id = ++frame_id_;
      int nth = lab_->drop_every_nth_frame;
      if (!lab_->camera_present) {
        frame.status = FrameStatus::kTimeout;
        frame.data.clear();
      } else if (nth > 0 && frame.camera_frame_id % static_cast<std::uint64_t>(nth) == 0) {
        frame.status = FrameStatus::kMissingPackets;
        frame.data.clear();
        stats_.missing_packets += 3;
      }
      if (frame.status == FrameStatus::kComplete) ++stats_.completed; else ++stats_.failed;
      auto callback = callback_;
      lock.unlock();
      callback(std::move(frame));
      lock.lock();
    }
  }
  Frame render(const DriveLevels& levels) const {
    Frame frame;
    frame.width = width_;
    frame.height = height_;
    frame.pixel_format = settings_.pixel_format;
    frame.host_timestamp = std::chrono::system_clock::now();
    frame.camera_timestamp_ns = static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count());
    double light = 0;
    for (double level : levels) light += level;
    light = std::min(1.0, light / 2.0);
    const int bits = significant_bits(frame.pixel_format);
    const int bytes = bits == 8 ? 1 : 2;
    const int samples = samples_per_pixel(frame.pixel_format);
    const double full = (1 << bits) - 1;
    frame.data.resize(static_cast<std::size_t>(width_) * height_ * samples * bytes);
    std::size_t i = 0;
    for (int y = 0; y < height_; ++y)
      for (int x = 0; x < width_ * samples; ++x) {
        double value = full * (0.02 + 0.9 * light * (0.5 + 0.5 * x / std::max(1, width_ * samples)));
        auto v = static_cast<std::uint16_t>(std::min(full, value));
        if (bytes == 1) frame.data[i++] = static_cast<std::uint8_t>(v);
        else {
          std::memcpy(&frame.data[i], &v, 2);
          i += 2;
        }
      }
    return frame;
  }
  std::shared_ptr<LoopbackLab> lab_;
  std::string name_;
  int width_, height_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  CameraSettings settings_;
  FrameCallback callback_;
  bool running_ = false;
  std::deque<Pending> pending_;
  std::thread worker_;
  std::uint64_t sequence_ = 0, frame_id_ = 0;
  StreamStatistics stats_;
};

}  // namespace

std::unique_ptr<LedController> make_loopback_led_controller(std::shared_ptr<LoopbackLab> lab, const DeviceConfig& config) {
  return std::make_unique<LoopbackLed>(std::move(lab), config.name);
}
std::unique_ptr<Camera> make_loopback_camera(std::shared_ptr<LoopbackLab> lab, const DeviceConfig& config) {
  return std::make_unique<LoopbackCamera>(std::move(lab), config);
}

std::vector<DeviceConfig> loopback_lab_devices() {
  DeviceConfig led{"sphere", DeviceKind::kLedController, "loopback", "in-process", nlohmann::json::object()};
  DeviceConfig camera{"cam0", DeviceKind::kCamera, "loopback", "in-process", {{"width", 64}, {"height", 48}}};
  return {led, camera};
}

}  // namespace chromo::daemon
