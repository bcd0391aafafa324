#pragma once
// Helpers of the daemon tests: a Daemon on loopback devices whose faults the
// test switches, in a fresh temporary sessions folder.

#include <chrono>
#include <filesystem>
#include <memory>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "chromo/daemon/daemon.hpp"
#include "chromo/daemon/loopback_lab.hpp"

namespace chromo::daemon::testing {

inline std::filesystem::path fresh_directory(const std::string& name) {
  auto path = std::filesystem::temp_directory_path() /
              ("chromo-" + name + "-" + std::to_string(::getpid()) + "-" + std::to_string(std::random_device{}()));
  std::filesystem::remove_all(path);
  std::filesystem::create_directories(path);
  return path;
}

struct TestLab {
  std::shared_ptr<LoopbackLab> lab = std::make_shared<LoopbackLab>();
  std::filesystem::path directory;
  DaemonConfig config;

  explicit TestLab(const std::string& name) : directory(fresh_directory(name)) {
    config.unix_socket = (directory / "chromod.sock").string();
    config.sessions_dir = directory / "sessions";
    config.mixes = default_virtual_lab_mixes();
    config.frame_timeout_ms = 300;
    config.devices = loopback_lab_devices();
  }
  ~TestLab() {
    std::error_code ignored;
    std::filesystem::remove_all(directory, ignored);
  }
  DeviceSet devices(nlohmann::json camera_settings = {{"width", 32}, {"height", 24}}) {
    BackendRegistry registry;
    registry.add_led_controller("loopback", [this](const DeviceConfig& c) { return make_loopback_led_controller(lab, c); });
    registry.add_camera("loopback", [this](const DeviceConfig& c) { return make_loopback_camera(lab, c); });
    auto configs = config.devices;
    for (auto& c : configs)
      if (c.kind == DeviceKind::kCamera) c.settings = camera_settings;
    return registry.open(configs);
  }
  std::unique_ptr<Daemon> daemon(nlohmann::json camera_settings = {{"width", 32}, {"height", 24}}) {
    return std::make_unique<Daemon>(config, devices(camera_settings));
  }
};

inline SessionPlan quick_standard_plan(std::uint32_t frames = 1, double exposure_us = 1000) {
  StandardPlanOptions options;
  options.exposure_us = exposure_us;
  options.frames_per_camera = frames;
  options.settle_ms = 0;
  return standard_plan(options);
}

// Waits until `predicate(record)` or the timeout; returns the last record.
template <typename Predicate>
OperationRecord wait_for(Daemon& daemon, const std::string& id, Predicate predicate,
                         std::chrono::milliseconds timeout = std::chrono::seconds(20)) {
  auto deadline = std::chrono::steady_clock::now() + timeout;
  std::uint64_t version = 0;
  while (true) {
    auto change = daemon.operations().wait_change(id, version, std::chrono::milliseconds(50));
    if (!change) throw std::runtime_error("operation vanished");
    version = change->second;
    if (predicate(change->first) || std::chrono::steady_clock::now() > deadline) return change->first;
  }
}

inline OperationRecord wait_final(Daemon& daemon, const std::string& id) {
  return wait_for(daemon, id, [](const OperationRecord& r) { return is_final(r.state); });
}

}  // namespace chromo::daemon::testing
