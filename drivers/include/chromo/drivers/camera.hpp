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
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace chromo::drivers {

enum class PixelFormat { kMono8, kMono12, kMono16, kBayerRG8, kBayerRG12, kBayerRG16, kRgb8 };

// How a format's samples map to colour.
enum class ColourLayout {
  kMono,       // one sample per pixel, no colour
  kBayerRGGB,  // one sample per pixel, colour filter array R G / G B (R at even row, even column)
  kRgb,        // three samples per pixel, R G B
};

// The one table of pixel-format facts (every library asks it; no other file
// keeps its own copy). Samples are stored in containers of bytes_per_sample
// bytes (16-bit containers in host order, i.e. little-endian as GigE Vision
// sends them); a 12-bit format keeps its values unscaled (0-4095) in 16 bits.
struct PixelFormatInfo {
  PixelFormat format;
  std::string_view name;        // GenICam PFNC name: files, JSON, configuration
  std::uint32_t pfnc_code;      // GigE Vision PFNC value (Aravis' ARV_PIXEL_FORMAT_*)
  int significant_bits;         // 8, 12 or 16
  int bytes_per_sample;         // 1 or 2
  int samples_per_pixel;        // 1 or 3
  ColourLayout layout;
  constexpr std::uint32_t full_scale() const { return (1u << significant_bits) - 1; }  // 255, 4095, 65535
  constexpr std::size_t frame_bytes(int width, int height) const {
    return static_cast<std::size_t>(width) * static_cast<std::size_t>(height) *
           static_cast<std::size_t>(samples_per_pixel * bytes_per_sample);
  }
};

inline constexpr PixelFormatInfo kPixelFormats[] = {
    {PixelFormat::kMono8, "Mono8", 0x01080001u, 8, 1, 1, ColourLayout::kMono},
    {PixelFormat::kMono12, "Mono12", 0x01100005u, 12, 2, 1, ColourLayout::kMono},
    {PixelFormat::kMono16, "Mono16", 0x01100007u, 16, 2, 1, ColourLayout::kMono},
    {PixelFormat::kBayerRG8, "BayerRG8", 0x01080009u, 8, 1, 1, ColourLayout::kBayerRGGB},
    {PixelFormat::kBayerRG12, "BayerRG12", 0x01100011u, 12, 2, 1, ColourLayout::kBayerRGGB},
    {PixelFormat::kBayerRG16, "BayerRG16", 0x0110002fu, 16, 2, 1, ColourLayout::kBayerRGGB},
    {PixelFormat::kRgb8, "RGB8", 0x02180014u, 8, 1, 3, ColourLayout::kRgb},
};

// The table is in enum order, so a format is its own index.
constexpr bool pixel_format_table_in_enum_order() {
  for (std::size_t i = 0; i < std::size(kPixelFormats); ++i)
    if (static_cast<std::size_t>(kPixelFormats[i].format) != i) return false;
  return std::size(kPixelFormats) == static_cast<std::size_t>(PixelFormat::kRgb8) + 1;
}
static_assert(pixel_format_table_in_enum_order());
constexpr const PixelFormatInfo& pixel_format_info(PixelFormat format) {
  return kPixelFormats[static_cast<std::size_t>(format)];
}
constexpr std::string_view pixel_format_name(PixelFormat format) { return pixel_format_info(format).name; }
// Inverse of pixel_format_name (exact, case-sensitive); nullopt for anything else.
constexpr std::optional<PixelFormat> parse_pixel_format(std::string_view name) {
  for (const auto& info : kPixelFormats)
    if (info.name == name) return info.format;
  return std::nullopt;
}
constexpr std::optional<PixelFormat> pixel_format_from_pfnc(std::uint32_t code) {
  for (const auto& info : kPixelFormats)
    if (info.pfnc_code == code) return info.format;
  return std::nullopt;
}
// "Mono8, Mono12, ..., RGB8": for messages that list the accepted names.
inline std::string pixel_format_names() {
  std::string names;
  for (const auto& info : kPixelFormats) (names += names.empty() ? "" : ", ") += info.name;
  return names;
}

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
  double exposure_min_us = 0, exposure_max_us = 0;  // GenICam ExposureTime range (0: not known)
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
  // The camera's count of the trigger this frame answered (1 = the first
  // trigger after the stream started; the device's chunk data), when the
  // camera sends it; nullopt for free-running frames, failed frames and
  // cameras without the chunk.
  std::optional<std::uint64_t> trigger_count;
  std::chrono::system_clock::time_point host_timestamp;
  int width = 0, height = 0;
  PixelFormat pixel_format = PixelFormat::kMono8;
  std::vector<std::uint8_t> data;  // empty unless status == kComplete
};

struct StreamStatistics {
  std::uint64_t completed = 0;
  std::uint64_t failed = 0;           // delivered with a failure status
  std::uint64_t lost_before_driver = 0;  // gaps in the camera's frame ids
  std::uint64_t resend_requests = 0;  // packets the receiver asked the device to send again
  std::uint64_t resent_packets = 0;   // ... that then arrived
  std::uint64_t missing_packets = 0;  // packets never received
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
