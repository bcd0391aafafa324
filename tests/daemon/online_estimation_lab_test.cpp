// The on-line estimator inside a Daemon on the virtual lab (the protocol
// simulators behind the real drivers: Modbus TCP LED controller, GigE Vision
// camera on loopback, USB2000+): a calibration run measures the LED library
// and solves the mixes, the standard session captures the skin scene, and
// the session ends with maps, the report and the results record; the maps
// are compared with the scene's truth.
#include <cmath>
#include <fstream>

#include "chromo/daemon/internal/api/api_conversions.hpp"
#include "chromo/estimation/pixel_flags.hpp"
#include "chromosphere/v1/estimation.pb.h"
#include "lab_truth.hpp"
#include "test_lab.hpp"

namespace chromo::daemon {
namespace {

namespace fs = std::filesystem;
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

  // Each lit capture waits five of the LEDs' thermal time constants after its
  // mix is applied (1 s of wall clock at the lab's 300x), so the white and
  // the subject of a mix are taken at that mix's settled junction
  // temperatures. Without it (settle 0) they were taken in the warm-up from
  // the previous mix, at junction temperatures set by the session's
  // wall-clock timing: 1 ms of delay is 0.3 s of LED time, so the load
  // decided how far the blue LED had warmed between its white and its
  // subject (5.6-9.4 K over runs at load 9-12); the per-frame thermal model
  // corrects that to first order only, and skin flagged went 1.08-2.35%
  // (13 runs) against 1.20% (exactly, every run) with the LEDs not
  // drifting. Settled: 0.91-1.21% (9 runs, load 13-14.5; tests/README.md
  // "Flaky tests").
  session::SessionPlan plan = testing::quick_standard_plan(1, kExposureUs);
  const double thermal_time_constant_wall_ms =
      simulators::LedLabOptions{}.thermal_time_constant_s * 1000.0 / lab.lab_options.led_time_scale;
  for (session::Step& step : plan.steps)
    if (step.role != session::StepRole::kDark)
      step.settle_ms = static_cast<std::uint32_t>(std::ceil(5 * thermal_time_constant_wall_ms));
  auto started = daemon->start_session(plan, "forearm");
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
  const testing::MapsAgainstTruth against = testing::maps_against_truth(folder / "results" / "maps.exr", lab.lab_options);
  ASSERT_EQ(against.width, 160);
  ASSERT_EQ(against.height, 120);
  const std::size_t skin_pixels = against.skin_pixels, flagged = against.flagged;
  const maps::DeltaEStats& relit = against.relit;
  ASSERT_GT(skin_pixels, 5000u);
  std::cout << "virtual lab session: skin " << skin_pixels << ", flagged " << flagged << "; relit ΔE94 (D65) vs truth mean "
            << relit.mean << " median " << relit.median << " p95 " << relit.p95 << "; estimate "
            << summary["timings_s"]["estimate"] << " s, " << summary["pixels_per_second"] << " pixels/s\n";
  // 1.5% since the noise model's fix (e37c201; 1.22-1.27% measured after
  // it, under 1% before). Not the blue LED's junction temperature, as first
  // supposed (checked in issue 37, docs/estimation.md "The noise model"):
  // with the lab's LEDs not drifting (led_thermal_drift false) seeds 1-3
  // flag 1.07%, 1.41%, 1.44% of skin, against 0.88-1.32%, 1.49-2.14%, 1.34%
  // with drift in captures taken unsettled (which varied from run to run
  // with the LEDs' timing: the settling above removes that). 70-85%
  // of the flagged skin is the spatial pass's neighbourhood flag (code 7),
  // 2.5-3.6% of the skin 3-4 map pixels from a scene region against
  // 0.5-0.8% of it 8 or more away: skin beside the scene's anomalies
  // (whether the fix alone moved them over 1% was not measured).
  EXPECT_LT(static_cast<double>(flagged) / skin_pixels, 0.015);
  EXPECT_LT(relit.median, 1.3);
  // The scene's white target strip is not skin: flagged white_target (no
  // parameters), not unexplained_colour as before (issue 42).
  std::cout << "white strip: " << against.white_target_pixels << " pixels, by flag:";
  for (const auto& [code, count] : against.white_target_by_flag) std::cout << " " << code << ": " << count;
  std::cout << "\n";
  const auto strip_flagged = [&](estimation::PixelFlag flag) {
    const auto found = against.white_target_by_flag.find(static_cast<int>(flag));
    return found == against.white_target_by_flag.end() ? std::size_t{0} : found->second;
  };
  ASSERT_GT(against.white_target_pixels, 500u);
  EXPECT_GE(static_cast<double>(strip_flagged(estimation::PixelFlag::kWhiteTarget)),
            0.99 * static_cast<double>(against.white_target_pixels));
  EXPECT_EQ(strip_flagged(estimation::PixelFlag::kUnexplainedColour), 0u);
  EXPECT_EQ(summary["flag_counts"]["white_target"].get<std::size_t>(),
            static_cast<std::size_t>(results.summary().flag_counts().at("white_target")));

  // Too long an exposure clips the white reference: no maps, and the record
  // says why (whatever the LEDs' temperatures: no settling needed).
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
