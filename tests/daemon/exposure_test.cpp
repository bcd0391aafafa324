// Exposure per capture, frames per capture and the blue-light hazard limit
// (issue 20) on the virtual lab: the sequencer meters each white on the
// camera's own frames, every frame records its exposure, N frames divide
// the white's noise by √N as the estimator's noise figure says, and a plan
// beyond the hazard limit is refused before anything is captured.
#include "test_lab.hpp"

#include <array>
#include <cmath>
#include <fstream>

#include "chromo/session/journal.hpp"
#include "chromo/session/method_measurement.hpp"
#include "chromo/session/session_captures.hpp"

namespace chromo::daemon {
namespace {

using testing::TestLab;
using testing::wait_for;

namespace fs = std::filesystem;

constexpr double kFullScale = 4095;

// Mean and noise variance (half the mean squared difference of horizontally
// adjacent sites of the same colour) of one RGGB site of a 16-bit frame, DN.
struct SiteStatistics {
  double mean = 0, variance = 0;
};
SiteStatistics site_statistics(const std::vector<std::vector<double>>& frames, int width, int height, int site) {
  const int dx = site % 2, dy = site / 2;
  double sum = 0, squared = 0;
  std::size_t count = 0, pairs = 0;
  for (int y = dy; y < height; y += 2)
    for (int x = dx; x < width; x += 2) {
      double value = 0, next = 0;
      for (const auto& frame : frames) value += frame[static_cast<std::size_t>(y) * width + x] / frames.size();
      sum += value, ++count;
      if (x + 2 < width) {
        for (const auto& frame : frames) next += frame[static_cast<std::size_t>(y) * width + x + 2] / frames.size();
        squared += (value - next) * (value - next), ++pairs;
      }
    }
  return {sum / static_cast<double>(count), squared / (2.0 * static_cast<double>(pairs))};
}

std::vector<double> samples_of(const fs::path& tiff, int* width, int* height) {
  const auto image = session::read_tiff(tiff);
  *width = image.width, *height = image.height;
  std::vector<double> out(static_cast<std::size_t>(image.width) * image.height);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = image.data[2 * i] | (image.data[2 * i + 1] << 8);
  return out;
}

std::vector<fs::path> frames_of(const session::SessionInfo& info, const std::string& step) {
  std::vector<fs::path> out;
  for (const auto& frame : info.frames)
    if (frame.step == step) out.push_back(fs::path(info.record.folder) / frame.file);
  return out;
}

TEST(ExposurePerCapture, MeteredSessionPutsEachWhiteAtTheTargetShareAndNFramesDivideItsNoise) {
  TestLab lab("exposure-metered");
  auto daemon = lab.daemon();
  constexpr double kShare = 0.7;
  constexpr std::uint32_t kFrames = 3;
  session::StandardPlanOptions options;
  options.exposure_us = 2000;  // the first guess
  options.frames_per_camera = kFrames;
  options.settle_ms = 0;
  options.meter_white_share = kShare;
  options.blue_ratio = 4;
  const session::SessionPlan plan = session::standard_plan(options);
  auto started = daemon->start_session(plan, "forearm");
  auto final = wait_for(*daemon, started.id, [](const session::OperationRecord& r) { return session::is_final(r.state); },
                        std::chrono::seconds(180));
  ASSERT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
  auto info = daemon->session(started.id);
  ASSERT_TRUE(info);

  // Exposures: per illumination, the subject at its white's; W57 at W57+blue's; the dark at the plan's.
  std::map<std::string, double> exposure;
  for (const auto& frame : info->frames) {
    if (exposure.count(frame.step)) EXPECT_EQ(exposure[frame.step], frame.exposure_us) << frame.step;
    exposure[frame.step] = frame.exposure_us;
  }
  EXPECT_EQ(exposure["dark"], 2000.0);
  EXPECT_EQ(exposure["subject_d65"], exposure["white_d65"]);
  EXPECT_EQ(exposure["white_w57"], exposure["white_w57+blue"]);
  EXPECT_EQ(exposure["subject_w57"], exposure["white_w57+blue"]);
  EXPECT_EQ(exposure["subject_w57+blue"], exposure["white_w57+blue"]);
  EXPECT_NE(exposure["white_d65"], exposure["white_w57+blue"]);

  // The white's brightest channel (Bayer sites R, G, B) at the target share, measured on the stored frames.
  int width = 0, height = 0;
  for (const char* step : {"white_d65", "white_w57+blue"}) {
    std::vector<std::vector<double>> frames;
    for (const auto& file : frames_of(*info, step)) frames.push_back(samples_of(file, &width, &height));
    ASSERT_EQ(frames.size(), kFrames);
    double brightest = 0;
    for (int site : {0, 1, 3}) brightest = std::max(brightest, site_statistics(frames, width, height, site).mean);
    EXPECT_NEAR(brightest / kFullScale, kShare, 0.05 * kShare) << step << " at " << exposure[step] << " us";
  }

  // The journal says how each white was metered.
  const auto journal = session::read_journal(fs::path(final.folder) / "journal.jsonl");
  int metered = 0;
  for (const auto& record : journal.records)
    if (record.value("type", "") == "exposure_metered") {
      ++metered;
      EXPECT_EQ(record.value("exposure_us", 0.0), exposure[record.value("step", "")]);
      EXPECT_NEAR(record.value("white_share", 0.0), kShare, 0.1 * kShare);
      EXPECT_FALSE(record.value("at_limit", true));
    }
  EXPECT_EQ(metered, 2);

  // N frames: the white's noise variance (R sites, one per binned cell) of the
  // N-frame mean is 1/N of one frame's, and the estimator's noise figure for
  // D65'.R on the white is that of the mean: σ²(ρ) ≈ 2·v₁/(N·W²).
  std::vector<std::vector<double>> white, dark;
  for (const auto& file : frames_of(*info, "white_d65")) white.push_back(samples_of(file, &width, &height));
  for (const auto& file : frames_of(*info, "dark")) dark.push_back(samples_of(file, &width, &height));
  const SiteStatistics one = site_statistics({white[0]}, width, height, 0);
  const SiteStatistics mean = site_statistics(white, width, height, 0);
  EXPECT_NEAR(mean.variance / one.variance, 1.0 / kFrames, 0.25 / kFrames);
  ASSERT_EQ(info->results.value("state", ""), "available") << info->results.dump();
  std::ifstream in(fs::path(final.folder) / "results" / "summary.json");
  const auto summary = nlohmann::json::parse(in);
  const auto& noise = summary.at("noise").at("D65'.R");
  const double W = (mean.mean - site_statistics(dark, width, height, 0).mean) / kFullScale;
  const double rho = lab.config.estimation.white_reflectance;
  const double model = noise.at("read_sigma").get<double>() * noise.at("read_sigma").get<double>() +
                       noise.at("shot_coefficient").get<double>() * rho;
  const double from_frames = 2.0 * (one.variance / (kFullScale * kFullScale)) / (kFrames * W * W);
  EXPECT_NEAR(model / from_frames, 1.0, 0.25) << "model " << model << " frames " << from_frames;

  // summary.json: each channel's SNR on the white and on the skin, and every capture's exposure.
  for (const char* channel : {"D65'.R", "D65'.G", "D65'.B", "blue.B"}) {
    const auto& snr = summary.at("snr").at(channel);
    EXPECT_GT(snr.at("white").get<double>(), 10.0) << channel;
    EXPECT_GT(snr.at("skin").get<double>(), 2.0) << channel;  // skin is darkest in blue
    EXPECT_LT(snr.at("skin").get<double>(), snr.at("white").get<double>()) << channel;
  }
  bool found = false;
  for (const auto& capture : summary.at("captures"))
    if (capture.at("capture") == "subject D65'") {
      found = true;
      EXPECT_EQ(capture.at("exposure_us").get<double>(), exposure["subject_d65"]);
      EXPECT_EQ(capture.at("frames").get<std::uint32_t>(), kFrames);
    }
  EXPECT_TRUE(found) << summary.at("captures").dump();

  // summary.json: the blue-light dose with the metered exposures (the
  // journal's last hazard record), which depends on them.
  const auto& hazard = summary.at("blue_light_hazard");
  EXPECT_EQ(hazard.at("exposures"), "metered");
  EXPECT_EQ(hazard.at("plan"), "standard");
  EXPECT_GT(hazard.at("dose_J_per_m2_sr").get<double>(), 0.0);
  EXPECT_TRUE(hazard.at("within_limit").get<bool>());
  EXPECT_EQ(hazard.at("steps").size(), 3u);
  for (const auto& step : hazard.at("steps")) {
    const std::string name = step.at("step");
    EXPECT_NEAR(step.at("lit_s").get<double>(),
                (exposure[name] / 1e6 + lab.config.hazard.frame_allowance_ms / 1e3) * kFrames, 1e-9)  // settle 0
        << name;
  }
}

TEST(BlueLightHazard, PlanBeyondTheLimitIsRefusedAndNothingIsCaptured) {
  TestLab lab("exposure-hazard");
  auto daemon = lab.daemon();
  const session::SessionPlan plan = testing::quick_standard_plan();
  const session::PlanHazard hazard = daemon->plan_hazard(plan);
  ASSERT_GT(hazard.dose_J_per_m2_sr, 0.0);
  EXPECT_TRUE(hazard.within_limit());  // the exempt-group limit, 10^6 J/(m2 sr)
  EXPECT_EQ(hazard.steps.size(), 3u);  // the subject steps

  lab.config.hazard.limit_J_per_m2_sr = hazard.dose_J_per_m2_sr / 2;
  daemon.reset();
  daemon = lab.daemon();
  try {
    daemon->start_session(plan, "forearm");
    FAIL() << "a plan beyond the hazard limit was started";
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("plan \"standard\""), std::string::npos) << message;
    EXPECT_NE(message.find("beyond the limit"), std::string::npos) << message;
    EXPECT_NE(message.find("J/(m2 sr)"), std::string::npos) << message;
  }
  EXPECT_TRUE(daemon->operations().list().empty());
  EXPECT_FALSE(fs::exists(lab.config.sessions_dir) && !fs::is_empty(lab.config.sessions_dir) &&
               std::any_of(fs::directory_iterator(lab.config.sessions_dir), fs::directory_iterator(),
                           [](const fs::directory_entry& e) { return fs::exists(e.path() / "journal.jsonl"); }));
  EXPECT_DOUBLE_EQ(lab.emitted()[0], 0.0);  // the LEDs never lit
}


namespace subject_metering {

// One standard session on the lab; its stored frames through `chromo
// estimate`'s path (read_session_captures, build_method_measurement).
struct MeteredRun {
  std::map<std::string, double> exposure;  // per step, from the frame records
  session::MethodMeasurement measurement;
  std::vector<nlohmann::json> subject_metered;  // the journal's records
};

MeteredRun run_standard(Daemon& daemon, double subject_fill) {
  session::StandardPlanOptions options = daemon.standard_plan_options();
  options.exposure_us = 2000;  // the first guess
  options.settle_ms = 0;
  options.meter_white_share = 0.7;
  options.blue_ratio = 4;
  options.reference_frames = 4;
  options.subject_fill = subject_fill;
  const session::SessionPlan plan = session::standard_plan(options);
  auto started = daemon.start_session(plan, "forearm");
  auto final = wait_for(daemon, started.id, [](const session::OperationRecord& r) { return session::is_final(r.state); },
                        std::chrono::seconds(180));
  EXPECT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
  MeteredRun run;
  auto info = daemon.session(started.id);
  if (!info) return run;
  for (const auto& frame : info->frames) run.exposure[frame.step] = frame.exposure_us;
  for (const auto& record : session::read_journal(fs::path(final.folder) / "journal.jsonl").records)
    if (record.value("type", "") == "subject_metered") run.subject_metered.push_back(record);
  const auto sources = session::resolve_capture_sources((fs::path(final.folder) / "results" / "led_library.json").string(),
                                                        "builtin:nikon_d5100", 0.99);
  run.measurement = session::build_method_measurement(session::read_session_captures(final.folder, sources));
  return run;
}

}  // namespace subject_metering

// Subject exposure metering on the live path (capture.subject_fill): the
// sequencer meters each subject on one frame at its white's exposure, the
// frames record the longer exposure, W57 takes W57+blue's ratio, and the
// albedo of the cells that clip in neither session agrees with the session
// whose subjects are at their whites' exposures.
TEST(ExposurePerCapture, SubjectMeteringTakesTheSubjectLongerAndKeepsItsAlbedo) {
  TestLab lab("subject-metered");
  auto daemon = lab.daemon();
  const subject_metering::MeteredRun one = subject_metering::run_standard(*daemon, 0);
  const subject_metering::MeteredRun metered = subject_metering::run_standard(*daemon, 0.85);
  ASSERT_EQ(metered.subject_metered.size(), 2u);  // D65' and W57+blue; W57 takes W57+blue's
  const double g_d65 = metered.exposure.at("subject_d65") / metered.exposure.at("white_d65");
  const double g_blue = metered.exposure.at("subject_w57+blue") / metered.exposure.at("white_w57+blue");
  std::printf("g d65 %.4f, w57+blue %.4f, w57 %.4f\n", g_d65, g_blue,
              metered.exposure.at("subject_w57") / metered.exposure.at("white_w57"));
  for (const auto& r : metered.subject_metered) std::printf("%s\n", r.dump().c_str());
  EXPECT_NEAR(one.exposure.at("subject_d65"), one.exposure.at("white_d65"), 1e-9);
  EXPECT_NEAR(metered.exposure.at("subject_w57") / metered.exposure.at("white_w57"), g_blue, 1e-9);
  for (const auto& r : metered.subject_metered)
    EXPECT_NEAR(r.value("exposure_us", 0.0), metered.exposure.at(r.value("step", "")), 1e-6) << r.dump();
  const auto& a = one.measurement;
  const auto& b = metered.measurement;
  ASSERT_EQ(a.measured.size(), b.measured.size());
  std::array<double, 4> sum_a{}, sum_b{};
  std::size_t cells = 0;
  for (std::size_t i = 0; i < a.measured.size() / 4; ++i) {
    bool usable = true;
    for (int c = 0; c < 4; ++c)
      usable = usable && std::isfinite(a.measured[i * 4 + c]) && std::isfinite(b.measured[i * 4 + c]) &&
               a.measured[i * 4 + c] < 0.9 * a.set.channels[c].noise.saturation_albedo &&
               b.measured[i * 4 + c] < 0.9 * b.set.channels[c].noise.saturation_albedo;
    if (!usable) continue;
    ++cells;
    for (int c = 0; c < 4; ++c) sum_a[c] += a.measured[i * 4 + c], sum_b[c] += b.measured[i * 4 + c];
  }
  std::printf("cells %zu of %zu; saturated %zu vs %zu\n", cells, a.measured.size() / 4, a.saturated_pixels,
              b.saturated_pixels);
  for (int c = 0; c < 4; ++c) std::printf("channel %d: %.5f vs %.5f\n", c, sum_a[c] / cells, sum_b[c] / cells);
}

}  // namespace
}  // namespace chromo::daemon
