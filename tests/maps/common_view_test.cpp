// The common view's pieces (maps/common_view.hpp) on flags maps drawn from a
// known quadrilateral: the outline's corners, the homography between two
// outlines against the one that drew them, the resampling's categorical and
// outside cells, and the errors for a target not wholly in view.
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>

#include "chromo/estimation/pixel_flags.hpp"
#include "chromo/maps/camera_results.hpp"
#include "chromo/maps/common_view.hpp"

namespace chromo::maps {
namespace {

constexpr float kOutside = static_cast<float>(estimation::PixelFlag::kNoReference);

// A 160×120 map whose cells with centres inside `quad` see the target.
files::FloatImage flags_inside(const std::vector<cv::Point2f>& quad) {
  files::FloatImage maps;
  maps.width = 160, maps.height = 120;
  maps.channel_names = {"Cm", "flags"};
  maps.channels.assign(2, std::vector<float>(160 * 120));
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) {
      const bool in = cv::pointPolygonTest(quad, cv::Point2f(x, y), false) >= 0;
      maps.channels[0][y * 160 + x] = in ? 0.01f * static_cast<float>(x) : NAN;
      maps.channels[1][y * 160 + x] = in ? 0.0f : kOutside;
    }
  return maps;
}

TEST(CommonView, TheOutlineCornersAndTheHomographyAreWithinAFractionOfACell) {
  const std::vector<cv::Point2f> a{{30.3f, 20.6f}, {131.2f, 25.1f}, {127.4f, 98.2f}, {34.1f, 95.7f}};
  const std::vector<cv::Point2f> b{{20.8f, 15.2f}, {110.5f, 22.9f}, {118.3f, 103.4f}, {25.6f, 90.1f}};
  const auto outline_a = find_target_outline(flags_inside(a), "a");
  const auto outline_b = find_target_outline(flags_inside(b), "b");
  for (int k = 0; k < 4; ++k) {
    EXPECT_LT(cv::norm(outline_a.corners[k] - cv::Point2d(a[k])), 0.5) << k;
    EXPECT_LT(cv::norm(outline_b.corners[k] - cv::Point2d(b[k])), 0.5) << k;
  }
  const auto mapping = map_onto_reference(outline_b, outline_a);
  const cv::Matx33d truth(cv::getPerspectiveTransform(b.data(), a.data()));
  for (double u = 40; u < 110; u += 10)
    for (double v = 30; v < 90; v += 10) {
      const cv::Vec3d p = mapping.to_reference * cv::Vec3d(u, v, 1), q = truth * cv::Vec3d(u, v, 1);
      EXPECT_LT(std::hypot(p[0] / p[2] - q[0] / q[2], p[1] / p[2] - q[1] / q[2]), 0.5) << u << "," << v;
    }
  EXPECT_GT(mapping.outline_cells, 200u);
  EXPECT_LT(mapping.residual_px, 0.5);
}

TEST(CommonView, ResamplingKeepsFlagsCategoricalAndMarksCellsItCannotSee) {
  auto maps = flags_inside({{30, 20}, {130, 20}, {130, 100}, {30, 100}});
  maps.channels[1][60 * 160 + 80] = 3;  // one flagged cell
  const cv::Matx33d shift(1, 0, 0.5, 0, 1, 0, 0, 0, 1);  // half a cell right
  const auto common = resample_into_common_view(maps, shift, 100, 100);
  const auto& flags = common.channel("flags");
  const auto& cm = common.channel("Cm");
  for (int x : {80, 81}) EXPECT_TRUE(flags[60 * 100 + x] == 0 || flags[60 * 100 + x] == 3) << x;  // never between
  EXPECT_TRUE(flags[60 * 100 + 80] == 3 || flags[60 * 100 + 81] == 3);
  EXPECT_NEAR(cm[50 * 100 + 70], 0.01 * 69.5, 1e-5);              // bilinear between 69 and 70
  EXPECT_EQ(flags[10 * 100 + 10], kOutside);
  EXPECT_TRUE(std::isnan(cm[10 * 100 + 10]));
}

TEST(CommonView, ATargetNotWhollyInViewIsRefusedNamingTheMaps) {
  try {
    find_target_outline(flags_inside({{-5, 20}, {130, 20}, {130, 100}, {-5, 100}}), "side's maps");
    FAIL() << "no error";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("side's maps: the white target reaches the map's left or right edge"),
              std::string::npos)
        << error.what();
  }
  auto none = flags_inside({{30, 20}, {130, 20}, {130, 100}, {30, 100}});
  std::fill(none.channels[1].begin(), none.channels[1].end(), kOutside);
  EXPECT_THROW(find_target_outline(none, "x"), std::invalid_argument);
}

// Two cameras' estimates whose maps.exr are written under `dir` (their
// channels in the report's order, not the file's) and kept in memory.
std::vector<CameraEstimate> two_cameras_written(const std::filesystem::path& dir) {
  const std::vector<std::vector<cv::Point2f>> quads = {{{30.3f, 20.6f}, {131.2f, 25.1f}, {127.4f, 98.2f}, {34.1f, 95.7f}},
                                                       {{20.8f, 15.2f}, {110.5f, 22.9f}, {118.3f, 103.4f}, {25.6f, 90.1f}}};
  std::vector<CameraEstimate> cameras(2);
  for (int k = 0; k < 2; ++k) {
    files::FloatImage maps = flags_inside(quads[k]);
    std::swap(maps.channel_names[0], maps.channel_names[1]), std::swap(maps.channels[0], maps.channels[1]);
    CameraEstimate& camera = cameras[k];
    camera.camera = camera.folder = "cam" + std::to_string(k);
    camera.ok = true;
    std::filesystem::create_directories(dir / camera.folder);
    files::write_exr(dir / camera.folder / "maps.exr", maps);
    camera.result.emplace();
    camera.result->maps = std::make_shared<const files::FloatImage>(std::move(maps));
  }
  return cameras;
}

std::string file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(CommonView, TheMapsInMemoryGiveTheCommonViewTheFilesGiveByteForByte) {
  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / "common_view_in_memory";
  std::filesystem::remove_all(dir);
  const FileCommit commit = [](const std::filesystem::path& path,
                               const std::function<void(const std::filesystem::path&)>& produce) { produce(path); };
  std::vector<CameraEstimate> from_memory = two_cameras_written(dir / "memory"), from_files = two_cameras_written(dir / "files");
  for (auto& camera : from_files) camera.result->maps.reset();
  add_common_views(from_memory, dir / "memory", commit);
  add_common_views(from_files, dir / "files", commit);
  ASSERT_TRUE(from_memory[1].common_view && from_files[1].common_view);
  ASSERT_EQ(from_memory[1].common_view->reason, "");
  EXPECT_EQ(from_memory[1].common_view->mapping.to_reference, from_files[1].common_view->mapping.to_reference);
  const std::string memory_file = file_bytes(dir / "memory" / "cam1" / "common_view.exr");
  EXPECT_GT(memory_file.size(), 1000u);
  EXPECT_EQ(memory_file, file_bytes(dir / "files" / "cam1" / "common_view.exr"));
}

TEST(CommonView, AMapsFileNotInPlaceGivesNoCommonViewEvenWithTheMapsInMemory) {
  // chromo estimate stages its files until the end: no common view there, as before.
  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / "common_view_staged";
  std::filesystem::remove_all(dir);
  std::vector<CameraEstimate> cameras = two_cameras_written(dir);
  std::filesystem::remove(dir / "cam0" / "maps.exr");
  add_common_views(cameras, dir, [](const std::filesystem::path& path,
                                    const std::function<void(const std::filesystem::path&)>& produce) { produce(path); });
  ASSERT_TRUE(cameras[1].common_view);
  EXPECT_NE(cameras[1].common_view->reason.find("maps.exr"), std::string::npos) << cameras[1].common_view->reason;
  EXPECT_FALSE(std::filesystem::exists(dir / "cam1" / "common_view.exr"));
}

}  // namespace
}  // namespace chromo::maps
