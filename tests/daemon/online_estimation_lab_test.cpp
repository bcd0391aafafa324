// The on-line estimator inside a Daemon on the virtual lab (the protocol
// simulators behind the real drivers: Modbus TCP LED controller, GigE Vision
// camera on loopback, USB2000+): a calibration run measures the LED library
// and solves the mixes, the standard session captures the skin scene, and
// the session ends with maps, the report and the results record; the maps
// are compared with the scene's truth.
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <fstream>

#include "chromo/daemon/api_conversions.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/maps/reconstruction.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromosphere/v1/estimation.pb.h"
#include "test_lab.hpp"

namespace chromo::daemon {
namespace {

namespace fs = std::filesystem;
using simulators::SceneRegion;
using testing::TestLab;
using testing::wait_final;
using testing::wait_for;

// The solved D65' mix drives W57 at full power: 4 ms keeps its white below
// full scale (10 ms clips it; the estimator then refuses, see below).
constexpr double kExposureUs = 4000;

TEST(OnlineEstimationOnTheVirtualLab, CalibratedStandardSessionEndsInMapsThatMatchTheScene) {
  TestLab lab("online-estimation-lab");
  lab.lab_options.cameras.front().sensor_width = 320;
  lab.lab_options.cameras.front().sensor_height = 240;
  lab.lab_options.scene_size = 128;
  lab.config.estimation.cache_dir = (fs::temp_directory_path() / "chromo-test-forward-tables").string();
  lab.config.estimation.threads = 2;
  auto daemon = lab.daemon();

  auto calibrated = testing::run_quick_calibration(*daemon);
  ASSERT_EQ(calibrated.state, session::OperationState::kSucceeded) << calibrated.error;

  auto started = daemon->start_session(testing::quick_standard_plan(1, kExposureUs), "forearm");
  auto final = wait_for(*daemon, started.id, [](const session::OperationRecord& r) { return session::is_final(r.state); },
                        std::chrono::seconds(120));
  ASSERT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
  EXPECT_EQ(final.counters.stored, 7u);
  EXPECT_EQ(final.counters.estimated, 7u);

  auto info = daemon->session(started.id);
  ASSERT_TRUE(info);
  ASSERT_EQ(info->results.value("state", ""), "available") << info->results.dump();
  const fs::path folder = final.folder;
  for (const char* file : {"maps.exr", "summary.json", "cm.png", "flags.png", "led_library.json"})
    EXPECT_TRUE(fs::exists(folder / "results" / file)) << file;
  std::ifstream in(folder / "results" / "summary.json");
  const auto summary = nlohmann::json::parse(in);
  EXPECT_EQ(summary["led_library"], daemon->calibrations().library_path());
  chromosphere::v1::Results results;
  results_to_proto(*info, &results);
  EXPECT_EQ(results.state(), chromosphere::v1::RESULTS_STATE_AVAILABLE);
  EXPECT_EQ(results.summary().relit_delta_e94().size(), 3);

  // Against the truth: the lab's scene (same options), resampled to the maps' grid.
  const auto maps = files::read_exr(folder / "results" / "maps.exr");
  ASSERT_EQ(maps.width, 160);
  ASSERT_EQ(maps.height, 120);
  simulators::SkinSceneOptions scene_options;
  scene_options.width = scene_options.height = lab.lab_options.scene_size;
  scene_options.seed = lab.lab_options.seed;
  scene_options.threads = 1;
  const auto scene = simulators::make_skin_scene(scene_options);
  const cv::Size size(maps.width, maps.height);
  cv::Mat regions, cm, ch, bm, che;
  cv::resize(scene.regions(), regions, size, 0, 0, cv::INTER_NEAREST);
  const std::pair<const cv::Mat*, cv::Mat*> truth_maps[] = {
      {&scene.cm(), &cm}, {&scene.ch(), &ch}, {&scene.bm(), &bm}, {&scene.che(), &che}};
  for (auto [from, to] : truth_maps) cv::resize(*from, *to, size, 0, 0, cv::INTER_LINEAR);
  cv::Mat skin = regions == static_cast<int>(SceneRegion::kSkin);
  cv::erode(skin, skin, cv::Mat(), cv::Point(-1, -1), 2);
  std::vector<estimation::SkinParameters> truth, estimate;
  std::size_t skin_pixels = 0, flagged = 0;
  for (int y = 0; y < maps.height; ++y)
    for (int x = 0; x < maps.width; ++x) {
      if (!skin.at<std::uint8_t>(y, x)) continue;
      const std::size_t i = static_cast<std::size_t>(y) * maps.width + x;
      ++skin_pixels;
      if (maps.channel("flags")[i] != 0) {
        ++flagged;
        continue;
      }
      truth.push_back({cm.at<float>(y, x), ch.at<float>(y, x), bm.at<float>(y, x), che.at<float>(y, x)});
      estimate.push_back(
          {maps.channel("Cm")[i], maps.channel("Ch")[i], maps.channel("Bm")[i], maps.channel("Che")[i]});
    }
  ASSERT_GT(skin_pixels, 5000u);
  const auto relit =
      maps::delta_e_stats(maps::relit_delta_e94(truth, estimate, spectral::illuminant_d65(), 1));
  std::cout << "virtual lab session: skin " << skin_pixels << ", flagged " << flagged << "; relit ΔE94 (D65) vs truth mean "
            << relit.mean << " median " << relit.median << " p95 " << relit.p95 << "; estimate "
            << summary["timings_s"]["estimate"] << " s, " << summary["pixels_per_second"] << " pixels/s\n";
  EXPECT_LT(static_cast<double>(flagged) / skin_pixels, 0.01);
  EXPECT_LT(relit.median, 1.3);

  // Too long an exposure clips the white reference: no maps, and the record says why.
  auto clipped = daemon->start_session(testing::quick_standard_plan(1, 12000), "forearm");
  auto clipped_final = wait_for(*daemon, clipped.id, [](const session::OperationRecord& r) { return session::is_final(r.state); },
                                std::chrono::seconds(120));
  ASSERT_EQ(clipped_final.state, session::OperationState::kSucceeded) << clipped_final.error;  // the frames are stored
  auto clipped_info = daemon->session(clipped.id);
  EXPECT_EQ(clipped_info->results.value("state", ""), "unavailable");
  EXPECT_NE(clipped_info->results.value("reason", "").find("white reference under D65'"), std::string::npos)
      << clipped_info->results.dump();
  EXPECT_NE(clipped_info->results.value("reason", "").find("saturated"), std::string::npos);
  EXPECT_FALSE(fs::exists(fs::path(clipped_final.folder) / "results" / "maps.exr"));
}

}  // namespace
}  // namespace chromo::daemon
