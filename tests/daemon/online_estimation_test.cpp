// The on-line estimator (daemon/internal/capture/online_estimator.hpp) on a standard session
// whose frames are the virtual lab's physics: the skin scene and the white
// target (simulators/scene), lit by the LED lab's true emission at the
// session's drive levels, read out by the camera model (RGGB Bayer, 12-bit,
// shot and read noise). The frames go through the daemon's real pipeline and
// storage (FramePipeline, journal, TIFFs) into the estimator; the maps are
// compared with the scene's truth maps; the folder is then estimated again
// offline (`chromo estimate SESSION_DIR`) and read back after a "restart"
// (a new Daemon on the same sessions folder, GetResults' conversion).
//
// No camera simulator (no GigE port) is started: the rendering runs in this
// process, so this suite needs no gige_loopback lock.
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <fstream>

#include "../cli/run_chromo.hpp"
#include "chromo/calibration/led_library_io.hpp"
#include "chromo/daemon/internal/api/api_conversions.hpp"
#include "chromo/daemon/daemon.hpp"
#include "chromo/daemon/internal/capture/online_estimator.hpp"
#include "chromo/session/session_store.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/maps/reconstruction.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/simulators/camera/camera_model.hpp"
#include "chromo/simulators/leds/led_lab.hpp"
#include "chromo/simulators/scene/scene.hpp"
#include "chromosphere/v1/estimation.pb.h"
#include "test_lab.hpp"

namespace chromo::daemon {
namespace {

namespace fs = std::filesystem;
using simulators::SceneRegion;

constexpr int kSceneSize = 96;   // scene pixels; the sensor has twice as many per side (binned back 2×2)
constexpr double kExposureUs = 10000;

// The virtual lab's physics without the devices.
struct RenderedLab {
  simulators::Scene skin = simulators::make_skin_scene([] {
    simulators::SkinSceneOptions o;
    o.width = o.height = kSceneSize;
    o.white_patch = false;
    o.seed = 7;
    o.threads = 1;
    return o;
  }());
  simulators::Scene white = simulators::make_white_target_scene(kSceneSize, kSceneSize);
  simulators::LedLab leds{[] {
    simulators::LedLabOptions o;
    o.start_warm = true;
    return o;
  }()};
  simulators::CameraModel camera{simulators::CameraModelOptions{}};
  std::uint64_t frame_index = 0;

  spectral::Spectrum emit(const drivers::DriveLevels& drive) { return leds.emit_settled(drive); }

  // What a perfect calibration run measures: each LED alone at full drive.
  calibration::LedLibrary measured_library() {
    calibration::LedLibrary library = calibration::nominal_led_library();
    library.source = "measured";
    for (std::size_t t = 0; t < spectral::kLedTypeCount; ++t) {
      drivers::DriveLevels drive{};
      drive[t] = 1.0;
      library.leds[t].ladder = {{1.0, std::nullopt, std::nullopt, true, emit(drive)}};
    }
    return library;
  }

  drivers::Frame frame(const simulators::Scene& scene, const drivers::DriveLevels& drive) {
    const spectral::Spectrum irradiance = emit(drive);
    const Eigen::Matrix<double, Eigen::Dynamic, spectral::kGridSize> weights = camera.weights(irradiance);
    cv::Mat response = scene.render(weights), sensor;
    cv::resize(response, sensor, cv::Size(2 * kSceneSize, 2 * kSceneSize), 0, 0, cv::INTER_LINEAR);
    const cv::Mat dn =
        camera.expose(sensor, simulators::SensorLayout::kBayerRGGB, 0, 0, kExposureUs, 0, frame_index);
    drivers::Frame f;
    f.sequence = frame_index++;
    f.width = dn.cols, f.height = dn.rows;
    f.pixel_format = drivers::PixelFormat::kBayerRG12;
    f.data.assign(dn.ptr<std::uint8_t>(), dn.ptr<std::uint8_t>() + dn.total() * dn.elemSize());
    return f;
  }
};

struct RecordedSession {
  std::string id;
  fs::path folder;
  nlohmann::json results;
  session::PipelineCounters counters;
  std::vector<std::uint64_t> behind_reports;
};

// Runs the standard plan's frames through storage and the estimator, the way
// Daemon::run_session does, and ends the session succeeded.
RecordedSession run_session(const fs::path& sessions, OnlineEstimator& estimator, std::size_t estimator_queue_frames) {
  RenderedLab lab;
  files::StorageBudget budget;
  session::SessionStore store(sessions, &budget);
  session::StandardPlanOptions plan_options;
  plan_options.exposure_us = kExposureUs;
  const session::SessionPlan plan = session::standard_plan(plan_options);
  auto created = store.create(plan, "rendered forearm", nlohmann::json::array());
  RecordedSession recorded{created.id, created.folder, nullptr, {}, {}};
  const auto mixes = default_virtual_lab_mixes();
  // One sum of the frames, filled by the storage thread and read by the estimator.
  const auto stored_sums = std::make_shared<session::SessionFrameSums>();
  estimator.begin_session({created.id, created.folder, plan, {}, {}, {}, stored_sums});
  {
    FramePipeline pipeline(created.folder, *created.journal, &budget, {64, estimator_queue_frames, stored_sums.get()},
                           &estimator, {},
                           [&](std::uint64_t skipped) { recorded.behind_reports.push_back(skipped); });
    for (std::size_t s = 0; s < plan.steps.size(); ++s) {
      const session::Step& step = plan.steps[s];
      const drivers::DriveLevels drive =
          step.role == session::StepRole::kDark ? drivers::DriveLevels{} : mixes.at(step.illumination.mix);
      drivers::Frame frame = lab.frame(step.role == session::StepRole::kSubject ? lab.skin : lab.white, drive);
      CapturedFrame captured;
      captured.record.camera = "cam0";
      captured.record.step = step.name;
      captured.record.step_index = static_cast<int>(s);
      captured.record.role = step.role;
      captured.record.exposure_us = kExposureUs;
      captured.record.led = session::FrameLedState{.drive = drive};
      captured.record.sequence = frame.sequence;
      captured.record.width = frame.width;
      captured.record.height = frame.height;
      captured.record.pixel_format = frame.pixel_format;
      captured.samples = std::move(frame.data);
      captured.trigger_time = std::chrono::steady_clock::now();
      pipeline.submit(std::move(captured));
    }
    pipeline.drain();
    recorded.counters = pipeline.counters();
  }
  recorded.results = estimator.end_session({true});
  if (!recorded.results.is_null()) created.journal->append(recorded.results);
  created.journal->append({{"type", "state"}, {"state", "succeeded"}});
  return recorded;
}

struct Fixture : ::testing::Test {
  static inline fs::path directory;
  static inline fs::path library_file;
  static inline RecordedSession streamed, behind;

  // Shared by the test processes (one per test): tables are written by rename.
  static fs::path cache_dir() { return fs::temp_directory_path() / "chromo-test-forward-tables"; }

  static std::unique_ptr<OnlineEstimator> estimator() {
    OnlineEstimatorOptions options;
    options.estimation.cache_dir = cache_dir();
    options.estimation.estimator.threads = 2;
    // The multi-pixel estimate, as chromod (estimation.skin_denoise) and `chromo estimate` run it by default.
    options.estimation.skin_denoise = estimation::SkinDenoiseOptions{};
    options.sources = [] {
      return session::resolve_capture_sources(library_file.string(), "builtin:nikon_d5100", simulators::kWhiteTargetReflectance);
    };
    return std::make_unique<OnlineEstimator>(options);
  }

  static void SetUpTestSuite() {
    directory = testing::fresh_directory("online-estimation");
    library_file = directory / "led-library.json";
    RenderedLab lab;
    calibration::save_led_library(lab.measured_library(), library_file);
    auto e = estimator();
    streamed = run_session(directory / "sessions", *e, 8);
    // The same frames with an estimator queue of 0: every frame is skipped
    // live and read back from storage at the end.
    behind = run_session(directory / "sessions", *e, 0);
  }
  static void TearDownTestSuite() {
    std::error_code ignored;
    fs::remove_all(directory, ignored);
  }
};

TEST_F(Fixture, StreamedSessionPublishesMapsReportAndResultsRecord) {
  ASSERT_EQ(streamed.results.value("state", ""), "available") << streamed.results.dump();
  EXPECT_EQ(streamed.counters.stored, 7u);
  EXPECT_EQ(streamed.counters.estimated, 7u);
  EXPECT_EQ(streamed.counters.estimator_skipped, 0u);
  EXPECT_EQ(streamed.results["frames_read_back"], 0);
  EXPECT_TRUE(streamed.behind_reports.empty());
  for (const char* file : {"maps.exr", "summary.json", "cm.png", "ch.png", "bm.png", "che.png", "residual.png",
                           "flags.png", "order.png", "led_library.json"})
    EXPECT_TRUE(fs::exists(streamed.folder / "results" / file)) << file;
  for (const auto& entry : fs::directory_iterator(streamed.folder / "results")) {
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos) << entry.path();
    EXPECT_FALSE(entry.is_directory()) << entry.path();  // one camera: no results/<camera>/
  }
  // One camera: the layout of before several cameras, and the record lists it.
  ASSERT_EQ(streamed.results["cameras"].size(), 1u) << streamed.results.dump();
  EXPECT_EQ(streamed.results["cameras"][0]["name"], "cam0");
  EXPECT_EQ(streamed.results["cameras"][0]["state"], "ok");
  EXPECT_EQ(streamed.results["cameras"][0]["maps_file"], "results/maps.exr");
  EXPECT_EQ(streamed.results["maps_file"], "results/maps.exr");
  EXPECT_EQ(streamed.results["report_file"], "results/summary.json");

  std::ifstream in(streamed.folder / "results" / "summary.json");
  const auto summary = nlohmann::json::parse(in);
  EXPECT_EQ(summary["method"], "fast");
  EXPECT_EQ(summary["model"], "auto");
  EXPECT_EQ(summary["pixels"], kSceneSize * kSceneSize);
  EXPECT_GT(summary["pixels_per_second"].get<double>(), 0);
  EXPECT_EQ(summary["camera"], "cam0");
  EXPECT_FALSE(summary.contains("cameras"));  // the camera's report itself, not an index
  EXPECT_EQ(summary["no_reference_pixels"], 0);  // the white fills the frame
  ASSERT_EQ(summary["registration"].size(), 2u);
  for (const auto& r : summary["registration"]) EXPECT_LT(r["residual_motion_px"].get<double>(), 0.5) << r.dump();
  // Relit against the photographs under each captured illuminant.
  for (const char* name : {"D65'", "W57", "W57+blue"}) {
    const auto& s = summary["relit_delta_e94"]["by_illuminant"][name];
    std::cout << name << " relit ΔE94 mean " << s["mean"] << " median " << s["median"] << " p95 " << s["p95"] << "\n";
    EXPECT_LT(s["median"].get<double>(), 2.0) << name;
    EXPECT_GT(s["pixels"].get<int>(), kSceneSize * kSceneSize / 2) << name;
    EXPECT_DOUBLE_EQ(streamed.results["relit_delta_e94"][name]["mean"].get<double>(), s["mean"].get<double>());
  }
  std::cout << "summary: " << summary["flag_counts"].dump() << " " << summary["timings_s"].dump() << "\n";
}

TEST_F(Fixture, RecoveredMapsMatchTheScenesTruth) {
  const auto maps = files::read_exr(streamed.folder / "results" / "maps.exr");
  ASSERT_EQ(maps.width, kSceneSize);
  RenderedLab lab;  // the same seeded scene
  const auto& regions = lab.skin.regions();
  // Skin pixels away from other regions (the sensor's bilinear resampling mixes borders).
  cv::Mat skin = regions == static_cast<int>(SceneRegion::kSkin);
  cv::erode(skin, skin, cv::Mat(), cv::Point(-1, -1), 2);
  std::vector<double> cm_error, ch_error, bm_error;
  std::vector<estimation::SkinParameters> truth, estimate;
  std::size_t skin_pixels = 0, skin_flagged = 0, ink = 0, ink_flagged = 0;
  const auto &cm = maps.channel("Cm"), &ch = maps.channel("Ch"), &bm = maps.channel("Bm"), &flags = maps.channel("flags");
  for (int y = 0; y < kSceneSize; ++y)
    for (int x = 0; x < kSceneSize; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * kSceneSize + x;
      const auto region = static_cast<SceneRegion>(regions.at<std::uint8_t>(y, x));
      if (region == SceneRegion::kMarker || region == SceneRegion::kTattoo) ink++, ink_flagged += flags[i] != 0;
      if (!skin.at<std::uint8_t>(y, x)) continue;
      ++skin_pixels;
      if (flags[i] != 0) {
        ++skin_flagged;
        continue;
      }
      cm_error.push_back(std::abs(std::log10(cm[i] / lab.skin.cm().at<float>(y, x))));
      ch_error.push_back(std::abs(std::log10(ch[i] / lab.skin.ch().at<float>(y, x))));
      bm_error.push_back(std::abs(bm[i] - lab.skin.bm().at<float>(y, x)));
      truth.push_back({lab.skin.cm().at<float>(y, x), lab.skin.ch().at<float>(y, x), lab.skin.bm().at<float>(y, x),
                       lab.skin.che().at<float>(y, x)});
      estimate.push_back({cm[i], ch[i], bm[i], maps.channel("Che")[i]});
    }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  ASSERT_GT(skin_pixels, 1000u);
  const double flagged_share = static_cast<double>(skin_flagged) / skin_pixels;
  std::cout << "skin pixels " << skin_pixels << ", flagged " << flagged_share << "; median |Δlog10 Cm| "
            << median(cm_error) << ", |Δlog10 Ch| " << median(ch_error) << ", |ΔβM| " << median(bm_error)
            << "; tattoo+marker flagged " << ink_flagged << "/" << ink << "\n";
  // Relit under D65 against the truth's albedo: what the maps are for.
  const auto relit = maps::delta_e_stats(
      maps::relit_delta_e94(truth, estimate, spectral::illuminant_d65(), 1));
  std::cout << "relit ΔE94 under D65 against the truth: mean " << relit.mean << ", median " << relit.median
            << ", p95 " << relit.p95 << "\n";
  EXPECT_LT(median(cm_error), 0.05);  // Cm within 12% (median) through one noisy frame per capture
  EXPECT_LT(median(bm_error), 0.06);
  // Ch trades against Che with four channels (docs/estimation.md: mean |Δlog10 Ch| 0.77 on noisy synthetic
  // frames); the relit colour is what is pinned.
  EXPECT_LT(median(ch_error), 0.5);
  EXPECT_LT(relit.median, 1.0);
  // Issue 37: with the noise model measured right (docs/estimation.md "The
  // noise model"; it had overstated the blue-only channel's variance 4×) the
  // per-pixel χ² flags 2.9% of this scene's skin (code 6). The flagged pixels
  // sit where the truth's ln Cm changes twice as fast as on the explained ones
  // (mean 3×3 gradient 0.150 against 0.075): the 96-px scene is upsampled 2×
  // bilinearly onto the Bayer sensor, so a cell's R and B sites see different
  // mixtures of neighbouring skin, a chain misfit the estimator does not model
  // (the 5-MP lab, one scene pixel per site: 0.08-0.19%, noise_model_bench).
  EXPECT_LT(flagged_share, 0.04);
  EXPECT_GT(ink_flagged, ink * 8 / 10);
}

TEST_F(Fixture, EstimatorBehindIsCountedAndCatchesUpFromStorageWithTheSameMaps) {
  ASSERT_EQ(behind.results.value("state", ""), "available") << behind.results.dump();
  EXPECT_EQ(behind.counters.stored, 7u);  // storage never waited or dropped
  EXPECT_EQ(behind.counters.estimator_skipped, 7u);
  EXPECT_EQ(behind.counters.skipped_reasons.at("queue_full"), 7u);
  EXPECT_EQ(behind.behind_reports, std::vector<std::uint64_t>{1});  // one report per run of skipped frames
  EXPECT_EQ(behind.results["frames_read_back"], 7);
  const auto a = files::read_exr(streamed.folder / "results" / "maps.exr");
  const auto b = files::read_exr(behind.folder / "results" / "maps.exr");
  ASSERT_EQ(a.channel_names, b.channel_names);
  for (std::size_t c = 0; c < a.channels.size(); ++c) EXPECT_EQ(a.channels[c], b.channels[c]) << a.channel_names[c];
}

TEST_F(Fixture, GetResultsAfterARestartComesFromTheSessionFolder) {
  DaemonConfig config;
  config.sessions_dir = directory / "sessions";
  config.estimation.enabled = false;
  Daemon restarted(config, DeviceSet{});
  auto info = restarted.session(streamed.id);
  ASSERT_TRUE(info);
  chromosphere::v1::Results results;
  results_to_proto(*info, &results);
  ASSERT_EQ(results.state(), chromosphere::v1::RESULTS_STATE_AVAILABLE) << results.reason();
  EXPECT_EQ(fs::path(results.maps_file()), fs::absolute(streamed.folder / "results/maps.exr"));
  EXPECT_TRUE(fs::exists(results.report_file()));
  EXPECT_EQ(results.summary().method(), "fast");
  EXPECT_EQ(results.summary().pixels(), static_cast<std::uint64_t>(kSceneSize * kSceneSize));
  EXPECT_GT(results.summary().pixels_per_second(), 0);
  std::uint64_t flag_total = 0;
  for (const auto& [name, count] : results.summary().flag_counts()) flag_total += count;
  EXPECT_EQ(results.summary().flag_counts().size(), static_cast<std::size_t>(estimation::kPixelFlagCount));
  EXPECT_EQ(flag_total, results.summary().pixels());
  EXPECT_EQ(results.summary().relit_delta_e94().size(), 3);
  // An unpolarised session: highlights are the estimator's specular flag.
  EXPECT_EQ(results.summary().highlight_detection(), "heuristic");
  EXPECT_EQ(results.summary().highlight_pixels(), results.summary().flag_counts().at("specular"));
  EXPECT_GT(results.summary().relit_delta_e94().at("D65'").mean(), 0);
}

TEST_F(Fixture, OfflineEstimateOfTheSessionFolderEqualsTheDaemonsMaps) {
  const fs::path out = directory / "offline";
  auto result = run_chromo("estimate " + streamed.folder.string() + " --out " + out.string() + " --cache-dir " +
                           cache_dir().string() + " --threads 2");
  ASSERT_EQ(result.exit_status, 0) << result.output;
  EXPECT_NE(result.output.find("relit ΔE94 against the photograph under D65'"), std::string::npos) << result.output;
  const auto daemon_maps = files::read_exr(streamed.folder / "results" / "maps.exr");
  const auto offline_maps = files::read_exr(out / "maps.exr");
  ASSERT_EQ(daemon_maps.channel_names, offline_maps.channel_names);
  for (std::size_t c = 0; c < daemon_maps.channels.size(); ++c)
    EXPECT_EQ(daemon_maps.channels[c], offline_maps.channels[c]) << daemon_maps.channel_names[c];
  std::ifstream in(out / "summary.json");
  const auto summary = nlohmann::json::parse(in);
  EXPECT_EQ(summary["flag_counts"], streamed.results["flag_counts"]);
  // The daemon estimated with the tables it prepared from the references,
  // kept in memory; the offline run loaded them from the disk cache.
  std::ifstream daemon_in(streamed.folder / "results" / "summary.json");
  const auto daemon_summary = nlohmann::json::parse(daemon_in);
  EXPECT_EQ(daemon_summary["table"]["tables_in_memory"], true);
  EXPECT_EQ(daemon_summary["timings_s"]["table"], 0.0);
  EXPECT_EQ(summary["table"]["tables_in_memory"], false);
  EXPECT_EQ(summary["table"]["key"], daemon_summary["table"]["key"]);
}

TEST_F(Fixture, BadSessionFolderIsRefusedNamingTheProblemAndWritesNothing) {
  // A copy of the session without its last subject frame.
  const fs::path broken = directory / "broken";
  fs::copy(streamed.folder, broken, fs::copy_options::recursive);
  fs::remove_all(broken / "results");
  fs::remove_all(broken / "frames" / "subject_w57+blue");
  const fs::path out = directory / "broken-out";
  auto result = run_chromo("estimate " + broken.string() + " --out " + out.string());
  EXPECT_EQ(result.exit_status, 2) << result.output;
  EXPECT_NE(result.output.find("subject_w57+blue"), std::string::npos) << result.output;
  EXPECT_FALSE(fs::exists(out));

  // Not a session at all.
  const fs::path empty = directory / "empty";
  fs::create_directories(empty);
  result = run_chromo("estimate " + empty.string() + " --out " + out.string());
  EXPECT_EQ(result.exit_status, 2) << result.output;
  EXPECT_NE(result.output.find("not a session folder"), std::string::npos) << result.output;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace chromo::daemon
