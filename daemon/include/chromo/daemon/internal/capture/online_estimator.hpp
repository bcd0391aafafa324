#pragma once
// OnlineEstimator: chromod's on-line chromophore estimator, the pipeline's
// FrameConsumer (frame_pipeline.hpp).
//
// As a standard session's frames arrive (dark, the white reference and the
// subject under D65', W57, W57+blue) it counts them into its captures
// (session_captures.hpp), reading the samples from the sums the pipeline's
// storage thread makes of every stored frame (SessionStart::stored_sums: a
// frame is summed once; without them it sums the samples itself). Once the dark and the three white references are
// in — before the subject is captured — it knows the measurement set
// (illuminants from the LED library and the applied drive levels, noise from
// the references) and builds or loads the forward table and the fast
// inverter's inverse table (maps::prepare_tables: into the disk cache too),
// and keeps both in memory until the estimate, so the last frame is followed
// by the estimate itself, with no table reload.
// Every camera is estimated from its own frames (the capture builder keeps
// them apart; each camera's tables are prepared once its own references are
// in, on a thread of the camera's own so that this thread keeps taking the
// subject's frames (TablePreparations; shared in memory between cameras with
// the same sensitivity and illuminants). When
// every camera of the session (SessionStart::cameras) has all its frames,
// or at the end of the session when that list is empty, it estimates every
// camera tile by tile on options.estimation.estimator.threads threads (0 =
// all cores) with maps::estimate_session_cameras and writes
// <session>/results/ (one camera: maps.exr, previews, summary.json there;
// several: results/<camera>/… and the index results/summary.json,
// camera_results.hpp), every file crash-safe (durable_file.hpp, charged to
// the storage budget). A camera that cannot be estimated is listed with its
// reason; the others are published.
//
// Falling behind: the pipeline's estimator queue is bounded; a frame that
// does not fit is skipped by the pipeline (counted "queue_full", an event
// says the estimator is behind) and never delays storage. end_session() reads
// every skipped frame back from the session folder before finishing, so the
// maps always use every stored frame; summary.json and the results record
// say how many were read back.
//
// end_session() returns the journal's results record:
//   {"type": "results", "state": "available", "maps_file": "results/maps.exr",
//    "report_file": "results/summary.json", "method", "model", "pixels",
//    "pixels_per_second", "estimate_seconds", "frames_read_back",
//    "flag_counts": {...}, "relit_delta_e94": {"D65'": {"mean", "median", "p95"}, ...},
//    "camera": the camera of these headline numbers (the first estimated),
//    "cameras": [every camera's entry, maps::camera_entry with paths under results/]}
// (several cameras: maps_file is the first estimated camera's, report_file the index)
// or {"type": "results", "state": "unavailable", "reason": "..."} (not the
// method's plan, mono frames, unusable references, a write that failed).
// A session that did not succeed gets no record.
//
// The same computation runs offline on a stored session (`chromo estimate
// SESSION_DIR`): session::read_stored_session() + maps::estimate_session_cameras().
//
// Thread rules: begin_session/end_session on the session's thread, consume on
// the pipeline's estimator thread; the daemon runs one session at a time and
// the pipeline's drain() orders them. Options are fixed at construction.

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>

#include "chromo/daemon/config.hpp"
#include "chromo/files/durable_file.hpp"
#include "chromo/daemon/internal/capture/frame_pipeline.hpp"
#include "chromo/daemon/internal/capture/table_preparations.hpp"
#include "chromo/session/session_captures.hpp"
#include "chromo/session/surface_factors.hpp"
#include "chromo/maps/camera_results.hpp"
#include "chromo/maps/estimate_report.hpp"

namespace chromo::daemon {

struct OnlineEstimatorOptions {
  maps::MethodEstimationOptions estimation;  // method fast, model auto by default
  // The LED library and camera sensitivity, resolved at each session start
  // (a new calibration applies to the next session).
  std::function<session::CaptureSources()> sources;
  files::StorageBudget* budget = nullptr;
  bool IsValid(std::string* error) const;
};

class OnlineEstimator;
// chromod's estimator from its configuration (config.estimation); sources are
// resolved at each session start, so a bad led_library or camera file makes
// that session's results "unavailable" naming the file. daemon_led_library
// (optional): the daemon's own LED library file at that moment ("" when it
// has none), used unless config.led_library overrides it; likewise
// daemon_state_libraries (optional): its measured library per polarisation
// state (CaptureSources::led_library_of_state). devices_films: the films as
// the devices describe them (DeviceSet::own_films), which
// films_extinction_ratio "virtual_lab" names; without them such a session's
// results are "unavailable", saying so.
std::unique_ptr<OnlineEstimator> make_online_estimator(
    const EstimationConfig& config, files::StorageBudget* budget, std::function<std::string()> daemon_led_library = {},
    std::function<std::map<drivers::Polarisation, session::StateLedLibrary>()> daemon_state_libraries = {},
    std::optional<session::SurfaceFactors> devices_films = std::nullopt);

class OnlineEstimator final : public FrameConsumer {
 public:
  explicit OnlineEstimator(OnlineEstimatorOptions options);  // std::invalid_argument if !IsValid

  void begin_session(const SessionStart& start) override;
  void consume(const CapturedFrame& frame, const StoredFrame& stored) override;
  nlohmann::json end_session(const SessionEnd& end) override;

 private:
  // end_session's record (the builder still held).
  nlohmann::json results_record(const SessionEnd& end);
  void estimate_now();
  bool every_camera_complete() const;
  void prepare_tables_of(const std::string& camera);
  nlohmann::json unavailable(const std::string& reason) const;

  OnlineEstimatorOptions options_;
  SessionStart session_;
  std::optional<session::CaptureSources> sources_;
  std::unique_ptr<session::SessionCaptureBuilder> builder_;
  std::set<std::uint64_t> consumed_;      // storage indices already added
  std::string error_;                     // first reason this session cannot be estimated
  std::map<std::string, std::string> camera_errors_;  // a camera's unusable frame (several cameras)
  std::map<std::string, double> table_prepare_seconds_;  // per camera: its references → its tables (at the estimate)
  std::map<std::string, maps::PreparedTables> prepared_;  // per camera, from the preparations until the estimate's end
  TablePreparations preparations_;                       // each camera's, on its own thread, from its references on
  std::vector<maps::CameraEstimate> cameras_;
  bool estimated_ = false;
  std::size_t read_back_ = 0;
};

}  // namespace chromo::daemon
