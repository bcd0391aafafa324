#pragma once
// DaemonConfig: chromod's one configuration file (JSON), documented in
// docs/config.md. Every field has a default; with no file at all the daemon
// listens on its default Unix socket and starts the built-in virtual lab.
//
// parse_config() is the one check of a configuration, and chromod runs it
// before anything starts (no simulator, device, folder or socket): every key's
// JSON type and range, files that must be readable (read as what they are),
// folders that must be usable, addresses that must be valid. Keys are a table
// in config.cpp (config_keys()): an entry is built by a typed factory that
// demands the key's range or check, and a key not in the table is refused by
// name, so a key cannot be added without its check.

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/drivers/camera.hpp"
#include "chromo/drivers/led_controller.hpp"
#include "chromo/files/runtime_dir.hpp"
#include "chromo/session/plan_hazard.hpp"

namespace chromo::daemon {

enum class DeviceKind { kLedController, kCamera, kSpectrometer };
std::string device_kind_name(DeviceKind kind);

struct DeviceConfig {
  std::string name;     // unique, [A-Za-z0-9_+.-]{1,64}
  DeviceKind kind = DeviceKind::kLedController;
  std::string backend;  // "modbus-tcp", "modbus-rtu", "hid", "usb", "aravis" (docs/config.md)
  std::string address;  // host:port, device path, serial: meaning per backend (docs/config.md)
  nlohmann::json settings = nlohmann::json::object();  // backend-specific
};

// estimation.films_extinction_ratio's value for the virtual lab's own films.
inline constexpr const char* kVirtualLabFilms = "virtual_lab";

// The on-line estimator (docs/config.md "Estimation"; daemon/internal/capture/online_estimator.hpp).
struct EstimationConfig {
  bool enabled = true;
  std::string method = "fast";   // inverter: fast, exhaustive, 2d
  std::string model = "auto";    // auto (χ² test per pixel), 2d, 4d
  // The skin model's shortfall on real skin added to the noise (docs/estimation.md
  // "Real skin"): "learned" (from the NIST forearm spectra) or "none".
  std::string discrepancy = "learned";
  // The multi-pixel estimate before the spatial pass (docs/estimation.md
  // "Relighting past the model"): "on" or "off".
  std::string skin_denoise = "on";
  // A skin's systematic shortfall judged as a local bias before the
  // neighbourhood flags (estimation/local_bias.hpp; docs/estimation.md
  // "A subject's shortfall as a local bias"): "on" or "off".
  std::string local_bias = "off";
  // The relit layer "model + discrepancy" in the maps (maps/discrepancy_layer.hpp;
  // docs/estimation.md "Relighting past the model"): "on" or "off".
  std::string discrepancy_layer = "on";
  std::string led_library;       // LED library file; empty = newest measured one, else the nominal one
  std::string camera_sensitivity = "builtin:nikon_d5100";  // or a CSV wavelength_nm,R,G,B
  // Per camera (device name → builtin:NAME or a CSV), overriding camera_sensitivity for that camera's maps.
  std::map<std::string, std::string> camera_sensitivities;
  // Camera → the subject's width one frame row spans, mm, where the geometry
  // is known: configured (estimation.camera_field_width_mm, measured with a
  // ruler: docs/config.md), else the virtual lab fills it for its cameras when
  // it starts (open_devices); every session records it (provenance
  // camera_field_width_mm) for the maps' scale bar.
  std::map<std::string, double> camera_field_width_mm;
  double white_reflectance = 0.99;  // ρ of the white reference target
  // The polariser films (docs/polarisation.md "What the estimator knows of
  // the films"): "" = not given (surface maps and cross captures uncorrected),
  // a CSV wavelength_nm,extinction_ratio (the films' datasheet curve), or
  // "virtual_lab" (the virtual lab's own film model, which its devices describe:
  // DeviceSet::own_films).
  std::string films_extinction_ratio;
  std::string cache_dir;         // forward tables; empty = $CHROMO_CACHE_DIR or ~/.cache/chromosphere
  std::uint64_t cache_limit_bytes = 2ull << 30;  // table cache bound (least recently used evicted)
  int threads = 0;               // 0 = all cores
};

// How the standard plan captures (docs/config.md "Capture"; session_plan.hpp).
struct CaptureConfig {
  bool exposure_per_capture = true;  // meter each illumination's white (false: one exposure for all steps)
  double white_share = 0.8;          // the metered white's brightest channel, share of full scale, (0, 1]
  std::uint32_t frames_per_capture = 1;  // frames per subject step of the standard plan when a request leaves it 0
  std::uint32_t reference_frames = 4;   // frames per dark and white step (0: frames_per_capture)
  // Subject exposure metering (with exposure_per_capture): 0 off, else each
  // subject's subject_percentile in its brightest channel at this share of
  // full scale, at most max_subject_exposure_ratio times its white's exposure.
  double subject_fill = 0;
  double subject_percentile = 0.99;
  double max_subject_exposure_ratio = 8;
  double blue_ratio = 8;             // the standard plan's w57+blue:R (0: the plain "w57+blue")
  // The standard plan polarised (docs/polarisation.md): "auto" when the LED
  // controller reports polariser banks on every LED type, "on", "off".
  std::string polarised_plan = "auto";
};

// A virtual lab camera's pose (docs/config.md "The built-in virtual lab"):
// it looks at the patch centre from there.
struct VirtualCameraPose {
  double distance_mm = 300;      // eye to the patch centre
  double azimuth_deg = 0;        // swung towards +X (right), |.| < 90
  double elevation_deg = 0;      // swung towards −Y (up), |.| < 90
  double roll_deg = 0;           // about the optical axis
  double focal_length_mm = 8;
  double pixel_size_um = 3.45;
};

// One camera of virtual_lab.cameras, as plain options: the virtual lab's
// backend (daemon/src/devices/virtual_lab_options.cpp) maps it to the
// simulator's camera.
struct VirtualCameraConfig {
  std::string name = "cam0";
  std::string serial;            // "" = the lab's default serial for this camera
  std::string address;           // "" = a free one in 127.77.0.0/16
  int sensor_width = 640;
  int sensor_height = 480;
  drivers::PixelFormat pixel_format = drivers::PixelFormat::kBayerRG12;
  std::optional<VirtualCameraPose> pose;  // none: the patch fills the sensor square-on
  std::string sensitivity;       // "" = the lab's; "builtin:NAME" or a CSV path
};

// The built-in virtual lab (docs/config.md "The built-in virtual lab"):
// used only when no devices are configured.
struct VirtualLabConfig {
  std::vector<VirtualCameraConfig> cameras = {VirtualCameraConfig{}};  // default: cam0, 640x480 BayerRG12
  double patch_width_mm = 80;  // the skin patch's width, for posed cameras
  bool polarisers = false;     // polariser banks on all six LED types, analysers on the cameras (docs/polarisation.md)
  // Subsurface spread in the skin's photographs (docs/config.md): each
  // wavelength blurred by σ from subsurface_blue_px (≤ 450 nm) to
  // subsurface_red_px (≥ 700 nm), scene pixels; off by default.
  bool subsurface = false;
  double subsurface_blue_px = 0.5, subsurface_red_px = 3.0;
};

struct DaemonConfig {
  // The daemon's own folder for its socket and the virtual lab's run files
  // (files/runtime_dir.hpp; never /tmp). Created 0700 at start.
  std::filesystem::path runtime_dir = files::default_runtime_dir();
  // Listening. unix_socket empty = no Unix socket; default <runtime_dir>/chromod.sock.
  std::string unix_socket = files::default_unix_socket().string();
  std::uint32_t unix_socket_mode = 0660;  // file permissions decide who may connect
  std::string tcp_address;                // e.g. "0.0.0.0:7443"; empty = no TCP
  std::string token;                      // required on TCP: "authorization: Bearer <token>"
  std::string tls_certificate_file;       // PEM; both set = TLS on TCP
  std::string tls_private_key_file;
  bool tcp_insecure = false;              // plaintext TCP, loopback peers only; needed when TCP has no TLS
  std::uint32_t max_streams = 64;         // concurrent streaming calls (Subscribe, WatchOperation); beyond: RESOURCE_EXHAUSTED
  // A TCP connection must finish its handshake (TLS, or the local
  // credentials' check) within this, else gRPC closes it (its own default:
  // 120 s, for any number of connections that send nothing).
  std::uint32_t tcp_handshake_timeout_ms = 10000;
  // A TCP connection with no call in flight for this long is closed (gRPC's
  // GOAWAY; clients reconnect on their next call): one that handshook and
  // then sent no call, or no valid token, is not kept as long as it likes.
  std::uint32_t tcp_idle_timeout_ms = 120000;
  // TCP connections held at once (chromod accepts them itself: tcp_gate.hpp);
  // more are closed as soon as they are accepted. Each needs three open
  // files, which must fit the process's limit beside 256 others.
  std::uint32_t max_tcp_connections = 128;
  std::filesystem::path maps_dir;         // the maps API's folder for work without a session; empty = none
  std::uint64_t max_read_maps_bytes = 1ull << 30;  // MapsService.ReadMaps: the most channel bytes one call sends
  std::uint32_t max_profile_exports = 1;  // concurrent ExportProfiles calls (each takes every core); beyond: RESOURCE_EXHAUSTED
  // The operator's web view (docs/web.md): host:port; empty = off. Needs the
  // token; a non-loopback address needs TLS (the same certificate and key).
  std::string web_address;
  std::filesystem::path web_dir;          // the built front end; empty = the one this chromod was built with
  // The web view's limits (docs/web.md "Limits"). A request body (Content-Length,
  // chunked or compressed: counted as decoded) longer than this: 413.
  std::uint64_t web_max_body_bytes = 1u << 20;
  // An event or preview stream writes a comment this often while it has
  // nothing to send, and ends (freeing its thread and its max_streams slot)
  // once the browser is gone.
  std::uint32_t web_stream_keepalive_ms = 15000;
  // Concurrent event and preview streams of the web view (below its 48 HTTP
  // threads, so that pages still load); beyond: 429.
  std::uint32_t web_max_streams = 24;
  // A request's head (request line and headers, and the TLS handshake of a
  // new connection) must arrive within this, else the connection is closed;
  // connections still waiting for theirs are the first shed when every
  // HTTP thread is busy (slowloris).
  std::uint32_t web_request_head_timeout_ms = 10000;
  // Host names (no port) the web view answers besides loopback names, the
  // web_address host and the address a request arrived on: a request whose
  // Host header names anything else is refused (DNS rebinding), 421.
  std::vector<std::string> web_host_names;

  std::filesystem::path sessions_dir = "chromod-sessions";
  std::uint64_t storage_limit_bytes = 0;  // 0 = the disk is the limit (see durable_file.hpp)
  std::size_t storage_queue_frames = 64;  // bounded queue between cameras and storage
  std::size_t estimator_queue_frames = 8;

  std::uint32_t frame_timeout_ms = 3000;  // after exposure, per frame
  std::uint32_t frame_attempts = 3;       // triggers per wanted frame before pausing

  std::filesystem::path led_library;      // LED library file until a calibration run measured one; empty = none
  // chromod's own log lines: "text" ("chromod: ...") or "json" (one object a line; log_line.hpp).
  std::string log_format = "text";

  std::vector<DeviceConfig> devices;      // empty = the built-in virtual lab
  // Mixes sessions may name, as drive levels, used while the daemon has no
  // LED library (the mix solver's weights from the library otherwise).
  std::map<std::string, drivers::DriveLevels> mixes;
  EstimationConfig estimation;
  CaptureConfig capture;
  session::BlueLightHazardOptions hazard;  // docs/config.md "Blue-light hazard"
  VirtualLabConfig virtual_lab;

  // The checks between keys (listening, token with TCP, TLS pair); the
  // per-key checks are in parse_config.
  bool IsValid(std::string* error) const;
};

// Every key's type and range read into a DaemonConfig (unknown keys refused,
// IsValid applied), without the checks that look at the file system or
// resolve addresses: parse_config runs those next. The configuration fuzz
// harness (tests/fuzz/fuzz_config.cpp) exercises this part, which touches
// nothing outside the process. Throws std::invalid_argument naming the key.
DaemonConfig read_config_values(const nlohmann::json& json, const std::string& origin = "config");

// Reads and checks everything: read_config_values, then each key's check on
// its final value (files read, a missing folder created and removed again to
// prove it can be made, addresses resolved); throws std::invalid_argument
// "<origin>: <key>: <what is wrong>". Changes nothing on disk.
DaemonConfig parse_config(const nlohmann::json& json, const std::string& origin = "config");
// The file's JSON object (std::invalid_argument when unreadable or not JSON),
// to be given to parse_config, after command-line overrides if any.
nlohmann::json read_config_json(const std::filesystem::path& path);
DaemonConfig read_config_file(const std::filesystem::path& path);

// True for "127.x.y.z:port", "localhost:port" and "[::1]:port": addresses
// only this machine reaches (the web view needs TLS anywhere else).
bool is_loopback_address(const std::string& host_port);

// A host name or numeric address as a Host header names it, without the port:
// letters, digits, '-' and '.' (at most 253), or an IPv6 address in [].
bool is_valid_host_name(const std::string& name);

// web_max_streams' upper bound: the web view serves with 48 HTTP threads and
// keeps 8 of them for pages and calls.
inline constexpr std::uint32_t kMaxWebStreams = 40;

// The names of every key the table knows ("unix_socket", "estimation.method", ...).
std::vector<std::string> config_key_names();

// Drive levels for the virtual lab's mixes before any calibration (d65, w57, w57+blue).
std::map<std::string, drivers::DriveLevels> default_virtual_lab_mixes();

}  // namespace chromo::daemon
