// The common view of a session's cameras (camera_results.hpp, add_common_views).
#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>

#include "chromo/maps/camera_results.hpp"

namespace chromo::maps {

namespace fs = std::filesystem;

namespace {

// A camera's maps as files::read_exr gives its maps.exr: from the estimate's
// copy in memory where the file is in place (the same floats, channels in
// the file's order, by name), else decoded from the file.
files::FloatImage camera_maps(const CameraEstimate& camera, const fs::path& results_dir) {
  const fs::path file = results_dir / camera.folder / "maps.exr";
  const auto& written = camera.result ? camera.result->maps : nullptr;
  if (!written || !fs::exists(file)) return files::read_exr(file);
  std::vector<std::size_t> order(written->channel_names.size());
  for (std::size_t c = 0; c < order.size(); ++c) order[c] = c;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return written->channel_names[a] < written->channel_names[b]; });
  files::FloatImage maps;
  maps.width = written->width, maps.height = written->height;
  for (std::size_t c : order) {
    maps.channel_names.push_back(written->channel_names[c]);
    maps.channels.push_back(written->channels[c]);
  }
  return maps;
}

}  // namespace

void add_common_views(std::vector<CameraEstimate>& cameras, const fs::path& results_dir, const FileCommit& commit) {
  std::vector<CameraEstimate*> with_maps;
  for (auto& camera : cameras)
    if (camera.ok) with_maps.push_back(&camera);
  if (with_maps.size() < 2) return;
  const CameraEstimate& reference = *with_maps.front();
  files::FloatImage reference_maps;
  TargetOutline reference_outline;
  std::string reference_failure;
  try {
    // A commit that stages files until the end (chromo estimate, chromo
    // study) has not put maps.exr in place yet: no common view, the maps stand.
    reference_maps = camera_maps(reference, results_dir);
    reference_outline = find_target_outline(reference_maps, reference.camera + "'s maps");
  } catch (const std::exception& error) {  // cv::Exception too: reported, the maps stand
    reference_failure = error.what();
  }
  for (CameraEstimate* camera : with_maps) {
    CameraCommonView view;
    view.reference = reference.camera;
    if (!reference_failure.empty()) {
      view.reason = reference_failure;
    } else if (camera == &reference) {
      view.file = reference.folder + "/maps.exr";  // the reference's own grid
    } else {
      try {
        const files::FloatImage maps = camera_maps(*camera, results_dir);
        view.mapping = map_onto_reference(find_target_outline(maps, camera->camera + "'s maps"), reference_outline);
        const auto common = resample_into_common_view(maps, view.mapping.to_reference, reference_maps.width,
                                                      reference_maps.height);
        view.file = camera->folder + "/common_view.exr";
        commit(results_dir / view.file, [&](const fs::path& temporary) { files::write_exr(temporary, common); });
      } catch (const std::exception& error) {  // cv::Exception too: reported, the maps stand
        view.reason = error.what();
      }
    }
    camera->common_view = std::move(view);
  }
}

nlohmann::ordered_json common_view_entry(const CameraCommonView& view, const std::string& path_prefix) {
  nlohmann::ordered_json out{{"reference", view.reference}};
  if (!view.reason.empty()) {
    out["reason"] = view.reason;
    return out;
  }
  out["file"] = path_prefix + view.file;
  nlohmann::ordered_json h = nlohmann::ordered_json::array();
  for (int k = 0; k < 9; ++k) h.push_back(view.mapping.to_reference.val[k]);
  out["homography"] = h;
  out["residual_px"] = view.mapping.residual_px;
  out["max_residual_px"] = view.mapping.max_residual_px;
  out["outline_cells"] = view.mapping.outline_cells;
  return out;
}

}  // namespace chromo::maps
