#pragma once
// A camera simulator on its own loopback address (127.77.x.y, picked at
// random) and the driver opened on it by address, for the camera tests. Each
// test's simulator has its own address, so test processes run in parallel.

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "chromo/drivers/camera/aravis_camera.hpp"
#include "chromo/simulators/camera/camera_simulator.hpp"
#include "chromo/simulators/camera/fixed_illumination.hpp"
#include "chromo/spectral/cie.hpp"

namespace chromo::testing {

// The simulator renders and sends on threads of this process, and ctest runs
// two suites at once on a 2-core machine: packets can arrive hundreds of
// milliseconds late. Real deployments keep the driver's 200 ms default; the
// tests give an incomplete frame 2 s before calling it failed, so a loaded
// machine makes them slower, never red.
inline constexpr int kTestFrameRetentionMs = 2000;

// Collects frames from the stream thread; the test thread waits on it.
class FrameSink {
 public:
  void operator()(drivers::Frame&& frame) {
    std::lock_guard lock(mutex_);
    frames_.push_back(std::move(frame));
    cv_.notify_all();
  }
  drivers::FrameCallback callback() {
    return [this](drivers::Frame&& frame) { (*this)(std::move(frame)); };
  }
  bool wait_for_count(std::size_t count, std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    return cv_.wait_for(lock, timeout, [&] { return frames_.size() >= count; });
  }
  std::vector<drivers::Frame> take() {
    std::lock_guard lock(mutex_);
    return std::move(frames_);
  }
  std::size_t size() {
    std::lock_guard lock(mutex_);
    return frames_.size();
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  std::vector<drivers::Frame> frames_;
};

// D65 scaled to a peak of 1: a smooth stand-in for the sphere's light.
inline spectral::Spectrum test_irradiance(double peak = 1.0) {
  const spectral::Spectrum d65 = spectral::illuminant_d65();
  return d65 * (peak / d65.max());
}

inline std::shared_ptr<const simulators::Scene> small_skin_scene() {
  static const auto scene = [] {
    simulators::SkinSceneOptions options;
    options.width = 128;
    options.height = 128;
    return std::make_shared<const simulators::Scene>(simulators::make_skin_scene(options));
  }();
  return scene;
}

class CameraOnLoopback : public ::testing::Test {
 protected:
  static constexpr const char* kSerial = "CHROMO-TEST";

  void SetUp() override {
    illumination_ = std::make_shared<simulators::FixedSpectrumIllumination>(test_irradiance());
    simulators::CameraSimulatorOptions sim_options;
    sim_options.serial = kSerial;
    sim_options.sensor_width = 256;
    sim_options.sensor_height = 256;
    sim_options.first_block_id = 65400;  // the 16-bit block id wraps after 135 frames
    simulator_ = std::make_unique<simulators::CameraSimulator>(sim_options, illumination_, small_skin_scene());
    open_camera(kTestFrameRetentionMs);
  }
  // (Re)opens the driver on the simulator with the given frame retention.
  void open_camera(int frame_retention_ms) {
    camera_.reset();
    drivers::AravisCameraOptions options;
    options.serial = kSerial;
    options.address = simulator_->address();
    options.frame_retention_ms = frame_retention_ms;
    options.socket_buffer_bytes = 4u << 20;
    options.watchdog_period_ms = 200;
    options.reconnect_retry_ms = 200;
    options.on_warning = [this](const std::string& message) {
      std::lock_guard lock(warnings_mutex_);
      warnings_.push_back(message);
    };
    camera_ = drivers::AravisCamera::open(options);
  }
  void TearDown() override {
    camera_.reset();
    simulator_.reset();
  }

  static drivers::CameraSettings settings(drivers::PixelFormat format, drivers::Roi roi = {}) {
    drivers::CameraSettings s;
    s.exposure_us = 10000;
    s.gain_db = 0;
    s.pixel_format = format;
    s.roi = roi;
    s.trigger_mode = drivers::TriggerMode::kSoftware;
    return s;
  }

  // Triggers one frame and waits for it (false if none came within the timeout).
  bool trigger_and_wait(FrameSink& sink, std::chrono::milliseconds timeout = std::chrono::milliseconds(4000)) {
    const std::size_t before = sink.size();
    camera_->software_trigger();
    return sink.wait_for_count(before + 1, timeout);
  }

  std::shared_ptr<simulators::FixedSpectrumIllumination> illumination_;
  std::unique_ptr<simulators::CameraSimulator> simulator_;
  std::unique_ptr<drivers::AravisCamera> camera_;
  std::mutex warnings_mutex_;
  std::vector<std::string> warnings_;
};

}  // namespace chromo::testing
