#pragma once
// Helpers of the daemon tests: a Daemon on the virtual lab (the device
// simulators on their real protocols: Modbus TCP LED controller, GigE Vision
// camera on a loopback address of its own, 127.77.x.y:3956, simulated
// USB2000+, all through the real drivers), with small frames, in a fresh
// temporary sessions folder. Faults are switched on the simulators
// (TestLab::simulators). Labs of parallel tests do not collide.

#include <chrono>
#include <filesystem>
#include <memory>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "../support/fresh_directory.hpp"
#include "chromo/daemon/daemon.hpp"
#include "chromo/session/frame_files.hpp"
#include "chromo/daemon/internal/devices/virtual_lab.hpp"
#include "chromo/drivers/camera/aravis_camera.hpp"
#include "chromo/simulators/camera/camera_simulator.hpp"
#include "chromo/simulators/leds/led_lab.hpp"

namespace chromo::daemon::testing {

using chromo::testing::fresh_directory;

// Small frames keep the suite fast: 160x120 BayerRG12 (16-bit containers).
inline VirtualLabOptions small_lab_options() {
  VirtualLabOptions options;
  options.cameras.front().sensor_width = 160;
  options.cameras.front().sensor_height = 120;
  options.scene_size = 64;
  options.scene_threads = 1;
  options.camera_serial = "CHROMO-TEST-CAM";
  return options;
}

struct TestLab {
  std::filesystem::path directory;
  DaemonConfig config;
  VirtualLabOptions lab_options = small_lab_options();
  // The simulators of the last daemon() (faults, truth).
  std::shared_ptr<VirtualLabSimulators> simulators;

  explicit TestLab(const std::string& name) : directory(fresh_directory(name)) {
    config.unix_socket = (directory / "chromod.sock").string();
    config.sessions_dir = directory / "sessions";
    config.mixes = default_virtual_lab_mixes();
    // A loaded 2-core machine renders, sends and receives in this one
    // process: a late frame must not read as a lost one.
    config.frame_timeout_ms = 2000;
  }
  ~TestLab() {
    std::error_code ignored;
    std::filesystem::remove_all(directory, ignored);
  }
  // A new virtual lab (the previous one is stopped first) and a Daemon on its devices.
  std::unique_ptr<Daemon> daemon() {
    simulators.reset();
    auto lab = start_virtual_lab(lab_options);
    simulators = lab.simulators;
    config.devices = lab.devices;
    for (auto& camera : lab.device_set.cameras)
      EXPECT_TRUE(camera->open_error.empty()) << camera->open_error;
    return std::make_unique<Daemon>(config, std::move(lab.device_set));
  }
  drivers::DriveLevels emitted() const { return simulators->leds().status().applied.drive; }
};

// The AravisCamera of a daemon's camera "cam0".
inline drivers::AravisCamera& aravis(Daemon& daemon) {
  return dynamic_cast<drivers::AravisCamera&>(*daemon.devices().cameras.front()->device);
}

inline session::SessionPlan quick_standard_plan(std::uint32_t frames = 1, double exposure_us = 2000) {
  session::StandardPlanOptions options;
  options.exposure_us = exposure_us;
  options.frames_per_camera = frames;
  options.settle_ms = 0;
  return session::standard_plan(options);
}

// Mean of one site of the RGGB mosaic (0 R, 1 and 2 G, 3 B) of a stored
// 16-bit frame, in DN of the 12-bit ADC.
inline double bayer_site_mean(const std::filesystem::path& tiff, int site) {
  const auto image = session::read_tiff(tiff);
  const int dx = site % 2, dy = site / 2;
  double sum = 0;
  std::size_t count = 0;
  for (int y = dy; y < image.height; y += 2)
    for (int x = dx; x < image.width; x += 2) {
      const std::size_t i = (static_cast<std::size_t>(y) * image.width + x) * 2;
      sum += static_cast<double>(image.data[i] | (image.data[i + 1] << 8));
      ++count;
    }
  return count ? sum / static_cast<double>(count) : 0.0;
}

// Waits until `predicate(record)` or the timeout; returns the last record.
template <typename Predicate>
session::OperationRecord wait_for(Daemon& daemon, const std::string& id, Predicate predicate,
                         std::chrono::milliseconds timeout = std::chrono::seconds(60)) {
  auto deadline = std::chrono::steady_clock::now() + timeout;
  std::uint64_t version = 0;
  while (true) {
    auto change = daemon.operations().wait_change(id, version, std::chrono::milliseconds(50));
    if (!change) throw std::runtime_error("operation vanished");
    version = change->second;
    if (predicate(change->first) || std::chrono::steady_clock::now() > deadline) return change->first;
  }
}

inline session::OperationRecord wait_final(Daemon& daemon, const std::string& id) {
  return wait_for(daemon, id, [](const session::OperationRecord& r) { return session::is_final(r.state); });
}

// The quick calibration the on-line estimation tests start from: drive
// levels 0.5 and 1, 100 ms warm-up (30 s of LED time at the lab's 300x).
inline session::OperationRecord run_quick_calibration(Daemon& daemon) {
  CalibrationRequest calibration;
  calibration.drive_levels = {0.5, 1.0};
  calibration.warmup_ms = 100;
  return wait_final(daemon, daemon.start_calibration(calibration).id);
}

}  // namespace chromo::daemon::testing
