#pragma once
// Camera: a GigE Vision camera (through Aravis), or its simulator, which is a
// real GigE Vision device on loopback and therefore runs this same code.
//
// Frames: every frame the camera announces completes exactly once, through
// the FrameCallback, with a status and a sequence number. Sequence numbers
// are the driver's own, consecutive from 0 per stream start, assigned in
// acquisition order: a gap between two delivered frames never happens; a frame
// that could not be received is delivered with a failure status instead. The
// camera's own frame id is reported too (gaps in it reveal frames the link
// lost before the driver ever saw them; they are counted in statistics()).
//
// Thread rules: configure/start/stop/trigger from one control thread. The
// FrameCallback runs on the driver's stream thread, one call at a time, and
// must return quickly (hand the frame to a queue). stop_stream() returns only
// after the last callback has returned. Lifetime: destroying a Camera stops
// its stream first.

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace chromo::drivers {

enum class PixelFormat { kMono8, kMono12, kMono16, kBayerRG8, kBayerRG12, kBayerRG16, kRgb8 };

struct Roi {
  int x = 0, y = 0, width = 0, height = 0;  // width/height 0 = full sensor
};

enum class TriggerMode {
  kFreeRun,   // continuous acquisition at the frame rate
  kSoftware,  // one frame per software_trigger()
  kHardware,  // one frame per edge on the trigger input line
};

struct CameraSettings {
  double exposure_us = 10000;
  double gain_db = 0;
  PixelFormat pixel_format = PixelFormat::kMono8;
  Roi roi;
  TriggerMode trigger_mode = TriggerMode::kSoftware;
  double frame_rate_hz = 10;  // kFreeRun only
};

struct CameraInfo {
  std::string vendor, model, serial, address;  // address: IP or device id
  int sensor_width = 0, sensor_height = 0;
  std::vector<PixelFormat> pixel_formats;
};

enum class FrameStatus {
  kComplete,
  kMissingPackets,  // packets lost and not recovered by resends
  kTimeout,         // the frame did not complete in time
  kAborted,         // the stream was stopped while the frame was in flight
  kError,
};

struct Frame {
  std::uint64_t sequence = 0;         // driver's, consecutive from 0 per stream
  std::uint64_t camera_frame_id = 0;  // the device's block id
  FrameStatus status = FrameStatus::kComplete;
  std::uint64_t camera_timestamp_ns = 0;
  std::chrono::system_clock::time_point host_timestamp;
  int width = 0, height = 0;
  PixelFormat pixel_format = PixelFormat::kMono8;
  std::vector<std::uint8_t> data;  // empty unless status == kComplete
};

struct StreamStatistics {
  std::uint64_t completed = 0;
  std::uint64_t failed = 0;           // delivered with a failure status
  std::uint64_t lost_before_driver = 0;  // gaps in the camera's frame ids
  std::uint64_t resent_packets = 0;
  std::uint64_t missing_packets = 0;
  std::uint64_t reconnects = 0;
};

using FrameCallback = std::function<void(Frame&&)>;

class Camera {
 public:
  virtual ~Camera() = default;
  virtual CameraInfo info() const = 0;
  // Applies and remembers the settings (they are restored after a reconnect).
  virtual void configure(const CameraSettings& settings) = 0;
  virtual void start_stream(FrameCallback on_frame) = 0;
  virtual void stop_stream() = 0;
  virtual void software_trigger() = 0;
  virtual StreamStatistics statistics() const = 0;
};

}  // namespace chromo::drivers
