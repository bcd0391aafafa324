#pragma once
// A session's estimation camera by camera (issue 21 part 4): what chromod's
// on-line estimator and `chromo estimate SESSION_DIR` both run, so their maps
// stay identical.
//
// Every camera that delivered frames is estimated from its own frames only
// (session::SessionCaptureBuilder keeps cameras apart: its own dark, white
// references, noise and exposures) with estimate_captures(), whatever the
// plan (its recipe rides on the captures).
//
// Layout of results/ (docs/maps.md "Several cameras"):
//  - one camera: the report's files directly in results/ (maps.exr,
//    summary.json, previews), exactly as before the lab had several cameras;
//  - several cameras: results/<camera>/ holds each camera's report and
//    results/summary.json is the index (camera_results_index_json()).
// A camera whose captures cannot be estimated (std::invalid_argument,
// session::RegistrationError) is listed "failed" with its reason and nothing
// of it is written; the others are still estimated and published. With one
// camera its error is thrown, as before.
//
// Tables: cameras whose measurement sets give the same forward-table key (the
// same sensitivity and illuminants) share one table (the disk cache's file,
// or the on-line estimator's table in memory); the index names the earlier
// camera as "shared_with".
//
// Thread rules: free functions on values; the estimation runs on its own threads.

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/maps/common_view.hpp"
#include "chromo/maps/estimate_report.hpp"
#include "chromo/session/session_captures.hpp"

namespace chromo::maps {

// Whether a camera name can be its results folder: 1-64 of [A-Za-z0-9_.+-],
// not "." or "..". A camera named otherwise fails with that reason.
bool usable_camera_folder_name(const std::string& camera);

// Where a camera's report goes: results_dir itself when the session has one
// camera, results_dir/<camera> otherwise.
std::filesystem::path camera_results_dir(const std::filesystem::path& results_dir, const std::string& camera,
                                         std::size_t camera_count);

// A camera's maps in the common view (common_view.hpp): the reference
// camera (the first with maps) keeps its own maps.exr; every other camera's
// are resampled into common_view.exr beside its maps.exr.
struct CameraCommonView {
  std::string reference;   // the reference camera's name
  std::string file;        // relative to results/ ("" when reason is set)
  std::string reason;      // why this camera has no common view (its target outline not found)
  CommonViewMapping mapping;
};

// One camera's outcome.
struct CameraEstimate {
  std::string camera;
  bool ok = false;
  std::string reason;                 // why it failed (ok false)
  std::string folder;                 // relative to results/: "" (one camera) or the camera's name
  std::string camera_sensitivity;     // where its spectral sensitivity came from
  std::string shared_with;            // an earlier camera whose forward table this one used ("" none)
  std::optional<MethodEstimationResult> result;  // ok only
  std::optional<CameraCommonView> common_view;   // several cameras with maps only
};

// The per-camera options: the tables prepared during capture (the on-line
// estimator; by camera name) and members added to every report's summary.json.
struct SessionCamerasInput {
  const session::SessionCaptureBuilder* builder = nullptr;  // every camera complete
  std::map<std::string, PreparedTables> const* prepared = nullptr;
  nlohmann::ordered_json extra;  // members added to each camera's summary.json and to the index (null: none)
  // Cameras whose frames the builder refused (camera → the first reason):
  // listed failed with it, in or beside the builder's cameras.
  std::map<std::string, std::string> unusable;
  // Camera → the subject's width one frame row spans, mm, where known
  // (SessionProvenance::camera_field_width_mm): its maps' scale.
  std::map<std::string, double> field_width_mm;
};

// Estimates every camera of input.builder (in cameras() order) into
// results_dir as above; with several cameras also writes the index. Throws
// as estimate_captures() when the session has one camera, or when no
// camera has frames (std::invalid_argument).
std::vector<CameraEstimate> estimate_session_cameras(const SessionCamerasInput& input,
                                                     const MethodEstimationOptions& options,
                                                     const std::filesystem::path& results_dir, const FileCommit& commit,
                                                     const files::Progress& progress = {});

// Adds every ok camera's common view (several cameras with maps): reads
// each camera's maps.exr under results_dir (from the estimate's copy in
// memory, MethodEstimationResult::maps, where the file is in place), finds the white target's outline,
// maps it onto the reference camera's and writes common_view.exr through
// `commit`. A camera whose outline cannot be found gets its reason (and the
// reference's own failure gives every camera that reason); nothing throws
// for it.
void add_common_views(std::vector<CameraEstimate>& cameras, const std::filesystem::path& results_dir,
                      const FileCommit& commit);

// A camera entry's "common_view" object (below), file prefixed by path_prefix.
nlohmann::ordered_json common_view_entry(const CameraCommonView& view, const std::string& path_prefix = "");

// results/summary.json of a session with several cameras:
//   {...extra, "cameras": [{"name", "state": "ok"|"failed", "reason" (failed),
//    "folder", "maps_file", "report_file" (relative to results/),
//    "camera_sensitivity", "table_key", "shared_with" (null: none), "pixels",
//    "explained", "estimate_seconds", "flag_counts", "relit_delta_e94",
//    "common_view": {"reference", "file", "homography" (9, row-major, camera
//    cell → reference cell), "residual_px", "max_residual_px",
//    "outline_cells"} or {"reference", "reason"}}]}
std::string camera_results_index_json(const std::vector<CameraEstimate>& cameras,
                                      const nlohmann::ordered_json& extra = {});

// One camera's key figures as the index's entry (a JSON value for the file
// edge: the index, and chromod's journal results record, which carries the
// same array with paths prefixed by path_prefix).
nlohmann::ordered_json camera_entry(const CameraEstimate& camera, const std::string& path_prefix = "");

// The forward-table key each camera shares: camera name of the first camera
// with the same key, for every later camera with it.
void mark_shared_tables(std::vector<CameraEstimate>& cameras);

}  // namespace chromo::maps
