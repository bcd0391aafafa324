// AravisCamera: see aravis_camera.hpp for the contract and docs/camera.md for
// the frame lifecycle.
#include "chromo/drivers/camera/aravis_camera.hpp"

#include <arpa/inet.h>
#include <arv.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <fstream>
#include <iostream>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>

#include "chromo/drivers/device_error.hpp"
#include "lost_frame_counter.hpp"
#include "stream_socket_buffer.hpp"

namespace chromo::drivers {
namespace {

// GigE Vision bootstrap register read by the watchdog: Control Channel Privilege.
constexpr guint64 kControlChannelPrivilegeRegister = 0x0A00;

// Aravis' device list is process-global: discovery calls are serialised.
std::mutex& discovery_mutex() {
  static std::mutex mutex;
  return mutex;
}

class GErrorSlot {
 public:
  ~GErrorSlot() { clear(); }
  GError** out() { clear(); return &error_; }
  explicit operator bool() const { return error_ != nullptr; }
  std::string message() const { return error_ != nullptr ? error_->message : ""; }
  bool is_timeout() const {
    return error_ != nullptr && (g_error_matches(error_, ARV_DEVICE_ERROR, ARV_DEVICE_ERROR_TIMEOUT) ||
                                 g_error_matches(error_, ARV_DEVICE_ERROR, ARV_DEVICE_ERROR_NOT_CONNECTED));
  }
  void clear() {
    if (error_ != nullptr) g_error_free(error_);
    error_ = nullptr;
  }

 private:
  GError* error_ = nullptr;
};

// The camera interface's table carries each format's PFNC code, which is
// Aravis' ArvPixelFormat value.
static_assert(pixel_format_info(PixelFormat::kMono8).pfnc_code == ARV_PIXEL_FORMAT_MONO_8);
static_assert(pixel_format_info(PixelFormat::kMono12).pfnc_code == ARV_PIXEL_FORMAT_MONO_12);
static_assert(pixel_format_info(PixelFormat::kMono16).pfnc_code == ARV_PIXEL_FORMAT_MONO_16);
static_assert(pixel_format_info(PixelFormat::kBayerRG8).pfnc_code == ARV_PIXEL_FORMAT_BAYER_RG_8);
static_assert(pixel_format_info(PixelFormat::kBayerRG12).pfnc_code == ARV_PIXEL_FORMAT_BAYER_RG_12);
static_assert(pixel_format_info(PixelFormat::kBayerRG16).pfnc_code == ARV_PIXEL_FORMAT_BAYER_RG_16);
static_assert(pixel_format_info(PixelFormat::kRgb8).pfnc_code == ARV_PIXEL_FORMAT_RGB_8_PACKED);

std::optional<PixelFormat> from_arv(ArvPixelFormat arv) { return pixel_format_from_pfnc(static_cast<std::uint32_t>(arv)); }

// net.core.rmem_max in bytes, 0 when unreadable.
std::size_t read_rmem_max() {
  std::ifstream in("/proc/sys/net/core/rmem_max");
  std::size_t value = 0;
  in >> value;
  return in ? value : 0;
}

FrameStatus to_frame_status(ArvBufferStatus status) {
  switch (status) {
    case ARV_BUFFER_STATUS_SUCCESS: return FrameStatus::kComplete;
    case ARV_BUFFER_STATUS_MISSING_PACKETS: return FrameStatus::kMissingPackets;
    case ARV_BUFFER_STATUS_TIMEOUT: return FrameStatus::kTimeout;
    case ARV_BUFFER_STATUS_ABORTED: return FrameStatus::kAborted;
    default: return FrameStatus::kError;
  }
}

}  // namespace

bool AravisCameraOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (serial.empty()) return fail("serial is empty");
  if (!address.empty()) {
    in_addr parsed{};
    if (inet_pton(AF_INET, address.c_str(), &parsed) != 1)
      return fail("address \"" + address.substr(0, 40) + "\" is not an IPv4 address (a.b.c.d)");
  }
  if (buffer_count < 2 || buffer_count > 256) return fail("buffer_count must be 2-256");
  if (socket_buffer_bytes < 65536) return fail("socket_buffer_bytes must be at least 65536");
  if (packet_size_bytes != 0 && (packet_size_bytes < 576 || packet_size_bytes > 16000))
    return fail("packet_size_bytes must be 0 or 576-16000");
  if (frame_retention_ms < 10 || frame_retention_ms > 10000) return fail("frame_retention_ms must be 10-10000");
  if (watchdog_period_ms < 50) return fail("watchdog_period_ms must be at least 50");
  if (reconnect_retry_ms < 50) return fail("reconnect_retry_ms must be at least 50");
  return true;
}

std::vector<CameraInfo> discover_gige_cameras() {
  std::lock_guard lock(discovery_mutex());
  arv_update_device_list();
  std::vector<CameraInfo> cameras;
  for (unsigned i = 0; i < arv_get_n_devices(); ++i) {
    const char* protocol = arv_get_device_protocol(i);
    if (protocol == nullptr || std::string(protocol) != "GigEVision") continue;
    CameraInfo info;
    auto text = [](const char* s) { return s != nullptr ? std::string(s) : std::string(); };
    info.vendor = text(arv_get_device_vendor(i));
    info.model = text(arv_get_device_model(i));
    info.serial = text(arv_get_device_serial_nbr(i));
    info.address = text(arv_get_device_address(i));
    cameras.push_back(std::move(info));
  }
  return cameras;
}

struct AravisCamera::Impl {
  AravisCameraOptions options;
  std::string device_name;  // "camera <serial>", the device in every DeviceError

  // Guards everything below up to the stream thread's own state.
  mutable std::mutex control_mutex;
  ArvCamera* camera = nullptr;
  ArvStream* stream = nullptr;
  gulong control_lost_handler = 0;
  CameraInfo info;
  std::optional<CameraSettings> settings;  // last configure()d, restored after a reconnect
  CameraSettings applied;
  // The trigger-count chunk: parser from the device's XML (made once), and
  // whether the configured settings enabled it. Written by configure (stream
  // stopped), read by the stream thread.
  ArvChunkParser* chunk_parser = nullptr;
  std::atomic<bool> trigger_count_chunk{false};
  bool streaming = false;  // between start_stream() and stop_stream()
  FrameCallback on_frame;
  std::thread stream_thread;
  std::atomic<bool> stream_thread_stop{false};

  // Owned by the (single) running stream thread.
  std::uint64_t next_sequence = 0;
  detail::LostFrameCounter lost_frames;

  mutable std::mutex stats_mutex;
  StreamStatistics stats;
  std::uint64_t resent_base = 0, missing_base = 0, requests_base = 0;  // counters of streams already destroyed

  std::atomic<bool> link_lost{false};
  std::atomic<bool> link_is_up{true};
  std::mutex link_mutex;
  std::condition_variable link_cv;
  bool shutting_down = false;  // guarded by link_mutex
  std::thread link_thread;

  void warn(const std::string& message) const {
    if (options.on_warning) options.on_warning(device_name + ": " + message);
    else std::cerr << "chromo " << device_name << ": " << message << "\n";
  }

  [[noreturn]] void fail(const std::string& request, const GErrorSlot& error) const {
    throw DeviceError(error.is_timeout() ? DeviceError::Kind::kTimeout : DeviceError::Kind::kRefused, device_name,
                      request, error.message());
  }

  // --- device (control_mutex held) ---

  // Discovery and the GVCP handshake, without control_mutex (they take seconds
  // when the camera is absent). Returns the new device and its address.
  ArvCamera* connect(std::string* address) const {
    return options.address.empty() ? connect_by_serial(address) : connect_by_address(address);
  }

  // Unicast: Aravis opens a device id that is an IP address directly.
  ArvCamera* connect_by_address(std::string* address) const {
    GErrorSlot error;
    ArvCamera* opened = arv_camera_new(options.address.c_str(), error.out());
    if (opened == nullptr)
      throw DeviceError(DeviceError::Kind::kNotFound, device_name, "open GigE Vision device at " + options.address,
                        error ? error.message() : "nothing answered there");
    const char* serial = arv_camera_get_device_serial_number(opened, error.out());
    const std::string found = serial != nullptr ? serial : "";
    if (found != options.serial) {
      g_object_unref(opened);
      throw DeviceError(DeviceError::Kind::kRefused, device_name, "open GigE Vision device at " + options.address,
                        "it has serial \"" + found + "\", not \"" + options.serial + "\"");
    }
    *address = options.address;
    return opened;
  }

  ArvCamera* connect_by_serial(std::string* address) const {
    std::string device_id;
    {
      std::lock_guard lock(discovery_mutex());
      arv_update_device_list();
      for (unsigned i = 0; i < arv_get_n_devices(); ++i) {
        const char* serial = arv_get_device_serial_nbr(i);
        const char* protocol = arv_get_device_protocol(i);
        if (serial != nullptr && options.serial == serial && protocol != nullptr &&
            std::string(protocol) == "GigEVision") {
          device_id = arv_get_device_id(i);
          *address = arv_get_device_address(i) != nullptr ? arv_get_device_address(i) : "";
          break;
        }
      }
    }
    if (device_id.empty())
      throw DeviceError(DeviceError::Kind::kNotFound, device_name, "discover GigE Vision serial " + options.serial,
                        "no device with this serial answered discovery");
    GErrorSlot error;
    ArvCamera* opened = arv_camera_new(device_id.c_str(), error.out());
    if (opened == nullptr) fail("open " + device_id, error);
    return opened;
  }

  // Takes ownership of `opened` and reads what the device offers.
  void install_camera_locked(ArvCamera* opened, const std::string& address) {
    GErrorSlot error;
    camera = opened;
    control_lost_handler = g_signal_connect(arv_camera_get_device(camera), "control-lost",
                                            G_CALLBACK(&Impl::on_control_lost), this);
    CameraInfo fresh;
    auto text = [](const char* s) { return s != nullptr ? std::string(s) : std::string(); };
    fresh.vendor = text(arv_camera_get_vendor_name(camera, error.out()));
    fresh.model = text(arv_camera_get_model_name(camera, error.out()));
    fresh.serial = options.serial;
    fresh.address = address;
    gint sensor_width = 0, sensor_height = 0;
    arv_camera_get_sensor_size(camera, &sensor_width, &sensor_height, error.out());
    if (error) fail("read SensorWidth/SensorHeight", error);
    fresh.sensor_width = sensor_width;
    fresh.sensor_height = sensor_height;
    guint n_formats = 0;
    gint64* formats = arv_camera_dup_available_pixel_formats(camera, &n_formats, error.out());
    for (guint i = 0; i < n_formats; ++i)
      if (auto format = from_arv(static_cast<ArvPixelFormat>(formats[i]))) fresh.pixel_formats.push_back(*format);
    g_free(formats);
    double exposure_min = 0, exposure_max = 0;
    arv_camera_get_exposure_time_bounds(camera, &exposure_min, &exposure_max, error.out());
    if (error) fail("read ExposureTime bounds", error);
    fresh.exposure_min_us = exposure_min, fresh.exposure_max_us = exposure_max;
    info = std::move(fresh);
  }

  void release_device_locked() { unref_detached(detach_device_locked()); }

  // Stops the stream thread and hands back the Aravis objects for unref_detached()
  // (which may block for seconds on a dead link, so callers drop the lock first).
  std::pair<ArvCamera*, ArvStream*> detach_device_locked() {
    stop_stream_thread_locked();
    std::pair<ArvCamera*, ArvStream*> detached{camera, stream};
    if (camera != nullptr && control_lost_handler != 0)
      g_signal_handler_disconnect(arv_camera_get_device(camera), control_lost_handler);
    control_lost_handler = 0;
    camera = nullptr;
    stream = nullptr;
    return detached;
  }
  static void unref_detached(std::pair<ArvCamera*, ArvStream*> detached) {
    if (detached.second != nullptr) g_object_unref(detached.second);
    if (detached.first != nullptr) g_object_unref(detached.first);
  }

  static void on_control_lost(ArvDevice*, gpointer self_pointer) {
    auto* self = static_cast<Impl*>(self_pointer);
    self->link_lost = true;
    self->link_cv.notify_all();
  }

  void apply_settings_locked(const CameraSettings& s) {
    GErrorSlot error;
    const auto& format = pixel_format_info(s.pixel_format);
    if (std::find(info.pixel_formats.begin(), info.pixel_formats.end(), s.pixel_format) == info.pixel_formats.end())
      throw DeviceError(DeviceError::Kind::kInvalidRequest, device_name,
                        "set PixelFormat=" + std::string(format.name), "the device does not offer this format");
    const int width = s.roi.width > 0 ? s.roi.width : info.sensor_width - s.roi.x;
    const int height = s.roi.height > 0 ? s.roi.height : info.sensor_height - s.roi.y;
    if (s.roi.x < 0 || s.roi.y < 0 || width <= 0 || height <= 0 || s.roi.x + width > info.sensor_width ||
        s.roi.y + height > info.sensor_height)
      throw DeviceError(DeviceError::Kind::kInvalidRequest, device_name,
                        "set ROI " + std::to_string(s.roi.x) + "," + std::to_string(s.roi.y) + " " +
                            std::to_string(width) + "x" + std::to_string(height),
                        "outside the " + std::to_string(info.sensor_width) + "x" +
                            std::to_string(info.sensor_height) + " sensor");
    if (!(s.exposure_us > 0) || !std::isfinite(s.gain_db))
      throw DeviceError(DeviceError::Kind::kInvalidRequest, device_name, "set ExposureTime/Gain",
                        "exposure_us must be > 0 and gain_db finite");
    if (options.packet_size_bytes > 0) {
      arv_camera_gv_set_packet_size(camera, options.packet_size_bytes, error.out());
      if (error) fail("set GevSCPSPacketSize=" + std::to_string(options.packet_size_bytes), error);
    }
    arv_camera_set_pixel_format(camera, static_cast<ArvPixelFormat>(format.pfnc_code), error.out());
    if (error) fail("set PixelFormat=" + std::string(format.name), error);
    arv_camera_set_region(camera, s.roi.x, s.roi.y, width, height, error.out());
    if (error) fail("set OffsetX/OffsetY/Width/Height", error);
    arv_camera_set_exposure_time(camera, s.exposure_us, error.out());
    if (error) fail("set ExposureTime=" + std::to_string(s.exposure_us) + " us", error);
    if (arv_camera_is_gain_available(camera, nullptr)) {
      arv_camera_set_gain(camera, s.gain_db, error.out());
      if (error) fail("set Gain=" + std::to_string(s.gain_db) + " dB", error);
    } else if (s.gain_db != 0) {
      throw DeviceError(DeviceError::Kind::kInvalidRequest, device_name, "set Gain", "the device has no gain");
    }
    arv_camera_set_acquisition_mode(camera, ARV_ACQUISITION_MODE_CONTINUOUS, error.out());
    if (error) fail("set AcquisitionMode=Continuous", error);
    switch (s.trigger_mode) {
      case TriggerMode::kFreeRun:
        arv_camera_clear_triggers(camera, error.out());
        if (error) fail("set TriggerMode=Off", error);
        arv_camera_set_frame_rate(camera, s.frame_rate_hz, error.out());
        if (error) fail("set AcquisitionFrameRate=" + std::to_string(s.frame_rate_hz), error);
        break;
      case TriggerMode::kSoftware:
        arv_camera_set_trigger(camera, "Software", error.out());
        if (error) fail("set TriggerSource=Software", error);
        break;
      case TriggerMode::kHardware: {
        const std::string line = hardware_line_locked();
        arv_camera_set_trigger(camera, line.c_str(), error.out());
        if (error) fail("set TriggerSource=" + line, error);
        break;
      }
    }
    configure_trigger_count_chunk_locked(s.trigger_mode != TriggerMode::kFreeRun);
    CameraSettings read_back = s;
    read_back.exposure_us = arv_camera_get_exposure_time(camera, error.out());
    if (error) fail("read ExposureTime", error);
    if (arv_camera_is_gain_available(camera, nullptr)) read_back.gain_db = arv_camera_get_gain(camera, error.out());
    read_back.roi = Roi{s.roi.x, s.roi.y, width, height};
    applied = read_back;
  }

  // Chunk data with the trigger count while triggered, when the device has it;
  // chunks off otherwise. Before the stream's buffers are sized (PayloadSize grows).
  void configure_trigger_count_chunk_locked(bool triggered) {
    trigger_count_chunk = false;
    if (options.trigger_count_chunk.empty() || !arv_camera_are_chunks_available(camera, nullptr)) return;
    GErrorSlot error;
    guint n = 0;
    const char** entries = arv_camera_dup_available_enumerations_as_strings(camera, "ChunkSelector", &n, error.out());
    if (error) fail("read ChunkSelector entries", error);
    bool listed = false;
    for (guint i = 0; i < n; ++i) listed = listed || options.trigger_count_chunk == entries[i];
    g_free(entries);
    if (!listed || !triggered) {
      arv_camera_set_chunk_mode(camera, FALSE, error.out());
      if (error) fail("set ChunkModeActive=false", error);
      return;
    }
    arv_camera_set_chunks(camera, options.trigger_count_chunk.c_str(), error.out());
    if (error) fail("enable chunk " + options.trigger_count_chunk, error);
    if (chunk_parser == nullptr) chunk_parser = arv_camera_create_chunk_parser(camera);
    trigger_count_chunk = chunk_parser != nullptr;
  }

  // The trigger count a complete buffer carries, if any.
  std::optional<std::uint64_t> trigger_count_of(ArvBuffer* buffer) {
    if (!trigger_count_chunk || !arv_buffer_has_chunks(buffer)) return std::nullopt;
    GError* error = nullptr;
    const std::string feature = "Chunk" + options.trigger_count_chunk;
    const gint64 value = arv_chunk_parser_get_integer_value(chunk_parser, buffer, feature.c_str(), &error);
    if (error != nullptr) {
      g_error_free(error);
      return std::nullopt;
    }
    return static_cast<std::uint64_t>(value);
  }

  std::string hardware_line_locked() {
    if (!options.hardware_trigger_line.empty()) return options.hardware_trigger_line;
    guint n = 0;
    GErrorSlot error;
    const char** sources = arv_camera_dup_available_trigger_sources(camera, &n, error.out());
    std::string line;
    for (guint i = 0; i < n && line.empty(); ++i)
      if (std::strncmp(sources[i], "Line", 4) == 0) line = sources[i];
    g_free(sources);
    if (line.empty())
      throw DeviceError(DeviceError::Kind::kInvalidRequest, device_name, "find a TriggerSource Line*",
                        "the device lists no trigger input line");
    return line;
  }

  std::size_t payload_locked() {
    GErrorSlot error;
    const guint payload = arv_camera_get_payload(camera, error.out());
    if (error) fail("read PayloadSize", error);
    return payload;
  }

  // The socket buffer this stream gets, with the warning NOTES.md asks for.
  std::size_t socket_buffer_locked(bool warn_if_low) {
    const std::size_t rmem_max = read_rmem_max();
    std::size_t size = options.socket_buffer_bytes;
    if (rmem_max > 0) size = std::min(size, rmem_max);
    if (warn_if_low && settings) {
      const std::size_t payload = payload_locked();
      double frames_in_flight = 4;
      if (settings->trigger_mode == TriggerMode::kFreeRun)
        frames_in_flight = std::max(frames_in_flight, std::ceil(settings->frame_rate_hz * 0.1));
      const auto needed = static_cast<std::size_t>(frames_in_flight * static_cast<double>(payload));
      if (size < needed)
        warn("socket buffer " + std::to_string(size) + " bytes (net.core.rmem_max " + std::to_string(rmem_max) +
             ") is below the " + std::to_string(needed) +
             " bytes this stream needs; frames may be lost (raise it: sysctl -w net.core.rmem_max=67108864)");
    }
    return size;
  }

  void create_stream_locked() {
    arv_camera_gv_set_stream_options(camera, ARV_GV_STREAM_OPTION_PACKET_SOCKET_DISABLED);
    GErrorSlot error;
    ArvStream* created = arv_camera_create_stream(camera, nullptr, nullptr, error.out());
    if (created == nullptr) fail("create stream", error);
    stream = created;
    g_object_set(stream, "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_FIXED, "socket-buffer-size",
                 static_cast<gint>(std::min<std::size_t>(socket_buffer_locked(false), G_MAXINT)), "frame-retention",
                 static_cast<guint>(options.frame_retention_ms * 1000), "packet-resend",
                 ARV_GV_STREAM_PACKET_RESEND_ALWAYS, nullptr);
    // Aravis applies that size only once the first frame arrives; the first
    // frame would meet the kernel's default buffer (stream_socket_buffer.hpp).
    detail::size_udp_receive_buffer(arv_gv_stream_get_port(ARV_GV_STREAM(stream)), socket_buffer_locked(false));
    const std::size_t payload = payload_locked();
    for (int i = 0; i < options.buffer_count; ++i) arv_stream_push_buffer(stream, arv_buffer_new(payload, nullptr));
  }

  void destroy_stream_locked() {
    stop_stream_thread_locked();
    if (stream != nullptr) {
      g_object_unref(stream);
      stream = nullptr;
    }
  }

  void start_acquisition_locked() {
    create_stream_locked();
    GErrorSlot error;
    arv_camera_start_acquisition(camera, error.out());
    if (error) {
      destroy_stream_locked();
      fail("AcquisitionStart", error);
    }
    stream_thread_stop = false;
    stream_thread = std::thread([this, s = stream] { stream_loop(s); });
  }

  void stop_stream_thread_locked() {
    if (!stream_thread.joinable()) return;
    stream_thread_stop = true;
    stream_thread.join();
  }

  // --- stream thread ---

  void stream_loop(ArvStream* s) {
    for (;;) {
      const bool draining = stream_thread_stop.load();
      // While draining, wait long enough for Aravis to close frames in flight.
      const guint64 timeout_us = draining ? (options.frame_retention_ms + 100) * 1000ull : 100000ull;
      ArvBuffer* buffer = arv_stream_timeout_pop_buffer(s, timeout_us);
      if (buffer == nullptr) {
        if (draining) break;
        continue;
      }
      deliver(s, buffer);
      arv_stream_push_buffer(s, buffer);
    }
    update_transfer_counters(s, true);
  }

  void update_transfer_counters(ArvStream* s, bool stream_ending) {
    guint64 resent = 0, missing = 0;
    arv_gv_stream_get_statistics(ARV_GV_STREAM(s), &resent, &missing);
    const guint64 requests = arv_stream_get_info_uint64_by_name(s, "n_resend_requests");
    std::lock_guard lock(stats_mutex);
    stats.resent_packets = resent_base + resent;
    stats.missing_packets = missing_base + missing;
    stats.resend_requests = requests_base + requests;
    if (stream_ending) {
      resent_base += resent;
      missing_base += missing;
      requests_base += requests;
    }
  }

  void deliver(ArvStream* s, ArvBuffer* buffer) {
    Frame frame;
    frame.sequence = next_sequence++;
    frame.status = to_frame_status(arv_buffer_get_status(buffer));
    const std::uint64_t camera_id = arv_buffer_get_frame_id(buffer);
    const bool id_trusted = frame.status == FrameStatus::kComplete || !lost_frames.is_stale(camera_id);
    const std::int64_t newly_lost =
        id_trusted ? lost_frames.on_frame(camera_id) : lost_frames.on_frame_without_id();
    const guint64 host_ns = id_trusted ? arv_buffer_get_system_timestamp(buffer) : 0;
    frame.camera_frame_id = id_trusted ? camera_id : 0;
    frame.camera_timestamp_ns = id_trusted ? arv_buffer_get_timestamp(buffer) : 0;
    frame.host_timestamp =
        host_ns != 0 ? std::chrono::system_clock::time_point(
                           std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::nanoseconds(host_ns)))
                     : std::chrono::system_clock::now();
    if (frame.status == FrameStatus::kComplete) {
      const auto format = from_arv(arv_buffer_get_image_pixel_format(buffer));
      std::size_t size = 0;
      const auto* data = static_cast<const std::uint8_t*>(arv_buffer_get_data(buffer, &size));
      if (!format || data == nullptr) {
        frame.status = FrameStatus::kError;
      } else {
        frame.pixel_format = *format;
        frame.width = arv_buffer_get_image_width(buffer);
        frame.height = arv_buffer_get_image_height(buffer);
        // The image only: chunk data (if any) follows it in the buffer.
        const std::size_t image_bytes = pixel_format_info(*format).frame_bytes(frame.width, frame.height);
        if (size < image_bytes) {
          frame.status = FrameStatus::kError;
        } else {
          frame.data.assign(data, data + image_bytes);
          frame.trigger_count = trigger_count_of(buffer);
        }
      }
    }
    {
      std::lock_guard lock(stats_mutex);
      stats.lost_before_driver += newly_lost;
      if (frame.status == FrameStatus::kComplete) ++stats.completed;
      else ++stats.failed;
    }
    update_transfer_counters(s, false);
    try {
      on_frame(std::move(frame));
    } catch (const std::exception& e) {
      warn(std::string("FrameCallback threw (it must not): ") + e.what());
    }
  }

  // --- link thread ---

  void link_loop() {
    for (;;) {
      {
        std::unique_lock lock(link_mutex);
        link_cv.wait_for(lock, std::chrono::milliseconds(options.watchdog_period_ms),
                         [this] { return shutting_down || link_lost.load(); });
        if (shutting_down) return;
      }
      if (!link_lost && !register_answers()) link_lost = true;
      if (link_lost) reconnect();
    }
  }

  bool register_answers() {
    std::lock_guard lock(control_mutex);
    if (camera == nullptr) return false;
    guint32 value = 0;
    GErrorSlot error;
    return arv_device_read_register(arv_camera_get_device(camera), kControlChannelPrivilegeRegister, &value,
                                    error.out()) != FALSE;
  }

  void reconnect() {
    link_is_up = false;
    warn("control channel lost; reconnecting");
    std::pair<ArvCamera*, ArvStream*> dead;
    {
      std::lock_guard lock(control_mutex);
      dead = detach_device_locked();
      lost_frames.reset();  // a restarted camera counts its frame ids afresh
    }
    unref_detached(dead);
    for (;;) {
      try {
        std::string address;
        ArvCamera* opened = connect(&address);
        std::lock_guard lock(control_mutex);
        try {
          install_camera_locked(opened, address);
          if (settings) apply_settings_locked(*settings);
          if (streaming) start_acquisition_locked();
        } catch (const DeviceError&) {
          release_device_locked();
          throw;
        }
        link_lost = false;
        link_is_up = true;
        std::lock_guard stats_lock(stats_mutex);
        ++stats.reconnects;
        return;
      } catch (const DeviceError&) {
      }
      std::unique_lock lock(link_mutex);
      if (link_cv.wait_for(lock, std::chrono::milliseconds(options.reconnect_retry_ms),
                           [this] { return shutting_down; }))
        return;
    }
  }

  // Fails fast (no lock) while a reconnect is under way, and again under the lock.
  void require_link(const std::string& request) const {
    if (!link_is_up)
      throw DeviceError(DeviceError::Kind::kDisconnected, device_name, request,
                        "control channel lost; reconnect in progress");
  }
  void require_link_locked(const std::string& request) const {
    if (!link_is_up || camera == nullptr)
      throw DeviceError(DeviceError::Kind::kDisconnected, device_name, request,
                        "control channel lost; reconnect in progress");
  }
};

AravisCamera::AravisCamera(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

std::unique_ptr<AravisCamera> AravisCamera::open(const AravisCameraOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("AravisCameraOptions: " + error);
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->device_name = "camera " + options.serial;
  {
    std::string address;
    ArvCamera* opened = impl->connect(&address);
    std::lock_guard lock(impl->control_mutex);
    try {
      impl->install_camera_locked(opened, address);
    } catch (...) {
      impl->release_device_locked();
      throw;
    }
  }
  Impl* raw = impl.get();
  raw->link_thread = std::thread([raw] { raw->link_loop(); });
  return std::unique_ptr<AravisCamera>(new AravisCamera(std::move(impl)));
}

AravisCamera::~AravisCamera() {
  {
    std::lock_guard lock(impl_->link_mutex);
    impl_->shutting_down = true;
  }
  impl_->link_cv.notify_all();
  if (impl_->link_thread.joinable()) impl_->link_thread.join();
  std::lock_guard lock(impl_->control_mutex);
  if (impl_->streaming && impl_->camera != nullptr && impl_->link_is_up) {
    GErrorSlot error;
    arv_camera_stop_acquisition(impl_->camera, error.out());
  }
  impl_->release_device_locked();
  if (impl_->chunk_parser != nullptr) g_object_unref(impl_->chunk_parser);
}

CameraInfo AravisCamera::info() const {
  std::lock_guard lock(impl_->control_mutex);
  return impl_->info;
}

void AravisCamera::configure(const CameraSettings& settings) {
  impl_->require_link("configure");
  std::lock_guard lock(impl_->control_mutex);
  if (impl_->streaming)
    throw DeviceError(DeviceError::Kind::kInvalidRequest, impl_->device_name, "configure",
                      "the stream is running: stop_stream() first");
  impl_->require_link_locked("configure");
  const auto previous = impl_->settings;
  try {
    impl_->apply_settings_locked(settings);
  } catch (const DeviceError& e) {
    // Bad input changes nothing: put the previous settings back when a device write failed midway.
    if (previous && e.kind() != DeviceError::Kind::kTimeout) {
      try {
        impl_->apply_settings_locked(*previous);
      } catch (const DeviceError&) {
      }
    }
    throw;
  }
  impl_->settings = settings;
  impl_->socket_buffer_locked(true);
}

void AravisCamera::start_stream(FrameCallback on_frame) {
  impl_->require_link("start_stream");
  std::lock_guard lock(impl_->control_mutex);
  impl_->require_link_locked("start_stream");
  if (impl_->streaming)
    throw DeviceError(DeviceError::Kind::kInvalidRequest, impl_->device_name, "start_stream", "already streaming");
  if (!impl_->settings)
    throw DeviceError(DeviceError::Kind::kInvalidRequest, impl_->device_name, "start_stream", "configure() first");
  if (!on_frame) throw std::invalid_argument("start_stream: empty FrameCallback");
  impl_->on_frame = std::move(on_frame);
  impl_->next_sequence = 0;
  impl_->lost_frames.reset();
  impl_->start_acquisition_locked();
  impl_->streaming = true;
}

void AravisCamera::stop_stream() {
  std::lock_guard lock(impl_->control_mutex);
  if (!impl_->streaming) return;
  impl_->streaming = false;
  if (impl_->camera != nullptr && impl_->link_is_up) {
    GErrorSlot error;
    arv_camera_stop_acquisition(impl_->camera, error.out());
  }
  impl_->destroy_stream_locked();
}

void AravisCamera::software_trigger() {
  impl_->require_link("TriggerSoftware");
  std::lock_guard lock(impl_->control_mutex);
  impl_->require_link_locked("TriggerSoftware");
  if (!impl_->settings || impl_->settings->trigger_mode != TriggerMode::kSoftware)
    throw DeviceError(DeviceError::Kind::kInvalidRequest, impl_->device_name, "TriggerSoftware",
                      "the camera is not configured for TriggerMode::kSoftware");
  if (!impl_->streaming)
    throw DeviceError(DeviceError::Kind::kInvalidRequest, impl_->device_name, "TriggerSoftware",
                      "no stream is running");
  GErrorSlot error;
  arv_camera_software_trigger(impl_->camera, error.out());
  if (error) impl_->fail("TriggerSoftware", error);
}

StreamStatistics AravisCamera::statistics() const {
  std::lock_guard lock(impl_->stats_mutex);
  return impl_->stats;
}

bool AravisCamera::link_up() const { return impl_->link_is_up; }

CameraSettings AravisCamera::applied_settings() const {
  std::lock_guard lock(impl_->control_mutex);
  return impl_->applied;
}

}  // namespace chromo::drivers
