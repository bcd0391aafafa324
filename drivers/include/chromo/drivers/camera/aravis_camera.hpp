#pragma once
// AravisCamera: the Camera interface (camera.hpp) over a GigE Vision camera,
// through Aravis 0.8. The camera simulator (simulators/camera) is a real GigE
// Vision device on its own loopback address 127.x.y.z, so tests run exactly
// this code.
//
// Opening: with AravisCameraOptions::address set ("127.77.3.9", "10.0.0.12"),
// open() asks Aravis for the device at that address (unicast GVCP, no
// broadcast discovery) and checks that its bootstrap serial number is
// AravisCameraOptions::serial (DeviceError kNotFound when nothing answers
// there, kRefused when another serial answers). Without an address,
// discover_gige_cameras() lists the GigE Vision devices Aravis finds
// (broadcast discovery on every interface) and open() takes the one whose
// serial number matches. Either way the driver then takes the control
// channel; a reconnect looks the camera up the same way.
//
// Receive path (docs/camera.md, NOTES.md): the stream uses the standard UDP
// socket (Aravis' packet socket is disabled: it receives nothing on loopback),
// with a fixed socket buffer of min(socket_buffer_bytes, net.core.rmem_max).
// When rmem_max is below what the configured rate needs (a few frames in
// flight, or 100 ms of free-running data) a warning goes to on_warning once
// per configure(). Packet resends are requested (Aravis' default); frames
// whose packets are still missing after frame_retention_ms complete with
// FrameStatus::kMissingPackets or kTimeout. StreamStatistics carries Aravis'
// receiver counters: resend_requests (packets asked for again),
// resent_packets (packets that arrived after a request) and missing_packets.
//
// Frame lifecycle: `buffer_count` ArvBuffers are pushed into the stream; the
// driver's stream thread pops each filled buffer, copies it into a Frame,
// hands the frame to the FrameCallback and pushes the buffer back. Every
// buffer Aravis completes is delivered once, with the driver's sequence number
// (consecutive from 0 per start_stream(), across reconnects). Frames the link
// lost entirely (no packet of them arrived, or no free buffer) show up as gaps
// in the camera's frame ids and are counted in lost_before_driver.
//
// Lost link: the device's "control-lost" signal (Aravis' heartbeat) and a
// watchdog that reads a bootstrap register every watchdog_period_ms both
// detect it. The link thread then drops the stream and the device, reopens
// the camera by serial (retrying every reconnect_retry_ms), applies the last
// configure()d settings and, if a stream was running, restarts acquisition
// and the stream thread. While the link is down, configure/start/trigger
// throw DeviceError kDisconnected.
//
// Thread rules: configure/start_stream/stop_stream/software_trigger/info come
// from one control thread; statistics() and link_up() from any thread. The
// FrameCallback runs on the stream thread, one call at a time; it must not
// call back into the camera. stop_stream() and the destructor return after
// the last callback has returned.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "chromo/drivers/camera.hpp"

namespace chromo::drivers {

struct AravisCameraOptions {
  std::string serial;                       // required: the device's serial number
  std::string address;                      // IPv4 of the device; "" = find it by broadcast discovery
  int buffer_count = 8;                     // ArvBuffers in the stream's pool
  std::size_t socket_buffer_bytes = 32u << 20;  // capped at net.core.rmem_max
  int packet_size_bytes = 0;                // 0 = leave the device's (1400 on the simulator)
  int frame_retention_ms = 200;             // how long an incomplete frame waits for resends
  int watchdog_period_ms = 500;
  int reconnect_retry_ms = 500;
  std::string hardware_trigger_line;        // "" = first "Line*" entry of TriggerSource
  // The ChunkSelector entry whose chunk (feature "Chunk" + this name) counts
  // the triggers the camera received since AcquisitionStart; enabled when the
  // device lists it and the camera is triggered (Frame::trigger_count), "" = never.
  std::string trigger_count_chunk = "TriggerCount";
  // Warnings (socket buffer too small, restore failures). Default: stderr.
  std::function<void(const std::string&)> on_warning;

  bool IsValid(std::string* error) const;
};

// The GigE Vision cameras visible now (Aravis' device list refreshed).
std::vector<CameraInfo> discover_gige_cameras();

class AravisCamera final : public Camera {
 public:
  // Throws DeviceError (kNotFound, kRefused) or std::invalid_argument for invalid options.
  static std::unique_ptr<AravisCamera> open(const AravisCameraOptions& options);
  ~AravisCamera() override;

  AravisCamera(const AravisCamera&) = delete;
  AravisCamera& operator=(const AravisCamera&) = delete;

  CameraInfo info() const override;
  void configure(const CameraSettings& settings) override;
  void start_stream(FrameCallback on_frame) override;
  void stop_stream() override;
  // Only in TriggerMode::kSoftware (DeviceError kInvalidRequest otherwise).
  void software_trigger() override;
  StreamStatistics statistics() const override;

  // False from the moment a lost link is detected until the reconnect completed.
  bool link_up() const;
  // The settings the device reported after the last configure() or reconnect
  // (exposure and gain as the device rounded them).
  CameraSettings applied_settings() const;

 private:
  struct Impl;
  explicit AravisCamera(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace chromo::drivers
