#include "chromo/maps/camera_results.hpp"

#include "cameras_progress.hpp"
#include "delta_e_json.hpp"
#include "report_extras.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <thread>

#include "chromo/estimation/pixel_flags.hpp"
#include "chromo/files/binary_cache.hpp"

namespace chromo::maps {

namespace fs = std::filesystem;

namespace {

// One camera's estimation into `dir` (its name added to summary.json).
MethodEstimationResult estimate_camera(const SessionCamerasInput& input, const std::string& camera,
                                       const MethodEstimationOptions& options, const fs::path& dir,
                                       const FileCommit& commit, const files::Progress& progress) {
  const session::SessionCaptureBuilder& builder = *input.builder;
  if (!builder.complete(camera)) throw std::invalid_argument("frames missing: " + builder.missing(camera));
  nlohmann::ordered_json extra = report_extras(input.extra, "extra");
  extra["camera"] = camera;
  extra["camera_sensitivity"] = builder.sensitivity_source(camera);
  const PreparedTables* prepared = nullptr;
  if (input.prepared)
    if (auto found = input.prepared->find(camera); found != input.prepared->end()) prepared = &found->second;
  MethodEstimationOptions own = options;
  if (const auto known = input.field_width_mm.find(camera); known != input.field_width_mm.end()) own.field_width_mm = known->second;
  return estimate_captures(builder.captures(camera), own, dir, commit, progress, extra, prepared);
}

}  // namespace

bool usable_camera_folder_name(const std::string& camera) {
  if (camera.empty() || camera.size() > 64 || camera == "." || camera == "..") return false;
  for (unsigned char c : camera)
    if (!(std::isalnum(c) || c == '_' || c == '.' || c == '+' || c == '-')) return false;
  return true;
}

fs::path camera_results_dir(const fs::path& results_dir, const std::string& camera, std::size_t camera_count) {
  return camera_count <= 1 ? results_dir : results_dir / camera;
}

void mark_shared_tables(std::vector<CameraEstimate>& cameras) {
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    if (!cameras[k].ok) continue;
    for (std::size_t j = 0; j < k; ++j)
      if (cameras[j].ok && cameras[j].result->table_key == cameras[k].result->table_key) {
        cameras[k].shared_with = cameras[j].camera;
        break;
      }
  }
}

namespace {

// One camera of several into results_dir/<camera>: failed with its reason
// where its captures cannot be estimated.
CameraEstimate estimate_listed_camera(const SessionCamerasInput& input, const std::string& camera, std::size_t cameras,
                                      const MethodEstimationOptions& options, const fs::path& results_dir,
                                      const FileCommit& commit, const files::Progress& progress) {
  CameraEstimate e;
  e.camera = camera;
  e.camera_sensitivity = input.builder->sensitivity_source(camera);
  e.folder = camera;
  try {
    if (const auto refused = input.unusable.find(camera); refused != input.unusable.end())
      throw std::invalid_argument(refused->second);
    if (!usable_camera_folder_name(camera))
      throw std::invalid_argument("camera name \"" + camera +
                                  "\" cannot name its results folder (1-64 of A-Z a-z 0-9 _ . + -)");
    e.result = estimate_camera(input, camera, options, camera_results_dir(results_dir, camera, cameras), commit, progress);
    e.ok = true;
  } catch (const std::invalid_argument& error) {
    e.reason = error.what();
  } catch (const session::RegistrationError& error) {
    e.reason = error.what();
  }
  return e;
}

// Every camera of `names`, options.cameras_at_once at a time (0: all), each
// on a thread of its own; the first other error is rethrown once all ended.
std::vector<CameraEstimate> estimate_cameras_at_once(const SessionCamerasInput& input, const std::vector<std::string>& names,
                                                     const MethodEstimationOptions& options, const fs::path& results_dir,
                                                     const FileCommit& commit, const files::Progress& progress) {
  std::vector<CameraEstimate> out(names.size());
  std::vector<std::exception_ptr> errors(names.size());
  detail::CamerasProgress shared(progress, names);
  const std::size_t at_once = options.cameras_at_once > 0 ? static_cast<std::size_t>(options.cameras_at_once) : names.size();
  for (std::size_t first = 0; first < names.size(); first += at_once) {
    std::vector<std::thread> running;
    for (std::size_t k = first; k < std::min(first + at_once, names.size()); ++k)
      running.emplace_back([&, k] {
        try {
          out[k] = estimate_listed_camera(input, names[k], names.size(), options, results_dir, commit, shared.of_camera(k));
        } catch (...) {
          errors[k] = std::current_exception();
        }
      });
    for (auto& thread : running) thread.join();
  }
  for (const auto& error : errors)
    if (error) std::rethrow_exception(error);
  return out;
}

}  // namespace

std::vector<CameraEstimate> estimate_session_cameras(const SessionCamerasInput& input,
                                                     const MethodEstimationOptions& options, const fs::path& results_dir,
                                                     const FileCommit& commit, const files::Progress& progress) {
  if (!input.builder) throw std::invalid_argument("estimate_session_cameras: no capture builder");
  std::vector<std::string> names = input.builder->cameras();
  for (const auto& [camera, reason] : input.unusable)
    if (std::find(names.begin(), names.end(), camera) == names.end()) names.push_back(camera);
  if (names.empty()) throw std::invalid_argument("no camera delivered a frame");
  if (names.size() == 1) {  // the one-camera layout; errors go to the caller
    const std::string& camera = names.front();
    if (const auto refused = input.unusable.find(camera); refused != input.unusable.end())
      throw std::invalid_argument(refused->second);
    CameraEstimate e;
    e.camera = camera;
    e.camera_sensitivity = input.builder->sensitivity_source(camera);
    e.result = estimate_camera(input, camera, options, results_dir, commit, progress);
    e.result->maps.reset();  // no common view of one camera
    e.ok = true;
    return {std::move(e)};
  }
  std::vector<CameraEstimate> out = estimate_cameras_at_once(input, names, options, results_dir, commit, progress);
  mark_shared_tables(out);
  add_common_views(out, results_dir, commit);
  for (auto& camera : out)
    if (camera.result) camera.result->maps.reset();  // the maps' memory back before the next session
  const std::string index = camera_results_index_json(out, input.extra);
  commit(results_dir / "summary.json", [&](const fs::path& temporary) {
    std::ofstream out(temporary);
    out << index;
    if (!out.flush()) throw std::runtime_error("cannot write " + temporary.string());
  });
  return out;
}

nlohmann::ordered_json camera_entry(const CameraEstimate& camera, const std::string& path_prefix) {
  nlohmann::ordered_json entry{{"name", camera.camera}, {"state", camera.ok ? "ok" : "failed"}};
  if (!camera.ok) {
    entry["reason"] = camera.reason;
    return entry;
  }
  const std::string folder = path_prefix + (camera.folder.empty() ? "" : camera.folder + "/");
  const auto& r = *camera.result;
  entry["folder"] = camera.folder;
  entry["maps_file"] = folder + "maps.exr";
  entry["report_file"] = folder + "summary.json";
  entry["camera_sensitivity"] = camera.camera_sensitivity;
  entry["table_key"] = files::cache_key_hex(r.table_key);
  entry["shared_with"] = camera.shared_with.empty() ? nlohmann::ordered_json() : nlohmann::ordered_json(camera.shared_with);
  entry["pixels"] = r.summary.pixels;
  entry["explained"] = r.summary.flag_counts[0];
  entry["estimate_seconds"] = r.summary.seconds;
  entry["pixels_per_second"] = r.pixels_per_second;
  nlohmann::ordered_json flags = nlohmann::ordered_json::object();
  for (int f = 0; f < estimation::kPixelFlagCount; ++f)
    flags[std::string(estimation::pixel_flag_name(static_cast<estimation::PixelFlag>(f)))] = r.summary.flag_counts[f];
  entry["flag_counts"] = flags;
  nlohmann::ordered_json relit = nlohmann::ordered_json::object();
  for (const auto& c : r.relit) relit[c.illuminant] = relit_comparison_json(c);
  entry["relit_delta_e94"] = relit;
  entry["highlights"] = {{"detection", r.highlight_detection}, {"pixels", r.highlight_pixels}};
  if (r.map_pixel_mm > 0) entry["map_pixel_mm"] = r.map_pixel_mm;
  if (camera.common_view) entry["common_view"] = common_view_entry(*camera.common_view, path_prefix);
  return entry;
}

std::string camera_results_index_json(const std::vector<CameraEstimate>& cameras, const nlohmann::ordered_json& extra) {
  nlohmann::ordered_json index = report_extras(extra, "extra");
  index["cameras"] = nlohmann::ordered_json::array();
  for (const auto& camera : cameras) index["cameras"].push_back(camera_entry(camera));
  return index.dump(2) + "\n";
}

}  // namespace chromo::maps
