#pragma once
// LoopbackLab: in-process stand-in devices (backend "loopback") that let the
// daemon's sequencer, pipeline, storage and API run without hardware or the
// protocol simulators. They speak no protocol and model no physics: the LED
// controller acknowledges states (or, on demand, stops answering with
// DeviceError::kTimeout); the camera renders a synthetic ramp whose level
// follows the applied drive levels, delivered from its own stream thread, and
// can drop frames or disappear on demand. Use the virtual lab (backend
// "virtual", simulators/) for anything that checks measurements.
//
// Thread rules: the fault switches are atomic and may be flipped from any
// thread; devices follow their interfaces' rules.

#include <atomic>
#include <memory>
#include <mutex>

#include "chromo/daemon/device_set.hpp"

namespace chromo::daemon {

class LoopbackLab {
 public:
  // Faults on demand.
  std::atomic<bool> led_responding{true};
  std::atomic<bool> camera_present{true};
  std::atomic<int> drop_every_nth_frame{0};  // 0 = none; n: every n-th frame arrives kMissingPackets

  // What the controller currently emits (set_state or the armed sequence).
  drivers::DriveLevels emitted() const;
  void set_emitted(const drivers::DriveLevels& levels);
  // The camera's exposure-active edge (hardware-timed sequences advance on it).
  void exposure_edge();
  void arm(std::vector<drivers::LedState> states, drivers::SequenceTrigger trigger);
  void disarm();
  int sequence_position() const;

 private:
  mutable std::mutex mutex_;
  drivers::DriveLevels emitted_{};
  std::vector<drivers::LedState> sequence_;
  drivers::SequenceTrigger trigger_ = drivers::SequenceTrigger::kSoftware;
  int position_ = -1;
};

std::unique_ptr<drivers::LedController> make_loopback_led_controller(std::shared_ptr<LoopbackLab> lab,
                                                                     const DeviceConfig& config);
// settings: width, height (default 64×48), pixel_format ("Mono8"|"Mono16"|"BayerRG12"...).
std::unique_ptr<drivers::Camera> make_loopback_camera(std::shared_ptr<LoopbackLab> lab, const DeviceConfig& config);

// A device list of one loopback LED controller "sphere" and one camera "cam0".
std::vector<DeviceConfig> loopback_lab_devices();

}  // namespace chromo::daemon
