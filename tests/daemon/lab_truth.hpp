#pragma once
// A session's maps against the virtual lab's truth: the lab's skin scene
// (the same options the lab built it with), resampled to the maps' grid; the
// skin pixels (eroded twice, off region edges) that the estimator explained
// (flag 0), relit under D65 and A (maps::relit_delta_e94) against the truth.

#include <opencv2/imgproc.hpp>

#include <filesystem>
#include <map>

#include "chromo/daemon/internal/devices/virtual_lab.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/maps/reconstruction.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "chromo/spectral/cie.hpp"

namespace chromo::daemon::testing {

struct MapsAgainstTruth {
  int width = 0, height = 0;  // the maps'
  std::size_t skin_pixels = 0, flagged = 0;
  std::map<int, std::size_t> flagged_by_code;  // the maps' flag value → skin pixels
  std::size_t white_target_pixels = 0;          // the scene's white strip (eroded twice)
  std::map<int, std::size_t> white_target_by_flag;  // the maps' flag value → its pixels
  maps::DeltaEStats relit;    // ΔE94 under D65 over the explained skin pixels
  maps::DeltaEStats relit_a;  // the same under CIE A
};

inline MapsAgainstTruth maps_against_truth(const std::filesystem::path& maps_exr, const VirtualLabOptions& lab) {
  const auto maps = files::read_exr(maps_exr);
  simulators::SkinSceneOptions scene_options;
  scene_options.width = scene_options.height = lab.scene_size;
  scene_options.seed = lab.seed;
  scene_options.white_patch = lab.skin_white_strip;
  scene_options.threads = 1;
  const auto scene = simulators::make_skin_scene(scene_options);
  const cv::Size size(maps.width, maps.height);
  cv::Mat regions, cm, ch, bm, che;
  cv::resize(scene.regions(), regions, size, 0, 0, cv::INTER_NEAREST);
  const std::pair<const cv::Mat*, cv::Mat*> truth_maps[] = {
      {&scene.cm(), &cm}, {&scene.ch(), &ch}, {&scene.bm(), &bm}, {&scene.che(), &che}};
  for (auto [from, to] : truth_maps) cv::resize(*from, *to, size, 0, 0, cv::INTER_LINEAR);
  cv::Mat skin = regions == static_cast<int>(simulators::SceneRegion::kSkin);
  cv::erode(skin, skin, cv::Mat(), cv::Point(-1, -1), 2);
  cv::Mat white = regions == static_cast<int>(simulators::SceneRegion::kWhiteTarget);
  cv::erode(white, white, cv::Mat(), cv::Point(-1, -1), 2);
  MapsAgainstTruth out;
  out.width = maps.width, out.height = maps.height;
  for (int y = 0; y < maps.height; ++y)
    for (int x = 0; x < maps.width; ++x)
      if (white.at<std::uint8_t>(y, x)) {
        ++out.white_target_pixels;
        ++out.white_target_by_flag[static_cast<int>(maps.channel("flags")[static_cast<std::size_t>(y) * maps.width + x])];
      }
  std::vector<estimation::SkinParameters> truth, estimate;
  for (int y = 0; y < maps.height; ++y)
    for (int x = 0; x < maps.width; ++x) {
      if (!skin.at<std::uint8_t>(y, x)) continue;
      const std::size_t i = static_cast<std::size_t>(y) * maps.width + x;
      ++out.skin_pixels;
      if (maps.channel("flags")[i] != 0) {
        ++out.flagged;
        ++out.flagged_by_code[static_cast<int>(maps.channel("flags")[i])];
        continue;
      }
      truth.push_back({cm.at<float>(y, x), ch.at<float>(y, x), bm.at<float>(y, x), che.at<float>(y, x)});
      estimate.push_back({maps.channel("Cm")[i], maps.channel("Ch")[i], maps.channel("Bm")[i], maps.channel("Che")[i]});
    }
  if (!truth.empty()) {
    out.relit = maps::delta_e_stats(maps::relit_delta_e94(truth, estimate, spectral::illuminant_d65(), 1));
    out.relit_a = maps::delta_e_stats(maps::relit_delta_e94(truth, estimate, spectral::illuminant_a(), 1));
  }
  return out;
}

}  // namespace chromo::daemon::testing
