// Per-camera references and maps (issue 21 part 4) on the virtual lab with
// live cameras: two posed cameras (each a GigE Vision simulator on its own
// loopback address, through the real driver) capture one standard session;
// chromod estimates each from its own frames into results/<camera>/, lists
// both in the index results/summary.json and the API, and each camera's maps
// match the scene's truth seen through its own pose (and not through the
// other's). `chromo estimate SESSION_DIR`'s path (read_stored_session +
// estimate_session_cameras) gives the same maps. A camera whose frames the
// estimator cannot use is listed with its reason while the other's maps are
// published.
#include <opencv2/imgproc.hpp>

#include <atomic>
#include <cmath>
#include <fstream>

#include "chromo/daemon/internal/api/api_conversions.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/maps/camera_results.hpp"
#include "chromo/maps/common_view.hpp"
#include "chromo/simulators/scene/camera_view.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "chromosphere/v1/estimation.pb.h"
#include "test_lab.hpp"

namespace chromo::daemon {
namespace {

namespace fs = std::filesystem;
using simulators::SceneRegion;
using testing::TestLab;
using testing::wait_for;

constexpr double kExposureUs = 4000;  // as online_estimation_lab_test: the D65' white below full scale

simulators::LabCamera posed_camera(const std::string& name, double azimuth_deg, double elevation_deg) {
  simulators::LabCamera camera;
  camera.name = name;
  camera.sensor_width = 320;
  camera.sensor_height = 240;
  camera.pose = simulators::LabCameraPose{};
  camera.pose->distance_mm = 300;
  camera.pose->azimuth_deg = azimuth_deg;
  camera.pose->elevation_deg = elevation_deg;
  camera.pose->focal_length_mm = 2.6;  // the 80 mm patch about 200 of 320 px across
  return camera;
}

session::OperationRecord run_to_end(Daemon& daemon, const std::string& id) {
  return wait_for(daemon, id, [](const session::OperationRecord& r) { return session::is_final(r.state); },
                  std::chrono::seconds(180));
}

// The scene's truth as a posed camera's maps see it: the patch → sensor
// homography, then sensor → 2×2-binned cell (a cell's centre is sensor
// pixel 2u + 0.5), NaN outside the patch.
struct PosedTruth {
  cv::Mat cm, ch, regions;
};
PosedTruth truth_through(const simulators::LabCamera& camera, const TestLab& lab, const simulators::Scene& scene,
                         cv::Size maps_size) {
  const auto view = simulators::lab_camera_view(camera);
  const simulators::PatchGeometry patch{lab.lab_options.scene_size, lab.lab_options.scene_size,
                                        lab.lab_options.patch_width_mm / lab.lab_options.scene_size};
  const cv::Matx33d to_cells(0.5, 0, -0.25, 0, 0.5, -0.25, 0, 0, 1);
  const cv::Matx33d h = to_cells * simulators::patch_to_image_homography(*view, patch);
  PosedTruth t;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::warpPerspective(scene.cm(), t.cm, cv::Mat(h), maps_size, cv::INTER_LINEAR, cv::BORDER_CONSTANT, nan);
  cv::warpPerspective(scene.ch(), t.ch, cv::Mat(h), maps_size, cv::INTER_LINEAR, cv::BORDER_CONSTANT, nan);
  cv::warpPerspective(scene.regions(), t.regions, cv::Mat(h), maps_size, cv::INTER_NEAREST, cv::BORDER_CONSTANT,
                      cv::Scalar(255));
  return t;
}

// Over skin cells (2 cells in from any other region or the patch's edge)
// that the estimator explained: the median estimate/truth ratio of Cm and
// Ch, and the correlation of log Cm with the truth (the moles and the smooth
// fields make it high only when the pose is right).
struct Agreement {
  double cm_ratio = 0, ch_ratio = 0, log_cm_correlation = 0;
  std::size_t cells = 0;
};
Agreement agreement(const files::FloatImage& maps, const PosedTruth& truth) {
  cv::Mat skin = truth.regions == static_cast<int>(SceneRegion::kSkin);
  cv::erode(skin, skin, cv::Mat(), cv::Point(-1, -1), 2);
  std::vector<double> cm_ratios, ch_ratios, a, b;
  for (int y = 0; y < maps.height; ++y)
    for (int x = 0; x < maps.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * maps.width + x;
      const double cm_true = truth.cm.at<float>(y, x), ch_true = truth.ch.at<float>(y, x);
      if (maps.channel("flags")[i] != 0 || !std::isfinite(cm_true) || !std::isfinite(ch_true)) continue;
      a.push_back(std::log(maps.channel("Cm")[i])), b.push_back(std::log(cm_true));
      if (!skin.at<std::uint8_t>(y, x)) continue;
      cm_ratios.push_back(maps.channel("Cm")[i] / cm_true);
      ch_ratios.push_back(maps.channel("Ch")[i] / ch_true);
    }
  Agreement out;
  out.cells = cm_ratios.size();
  auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  out.cm_ratio = median(cm_ratios), out.ch_ratio = median(ch_ratios);
  double ma = 0, mb = 0;
  for (std::size_t k = 0; k < a.size(); ++k) ma += a[k], mb += b[k];
  ma /= std::max<std::size_t>(1, a.size()), mb /= std::max<std::size_t>(1, b.size());
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t k = 0; k < a.size(); ++k)
    sab += (a[k] - ma) * (b[k] - mb), saa += (a[k] - ma) * (a[k] - ma), sbb += (b[k] - mb) * (b[k] - mb);
  out.log_cm_correlation = saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : 0.0;
  return out;
}

std::size_t count_flag(const files::FloatImage& maps, estimation::PixelFlag flag) {
  std::size_t n = 0;
  for (float f : maps.channel("flags")) n += f == static_cast<float>(flag);
  return n;
}

TEST(MultiCameraEstimation, TwoPosedCamerasGetTheirOwnMapsThatMatchTheirPoses) {
  TestLab lab("multi-camera-estimation");
  lab.lab_options.scene_size = 128;
  lab.lab_options.cameras = {posed_camera("cam0", -15, 0), posed_camera("side", 30, 10)};
  lab.config.estimation.cache_dir = (fs::temp_directory_path() / "chromo-test-forward-tables").string();
  lab.config.estimation.threads = 2;
  auto daemon = lab.daemon();

  auto calibrated = testing::run_quick_calibration(*daemon);
  ASSERT_EQ(calibrated.state, session::OperationState::kSucceeded) << calibrated.error;

  auto started = daemon->start_session(testing::quick_standard_plan(1, kExposureUs), "forearm, two views");
  auto final = run_to_end(*daemon, started.id);
  ASSERT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
  EXPECT_EQ(final.counters.stored, 14u);

  auto info = daemon->session(started.id);
  ASSERT_TRUE(info);
  ASSERT_EQ(info->results.value("state", ""), "available") << info->results.dump();
  const fs::path results = fs::path(final.folder) / "results";
  EXPECT_FALSE(fs::exists(results / "maps.exr"));  // several cameras: each in its own folder
  std::ifstream index_file(results / "summary.json");
  const auto index = nlohmann::json::parse(index_file);
  ASSERT_EQ(index["cameras"].size(), 2u) << index.dump(2);
  EXPECT_EQ(index["session_id"], started.id);
  for (int k = 0; k < 2; ++k) {
    const auto& entry = index["cameras"][k];
    EXPECT_EQ(entry["name"], k == 0 ? "cam0" : "side");
    EXPECT_EQ(entry["state"], "ok") << entry.dump();
    EXPECT_EQ(entry["maps_file"], entry["name"].get<std::string>() + "/maps.exr");
    EXPECT_TRUE(fs::exists(results / entry["maps_file"].get<std::string>()));
    for (const char* file : {"summary.json", "cm.png", "flags.png"})
      EXPECT_TRUE(fs::exists(results / entry["name"].get<std::string>() / file)) << file;
    std::ifstream report_file(results / entry["report_file"].get<std::string>());
    EXPECT_EQ(nlohmann::json::parse(report_file)["camera"], entry["name"]);
  }
  // One sensitivity and the same LED states: the second camera used the first's forward table.
  EXPECT_TRUE(index["cameras"][0]["shared_with"].is_null());
  EXPECT_EQ(index["cameras"][1]["shared_with"], "cam0");
  EXPECT_EQ(index["cameras"][0]["table_key"], index["cameras"][1]["table_key"]);

  chromosphere::v1::Results api;
  results_to_proto(*info, &api);
  ASSERT_EQ(api.cameras_size(), 2);
  EXPECT_EQ(api.cameras(1).camera(), "side");
  EXPECT_EQ(api.cameras(1).state(), chromosphere::v1::RESULTS_STATE_AVAILABLE);
  EXPECT_EQ(api.cameras(1).maps_file(), (results / "side" / "maps.exr").string());
  EXPECT_EQ(api.cameras(1).shared_with(), "cam0");
  EXPECT_GT(api.cameras(1).summary().pixels(), 0u);
  EXPECT_EQ(api.maps_file(), (results / "cam0" / "maps.exr").string());
  EXPECT_EQ(api.report_file(), (results / "summary.json").string());

  // Each camera's maps against the truth through its own pose and through the other's.
  simulators::SkinSceneOptions scene_options;
  scene_options.width = scene_options.height = lab.lab_options.scene_size;
  scene_options.seed = lab.lab_options.seed;
  scene_options.threads = 1;
  const auto scene = simulators::make_skin_scene(scene_options);
  std::vector<files::FloatImage> maps;
  for (const char* camera : {"cam0", "side"}) maps.push_back(files::read_exr(results / camera / "maps.exr"));
  const cv::Size size(maps[0].width, maps[0].height);
  ASSERT_EQ(size, cv::Size(160, 120));
  for (int k = 0; k < 2; ++k) {
    const auto& camera = lab.lab_options.cameras[k];
    const auto own = agreement(maps[k], truth_through(camera, lab, scene, size));
    const auto other = agreement(maps[k], truth_through(lab.lab_options.cameras[1 - k], lab, scene, size));
    std::cout << camera.name << ": " << own.cells << " skin cells, Cm ratio " << own.cm_ratio << ", Ch ratio "
              << own.ch_ratio << ", log Cm correlation " << own.log_cm_correlation << " (through the other pose "
              << other.log_cm_correlation << ")\n";
    EXPECT_GT(own.cells, 3000u);
    // Cm as the frontal camera's (online_estimation_lab_test); Ch is not
    // pinned apart from Che by the four channels (docs/estimation.md), so
    // only its printed ratio is reported here.
    EXPECT_NEAR(own.cm_ratio, 1.0, 0.15) << camera.name;
    // 0.6 since the noise model's fix (e37c201): 0.62-0.63 measured after,
    // above 0.7 before. Not the blue LED's temperature (checked in issue 37,
    // docs/estimation.md "The noise model"): with the LEDs not drifting,
    // cam0 / side read 0.714 / 0.610 (seed 1) and 0.679 / 0.653 (seed 2)
    // against 0.728 / 0.626 and 0.682 / 0.691 with drift. The side camera
    // (30° off the normal) sets the bound: 0.607 with the 2D model alone
    // (cam0 0.769), 0.469 with the 4D (cam0 0.486).
    // 7 Dec 2026 (the LEDs' thermal model, issue 39's prepared tables):
    // side 0.5995-0.656 over six runs (one failed the 0.6 bound, 0.607 and
    // 0.607 twice), cam0 0.710-0.728; the spread is the run's LED timing.
    // The bound sits under that spread; what tells the poses apart is the
    // other pose's correlation staying 0.05 below, asserted next.
    EXPECT_GT(own.log_cm_correlation, 0.55) << camera.name;
    EXPECT_LT(other.log_cm_correlation, own.log_cm_correlation - 0.05) << camera.name;
    // Outside the camera's footprint of the white target: flagged no_reference, maps NaN.
    const auto view = simulators::lab_camera_view(camera);
    const auto corners = simulators::patch_corners_in_image(
        *view, {lab.lab_options.scene_size, lab.lab_options.scene_size,
                lab.lab_options.patch_width_mm / lab.lab_options.scene_size});
    std::vector<cv::Point2f> quad(corners.begin(), corners.end());
    const double inside_cells = cv::contourArea(quad) / 4;
    const double outside = static_cast<double>(count_flag(maps[k], estimation::PixelFlag::kNoReference));
    EXPECT_NEAR(static_cast<double>(size.area()) - outside, inside_cells, 0.04 * inside_cells) << camera.name;
    std::size_t nan_outside = 0;
    for (std::size_t i = 0; i < maps[k].channel("flags").size(); ++i)
      if (maps[k].channel("flags")[i] == static_cast<float>(estimation::PixelFlag::kNoReference))
        nan_outside += std::isnan(maps[k].channel("Cm")[i]) && std::isnan(maps[k].channel("Ch")[i]);
    EXPECT_EQ(static_cast<double>(nan_outside), outside);
  }

  // The common view (issue 42 part 2): side's maps resampled into cam0's
  // grid through the homography of the white target's outline; its
  // corresponding points against the poses' truth, and Cm there against cam0's.
  ASSERT_EQ(api.cameras(0).common_view_reference(), "cam0");
  EXPECT_EQ(api.cameras(0).common_view_file(), api.cameras(0).maps_file());
  ASSERT_EQ(api.cameras(1).common_view_reason(), "");
  ASSERT_EQ(api.cameras(1).common_view_file(), (results / "side" / "common_view.exr").string());
  ASSERT_EQ(api.cameras(1).common_view_homography_size(), 9);
  cv::Matx33d estimated;
  for (int k = 0; k < 9; ++k) estimated.val[k] = api.cameras(1).common_view_homography(k);
  const cv::Matx33d to_cells(0.5, 0, -0.25, 0, 0.5, -0.25, 0, 0, 1);
  const simulators::PatchGeometry patch{lab.lab_options.scene_size, lab.lab_options.scene_size,
                                        lab.lab_options.patch_width_mm / lab.lab_options.scene_size};
  const auto cells_of = [&](const simulators::LabCamera& camera) {
    return to_cells * simulators::patch_to_image_homography(*simulators::lab_camera_view(camera), patch);
  };
  const cv::Matx33d truth = cells_of(lab.lab_options.cameras[0]) * cells_of(lab.lab_options.cameras[1]).inv();
  double worst_px = 0;
  for (double u = 0.05; u < 1; u += 0.1)  // a grid over the target, in patch units
    for (double v = 0.05; v < 1; v += 0.1) {
      const cv::Vec3d p = cells_of(lab.lab_options.cameras[1]) *
                          cv::Vec3d(u * lab.lab_options.scene_size, v * lab.lab_options.scene_size, 1);
      const cv::Vec3d a = estimated * p, b = truth * p;
      worst_px = std::max(worst_px, std::hypot(a[0] / a[2] - b[0] / b[2], a[1] / a[2] - b[1] / b[2]));
    }
  const double residual_px = api.cameras(1).common_view_residual_px();
  std::cout << "common view: residual " << residual_px << " cells, worst corresponding point " << worst_px
            << " cells from the poses' truth\n";
  EXPECT_LT(worst_px, 1.0);
  EXPECT_LT(residual_px, 0.5);
  const auto common = files::read_exr(results / "side" / "common_view.exr");
  ASSERT_EQ(common.width, maps[0].width);
  ASSERT_EQ(common.height, maps[0].height);
  std::vector<double> z;
  for (std::size_t i = 0; i < common.channel("Cm").size(); ++i) {
    if (maps[0].channel("flags")[i] != 0 || common.channel("flags")[i] != 0) continue;
    const double s0 = maps[0].channel("sigma_Cm")[i], s1 = common.channel("sigma_Cm")[i];
    if (!(s0 > 0 && s1 > 0)) continue;
    z.push_back((common.channel("Cm")[i] - maps[0].channel("Cm")[i]) / std::hypot(s0, s1));
  }
  ASSERT_GT(z.size(), 3000u);
  std::size_t within_1 = 0, within_2 = 0;
  for (double v : z) within_1 += std::abs(v) <= 1, within_2 += std::abs(v) <= 2;
  const double share_1 = static_cast<double>(within_1) / z.size(), share_2 = static_cast<double>(within_2) / z.size();
  std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
  std::cout << "common view: Cm of side against cam0 over " << z.size() << " cells: " << 100 * share_1
            << "% within 1 sigma, " << 100 * share_2 << "% within 2 sigma, median z " << z[z.size() / 2] << "\n";
  EXPECT_GT(share_1, 0.6);
  EXPECT_GT(share_2, 0.9);
  EXPECT_LT(std::abs(z[z.size() / 2]), 0.3);

  // The σ maps are wide for this check (the estimator's σ covers the model's
  // ambiguity, not only the camera's noise), so the registration is also
  // judged by the RMS Cm difference: the estimated homography's against the
  // poses' own, and a 2-cell misregistration's.
  const auto rms_against_cam0 = [&](const files::FloatImage& view) {
    double sum = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < view.channel("Cm").size(); ++i) {
      if (maps[0].channel("flags")[i] != 0 || view.channel("flags")[i] != 0) continue;
      const double d = view.channel("Cm")[i] - maps[0].channel("Cm")[i];
      sum += d * d, ++n;
    }
    return std::sqrt(sum / std::max<std::size_t>(n, 1));
  };
  const double rms_estimated = rms_against_cam0(common);
  const double rms_truth = rms_against_cam0(maps::resample_into_common_view(maps[1], truth, common.width, common.height));
  const double rms_shifted = rms_against_cam0(maps::resample_into_common_view(
      maps[1], cv::Matx33d(1, 0, 2, 0, 1, 0, 0, 0, 1) * truth, common.width, common.height));
  std::cout << "common view: RMS Cm difference " << rms_estimated << " (the poses' homography " << rms_truth
            << ", shifted 2 cells " << rms_shifted << ")\n";
  EXPECT_LT(rms_estimated, 1.05 * rms_truth);
  EXPECT_GT(rms_shifted, 1.2 * rms_estimated);

  // `chromo estimate SESSION_DIR`'s path gives the daemon's maps, camera by camera.
  const auto sources = session::resolve_capture_sources((results / "led_library.json").string(), "builtin:nikon_d5100", 0.99);
  const auto builder = session::read_stored_session(final.folder, sources);
  maps::MethodEstimationOptions options;
  options.cache_dir = lab.config.estimation.cache_dir;
  options.estimator.threads = 2;
  // The multi-pixel estimate as chromod runs it (estimation.skin_denoise, on by default).
  if (lab.config.estimation.skin_denoise == "on") options.skin_denoise = estimation::SkinDenoiseOptions{};
  const fs::path offline = lab.directory / "offline";
  const maps::FileCommit commit = [](const fs::path& path, const std::function<void(const fs::path&)>& produce) {
    fs::create_directories(path.parent_path());
    produce(path);
  };
  // Both cameras at once (the default, as the daemon ran), then one after another: the same maps.
  for (const int at_once : {0, 1}) {
    SCOPED_TRACE("cameras at once " + std::to_string(at_once));
    options.cameras_at_once = at_once;
    const fs::path offline_run = offline / std::to_string(at_once);
    // files::Progress's contract: one call at a time, fractions never decreasing, ending at 1.
    std::atomic<int> inside{0};
    int overlapping_calls = 0, decreasing = 0;
    double last = 0;
    files::Progress progress;
    progress.on_progress = [&](double fraction, const std::string&) {
      overlapping_calls += inside.fetch_add(1) != 0;
      decreasing += fraction < last;
      last = fraction;
      inside.fetch_sub(1);
    };
    const auto offline_cameras =
        maps::estimate_session_cameras({&builder, nullptr, {}, {}}, options, offline_run, commit, progress);
    EXPECT_EQ(overlapping_calls, 0);
    EXPECT_EQ(decreasing, 0);
    EXPECT_DOUBLE_EQ(last, 1.0);
    ASSERT_EQ(offline_cameras.size(), 2u);
    for (int k = 0; k < 2; ++k) {
      ASSERT_TRUE(offline_cameras[k].ok) << offline_cameras[k].reason;
      EXPECT_EQ(offline_cameras[k].camera, k == 0 ? "cam0" : "side");
      const auto again = files::read_exr(offline_run / offline_cameras[k].camera / "maps.exr");
      for (const char* channel : {"Cm", "Ch", "Bm", "Che", "flags"}) {
        const auto &x = again.channel(channel), &y = maps[k].channel(channel);
        ASSERT_EQ(x.size(), y.size());
        std::size_t differ = 0;
        for (std::size_t i = 0; i < x.size(); ++i) differ += !(x[i] == y[i] || (std::isnan(x[i]) && std::isnan(y[i])));
        EXPECT_EQ(differ, 0u) << offline_cameras[k].camera << " " << channel;
      }
    }
  }
}

TEST(MultiCameraEstimation, ACameraThatCannotBeEstimatedIsListedWithItsReasonAndTheOtherIsPublished) {
  TestLab lab("multi-camera-failed");
  lab.lab_options.cameras.front().sensor_width = 320;  // the size online_estimation_lab_test estimates
  lab.lab_options.cameras.front().sensor_height = 240;
  lab.lab_options.scene_size = 128;
  simulators::LabCamera mono;  // the capture builder refuses mono frames
  mono.name = "mono";
  mono.sensor_width = 160;
  mono.sensor_height = 120;
  mono.pixel_format = drivers::PixelFormat::kMono12;
  lab.lab_options.cameras.push_back(mono);
  lab.config.estimation.cache_dir = (fs::temp_directory_path() / "chromo-test-forward-tables").string();
  lab.config.estimation.threads = 2;
  auto daemon = lab.daemon();
  auto started = daemon->start_session(testing::quick_standard_plan(1, kExposureUs), "one camera fails");
  auto final = run_to_end(*daemon, started.id);
  ASSERT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
  auto info = daemon->session(started.id);
  ASSERT_TRUE(info);
  ASSERT_EQ(info->results.value("state", ""), "available") << info->results.dump();
  const fs::path results = fs::path(final.folder) / "results";
  std::ifstream index_file(results / "summary.json");
  const auto index = nlohmann::json::parse(index_file);
  ASSERT_EQ(index["cameras"].size(), 2u) << index.dump(2);
  EXPECT_EQ(index["cameras"][0]["state"], "ok");
  EXPECT_EQ(index["cameras"][1]["name"], "mono");
  EXPECT_EQ(index["cameras"][1]["state"], "failed");
  EXPECT_NE(index["cameras"][1]["reason"].get<std::string>().find("no colour"), std::string::npos) << index.dump(2);
  EXPECT_TRUE(fs::exists(results / "cam0" / "maps.exr"));
  EXPECT_FALSE(fs::exists(results / "mono"));
  chromosphere::v1::Results api;
  results_to_proto(*info, &api);
  ASSERT_EQ(api.cameras_size(), 2);
  EXPECT_EQ(api.cameras(1).state(), chromosphere::v1::RESULTS_STATE_UNAVAILABLE);
  EXPECT_NE(api.cameras(1).reason().find("no colour"), std::string::npos);
}

}  // namespace
}  // namespace chromo::daemon
