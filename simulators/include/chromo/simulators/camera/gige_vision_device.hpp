#pragma once
// GigeVisionDevice: the device side of GigE Vision (GVCP control channel and
// GVSP stream channel 0) on one loopback address 127.x.y.z:3956, the
// project's own (docs/protocols/gige-vision.md). It serves a GenICam
// description from device memory (XML URL "Local:...", read with READMEM),
// keeps the bootstrap registers and a block of camera registers, and sends
// image blocks (leader, payload packets, trailer) to the stream destination
// the controlling application wrote (SCDA/SCP), with the packet size SCPS.
// It knows nothing of cameras: CameraSimulator owns one and gives meaning to
// the camera registers (write hook) and the pixels (send_block).
//
// Address: options.address "127.a.b.c" binds that address (std::runtime_error
// when taken); empty picks one at random in 127.77.0.1-127.77.255.254 (the
// documented sub-range for simulators), keeping the first that binds, so
// parallel processes do not collide. Nothing is ever sent outside
// 127.0.0.0/8: replies go to the command's source (a loopback address by
// construction) and a stream destination outside 127/8 is refused with
// GVCP status INVALID_PARAMETER.
//
// GVCP: DISCOVERY (unicast), READREG/WRITEREG (several addresses per
// command), READMEM/WRITEMEM, PACKETRESEND (no acknowledge). Malformed
// packets (shorter than a header, key not 0x42, length field beyond the
// datagram) are ignored and counted; an unknown command, a bad alignment, an
// address outside the map, a write to a read-only register or a count out of
// range is answered with the GigE Vision error status and changes nothing.
// Control channel privilege (0x0A00): the first application that writes
// control (or exclusive) access owns writes until it writes 0 or stays
// silent for longer than the heartbeat timeout (0x0938, ms); others' writes
// get ACCESS_DENIED. Losing control stops acquisition (on_control_lost).
//
// GVSP and resends: blocks carry 16-bit block ids (first_block_id after each
// start(), then counting up, 65535 -> 1: 0 is skipped) and
// 24-bit packet ids; each payload packet holds SCPS - 36 bytes. The last
// `retained_blocks` blocks are kept; a PACKETRESEND for one of them is
// answered by sending the requested packets again (standard or extended
// ids), a request for a block no longer kept gets one GVSP packet with
// status PACKET_UNAVAILABLE. Fault injection (GvspFaultOptions) acts on first
// transmissions only: resent packets are never dropped, delayed or reordered.
//
// Threading and lifetime: one GVCP thread (commands, resends, heartbeat)
// runs from start() until stop() or destruction; send_block() is called from
// the owner's acquisition thread (one caller at a time) and returns when the
// block's packets (and delayed ones) are sent. The write hook and
// on_control_lost run on the GVCP thread and must not call stop(). All
// public methods are thread-safe. stop() closes both sockets (the device
// disappears, as when powered off); start() binds the same address again
// with power-on register values.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace chromo::simulators {

struct GvspFaultOptions {
  double loss_probability = 0;     // each first transmission of a GVSP packet is dropped with this probability
  double reorder_probability = 0;  // ... sent after the packet that follows it
  double delay_probability = 0;    // ... held back delay_us (sent late, after later packets)
  int delay_us = 0;
  // false: PACKETRESEND commands are counted but not answered (a camera
  // without a resend buffer: lost packets stay lost, frames fail).
  bool answer_resend_requests = true;
  std::uint64_t seed = 1;          // the fault dice

  bool IsValid(std::string* error) const;
};

struct GigeVisionDeviceOptions {
  std::string address;  // "127.a.b.c"; empty = random in 127.77.0.0/16 (see above)
  std::string manufacturer = "Chromosphere";
  std::string model = "CHROMO-SIM-CAM";
  std::string device_version = "1.0";
  std::string serial;     // 1-15 characters (bootstrap field of 16 bytes)
  std::string user_name;  // 0-15 characters
  std::string genicam_xml;         // served from device memory; required
  std::uint32_t camera_register_base = 0x10000;  // camera registers: [base, base + 4 * camera_register_count)
  std::uint32_t camera_register_count = 64;
  int retained_blocks = 8;         // blocks kept for resends, 1-64
  std::uint16_t first_block_id = 1;  // block id of the first block after start(), 1-65535
  GvspFaultOptions faults;

  bool IsValid(std::string* error) const;
};

// Counters since construction (they survive stop()/start()).
struct GigeVisionDeviceCounters {
  std::uint64_t gvcp_commands = 0;          // well-formed commands handled
  std::uint64_t gvcp_error_acks = 0;        // answered with an error status
  std::uint64_t gvcp_ignored = 0;           // malformed datagrams dropped without answer
  std::uint64_t blocks_sent = 0;
  std::uint64_t packets_sent = 0;           // GVSP packets on the wire, resends included
  std::uint64_t packets_dropped = 0;        // fault injection: lost
  std::uint64_t packets_delayed = 0;
  std::uint64_t packets_reordered = 0;
  std::uint64_t resend_requests = 0;        // PACKETRESEND commands received
  std::uint64_t resend_requests_answered = 0;  // ... whose block was retained
  std::uint64_t resend_requests_unavailable = 0;
  std::uint64_t packets_resent = 0;
  std::uint64_t control_lost = 0;           // heartbeat expiries
};

// One image block: what the leader announces and the payload bytes.
struct GvspImageBlock {
  std::uint32_t pixel_format = 0;  // PFNC
  std::uint32_t width = 0, height = 0, offset_x = 0, offset_y = 0;
  std::uint64_t timestamp_ticks = 0;  // device clock, 1 GHz ticks
  // true: the payload is chunk data (the image as the first chunk, then
  // others, each followed by its id and length, big-endian) and the leader
  // says so (payload type 0x4001, image with extended chunk).
  bool has_chunks = false;
  std::shared_ptr<const std::vector<std::uint8_t>> payload;
};

class GigeVisionDevice {
 public:
  static constexpr int kGvcpPort = 3956;
  // Called (GVCP thread, under the device's lock) for a write to a camera
  // register before it is stored; returns the GVCP status (0 = store the
  // value, anything else = refuse with that status). It must not call the
  // device: `read` gives the other camera registers' current values.
  using RegisterReader = std::function<std::uint32_t(std::uint32_t address)>;
  using WriteHook =
      std::function<std::uint16_t(std::uint32_t address, std::uint32_t value, const RegisterReader& read)>;

  explicit GigeVisionDevice(GigeVisionDeviceOptions options);  // std::invalid_argument for invalid options
  ~GigeVisionDevice();
  GigeVisionDevice(const GigeVisionDevice&) = delete;
  GigeVisionDevice& operator=(const GigeVisionDevice&) = delete;

  // Binds (address chosen on the first start and kept) and starts the GVCP
  // thread; resets the bootstrap registers to power-on values. Throws
  // std::runtime_error when the address cannot be bound.
  void start();
  void stop();
  bool running() const;
  std::string address() const;  // "127.a.b.c", known after the first start()

  void set_write_hook(WriteHook hook);
  void set_on_control_lost(std::function<void()> callback);
  void set_faults(const GvspFaultOptions& faults);  // std::invalid_argument when invalid

  // Camera registers (addresses inside the camera block), local access.
  std::uint32_t camera_register(std::uint32_t address) const;
  void set_camera_register(std::uint32_t address, std::uint32_t value);

  // Sends one block to the stream destination; false (nothing sent) when no
  // destination is set or the device is stopped. Returns the block id used.
  bool send_block(const GvspImageBlock& block, std::uint16_t* block_id = nullptr);
  // Nanoseconds on the device clock (the GVSP timestamp's clock, since start()).
  std::uint64_t now_ticks() const;

  GigeVisionDeviceCounters counters() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace chromo::simulators
