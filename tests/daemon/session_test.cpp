// Sessions end to end inside one process: Daemon + sequencer + pipeline +
// storage on the virtual lab (LED controller simulator over Modbus TCP,
// GigE Vision camera simulator through Aravis), with the simulators' faults.
#include "test_lab.hpp"

#include <cstring>

#include "../support/fresh_directory.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/session/derived_data.hpp"
#include "chromo/session/session_captures.hpp"

namespace chromo::daemon {
namespace {

using testing::bayer_site_mean;
using testing::quick_standard_plan;
using testing::TestLab;
using testing::wait_final;
using testing::wait_for;

constexpr int kRed = 0, kGreen = 1, kBlue = 3;  // RGGB sites

// The frame file of the n-th stored frame of a step.
std::filesystem::path frame_of(const session::SessionInfo& info, const std::string& step, std::size_t n = 0) {
  for (const auto& frame : info.frames)
    if (frame.step == step && n-- == 0) return std::filesystem::path(info.record.folder) / frame.file;
  ADD_FAILURE() << "no frame of step " << step;
  return {};
}

TEST(Session, StandardSessionStoresEveryFrameWithMetadataAndDerivedData) {
  TestLab lab("standard");
  auto daemon = lab.daemon();
  auto started = daemon->start_session(quick_standard_plan(2), "forearm");
  auto final = wait_final(*daemon, started.id);
  ASSERT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
  EXPECT_EQ(final.counters.stored, 14u);
  EXPECT_EQ(final.counters.estimated, 14u);  // consumed by the on-line estimator
  EXPECT_DOUBLE_EQ(final.progress, 1.0);

  auto info = daemon->session(started.id);
  ASSERT_TRUE(info);
  EXPECT_EQ(info->subject, "forearm");
  ASSERT_EQ(info->frames.size(), 14u);
  for (const auto& step : info->steps) EXPECT_TRUE(step.completed) << step.name;
  // Every frame: the camera simulator's sensor at its native 12 bits in 16-bit samples.
  for (const auto& frame : info->frames) {
    auto image = session::read_tiff(std::filesystem::path(final.folder) / frame.file);
    EXPECT_EQ(image.width, 160);
    EXPECT_EQ(image.height, 120);
    EXPECT_EQ(image.bits_per_sample, 16);
    EXPECT_EQ(frame.pixel_format, drivers::PixelFormat::kBayerRG12);
    EXPECT_GT(frame.camera_timestamp_ns, 0u);
    ASSERT_TRUE(frame.led);
    EXPECT_GT(frame.led->temperature_C[0], 0.0);  // the controller's reading
    EXPECT_DOUBLE_EQ(frame.exposure_us, 2000.0);
  }
  // The controller applied the configured mix (read back over Modbus).
  const auto& last = info->frames.back();
  EXPECT_EQ(last.step, "subject_w57+blue");
  EXPECT_EQ(last.role, session::StepRole::kSubject);
  ASSERT_TRUE(last.led);
  EXPECT_NEAR(last.led->drive[5], lab.config.mixes["w57+blue"][5], 1e-3);
  // What the camera saw: black in the dark; the white target (rho 0.99) is
  // brighter than the skin under the same light (the scene was switched for
  // each step); the blue LED raises the blue sites, not the red ones.
  const double dark = bayer_site_mean(frame_of(*info, "dark"), kGreen);
  const double white_d65 = bayer_site_mean(frame_of(*info, "white_d65"), kGreen);
  const double skin_d65 = bayer_site_mean(frame_of(*info, "subject_d65"), kGreen);
  EXPECT_LT(dark, 40.0);  // black level 16 DN plus read noise
  EXPECT_GT(white_d65, dark + 200.0);
  EXPECT_GT(white_d65, 1.3 * skin_d65);
  EXPECT_GT(skin_d65, dark + 20.0);
  const auto white_w57 = frame_of(*info, "white_w57"), white_blue = frame_of(*info, "white_w57+blue");
  const double blue_gain = bayer_site_mean(white_blue, kBlue) / bayer_site_mean(white_w57, kBlue);
  const double red_gain = bayer_site_mean(white_blue, kRed) / bayer_site_mean(white_w57, kRed);
  EXPECT_GT(blue_gain, 1.04);
  EXPECT_NEAR(red_gain, 1.0, 0.02);
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(final.folder) / "derived/albedo-d65-cam0.exr"));
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(final.folder) / "derived/dark-cam0-mean.exr"));

  // Derived data written live (from the sums the pipeline filled as frames
  // were stored) equals a re-processing of the stored frames from disk.
  namespace fs = std::filesystem;
  const fs::path copy = testing::fresh_directory("session-derived-reprocessed");
  fs::copy(final.folder, copy, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
  fs::remove_all(copy / "derived");
  double white_reflectance = 0;
  for (const auto& record : session::read_journal(copy / "journal.jsonl").records)
    if (record.value("kind", "") == "albedo") white_reflectance = record.at("white_reflectance").get<double>();
  ASSERT_GT(white_reflectance, 0);
  session::SessionFrameSums sums;
  EXPECT_EQ(session::add_stored_frames(sums, copy), 14u);
  {
    session::Journal journal(copy / "journal.jsonl", nullptr);
    session::write_derived_data(copy, session::read_session_plan(copy), sums, white_reflectance, journal, nullptr);
  }
  int compared = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(final.folder) / "derived")) {
    const auto live = files::read_exr(entry.path());
    const auto again = files::read_exr(copy / "derived" / entry.path().filename());
    ASSERT_EQ(live.channel_names, again.channel_names) << entry.path();
    for (std::size_t c = 0; c < live.channels.size(); ++c)
      EXPECT_EQ(std::memcmp(live.channels[c].data(), again.channels[c].data(), live.channels[c].size() * sizeof(float)), 0)
          << entry.path();
    ++compared;
  }
  EXPECT_EQ(compared, 7 + 3);  // a mean per step, an albedo per mix (one camera)
}

TEST(Session, HardwareTimedSequenceAdvancesOnTheControllersOwnTriggerPulse) {
  TestLab lab("hardware");
  auto daemon = lab.daemon();
  auto plan = quick_standard_plan(2);
  plan.timing = session::Timing::kHardware;
  const int triggers_before = lab.simulators->leds().trigger_count();
  const std::uint32_t pulses_before = lab.simulators->leds().trigger_pulses();
  auto started = daemon->start_session(plan, "");
  auto final = wait_final(*daemon, started.id);
  ASSERT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
  auto info = daemon->session(started.id);
  ASSERT_EQ(info->frames.size(), 14u);
  // The controller fired one pulse per frame on its output (the camera's
  // Line0; the sequence advanced on it), and every exposure was an edge on
  // its trigger input ...
  EXPECT_EQ(lab.simulators->leds().trigger_pulses() - pulses_before, 14u);
  EXPECT_EQ(lab.simulators->leds().trigger_count() - triggers_before, 14);
  for (const auto& frame : info->frames) EXPECT_GT(frame.trigger_id, pulses_before);
  // ... and frame k shows state k: dark frames are black, the second frame
  // of each lit step too shows its own step's light (not the next one's).
  EXPECT_LT(bayer_site_mean(frame_of(*info, "dark", 1), kGreen), 40.0);
  EXPECT_GT(bayer_site_mean(frame_of(*info, "white_d65", 0), kGreen), 200.0);
  const double w57_blue = bayer_site_mean(frame_of(*info, "white_w57", 1), kBlue);
  const double w57_plus_blue_blue = bayer_site_mean(frame_of(*info, "white_w57+blue", 0), kBlue);
  EXPECT_GT(w57_plus_blue_blue, 1.04 * w57_blue);
  EXPECT_EQ(lab.simulators->leds().status().sequence_position, -1);  // disarmed at the end
  // A sequence longer than the controller holds is refused before anything runs.
  auto long_plan = quick_standard_plan(10);
  long_plan.timing = session::Timing::kHardware;
  try {
    daemon->start_session(long_plan, "");
    FAIL() << "accepted 71 states for a 64-state controller";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("plan.timing: hardware timing needs 71 sequence states"), std::string::npos)
        << error.what();
  }
}

TEST(Session, CancelInTheMiddleKeepsStoredFramesAndEndsCancelled) {
  TestLab lab("cancel");
  auto daemon = lab.daemon();
  auto started = daemon->start_session(quick_standard_plan(20), "");
  wait_for(*daemon, started.id, [](const session::OperationRecord& r) { return r.counters.stored >= 5; });
  daemon->operations().control(started.id)->request_cancel();
  auto final = wait_final(*daemon, started.id);
  EXPECT_EQ(final.state, session::OperationState::kCancelled);
  EXPECT_LT(final.counters.stored, 140u);
  auto info = daemon->session(started.id);
  EXPECT_EQ(info->record.state, session::OperationState::kCancelled);
  EXPECT_EQ(info->frames.size(), final.counters.stored);
  EXPECT_FALSE(info->steps.back().completed);
  EXPECT_EQ(lab.emitted(), drivers::DriveLevels{});  // the simulator's LEDs dark after the cancel
  // A new session may start once the first ended.
  auto second = daemon->start_session(quick_standard_plan(), "");
  EXPECT_EQ(wait_final(*daemon, second.id).state, session::OperationState::kSucceeded);
}

TEST(Session, SecondSessionWhileOneRunsIsRefused) {
  TestLab lab("busy");
  auto daemon = lab.daemon();
  auto started = daemon->start_session(quick_standard_plan(10), "");
  EXPECT_THROW(daemon->start_session(quick_standard_plan(), ""), std::logic_error);
  daemon->operations().control(started.id)->request_cancel();
  wait_final(*daemon, started.id);
}

TEST(Session, PauseFinishesTheStepAndResumeContinues) {
  TestLab lab("pause");
  auto daemon = lab.daemon();
  auto started = daemon->start_session(quick_standard_plan(3), "");
  daemon->operations().control(started.id)->request_pause();
  auto paused = wait_for(*daemon, started.id, [](const session::OperationRecord& r) { return r.state == session::OperationState::kPaused; });
  ASSERT_EQ(paused.state, session::OperationState::kPaused);
  auto stored = paused.counters.stored;
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(daemon->operations().get(started.id)->counters.stored, stored);  // nothing taken while paused
  daemon->operations().control(started.id)->request_resume();
  auto final = wait_final(*daemon, started.id);
  EXPECT_EQ(final.state, session::OperationState::kSucceeded);
  EXPECT_EQ(final.counters.stored, 21u);
}

TEST(Session, LedControllerThatStopsAnsweringPausesWithAClearStatus) {
  TestLab lab("led-silent");
  auto daemon = lab.daemon();
  // The simulator's firmware stops answering Modbus requests: the driver
  // times out (300 ms) and the session pauses instead of hanging.
  lab.simulators->leds().set_unresponsive(true);
  auto started = daemon->start_session(quick_standard_plan(), "");
  auto paused = wait_for(*daemon, started.id, [](const session::OperationRecord& r) { return r.state == session::OperationState::kPaused; },
                         std::chrono::seconds(10));
  ASSERT_EQ(paused.state, session::OperationState::kPaused);
  EXPECT_NE(paused.message.find("LED controller \"sphere\" stopped answering"), std::string::npos) << paused.message;
  EXPECT_EQ(paused.counters.stored, 0u);
  lab.simulators->leds().set_unresponsive(false);
  daemon->operations().control(started.id)->request_resume();
  auto final = wait_final(*daemon, started.id);
  EXPECT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
  EXPECT_EQ(final.counters.stored, 7u);
}

TEST(Session, CameraPacketLossIsCountedWithItsReasonAndRetaken) {
  TestLab lab("loss");
  lab.config.frame_attempts = 30;  // at this loss most frames need several triggers
  auto daemon = lab.daemon();
  // ~28 GVSP packets per 160x120x16-bit frame: 2% loss spoils about 40% of
  // the frames when the camera ignores resend requests (as one without a
  // resend buffer does).
  simulators::GvspFaultOptions faults;
  faults.loss_probability = 0.02;
  faults.answer_resend_requests = false;
  lab.simulators->camera().set_faults(faults);
  auto started = daemon->start_session(quick_standard_plan(2), "");
  auto final = wait_final(*daemon, started.id);
  ASSERT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
  EXPECT_EQ(final.counters.stored, 14u);  // every wanted frame, retaken
  EXPECT_GE(final.counters.lost, 2u);
  // Each lost frame with its reason: Aravis completes a frame whose packets
  // are still missing after the retention time as TIMEOUT (or
  // MISSING_PACKETS once its resends are exhausted).
  std::uint64_t by_reason = 0;
  for (const auto& [reason, count] : final.counters.lost_reasons) {
    EXPECT_TRUE(reason == "timeout" || reason == "missing_packets") << reason;
    by_reason += count;
  }
  EXPECT_EQ(by_reason, final.counters.lost);
  // Aravis asked for the lost packets again; this camera ignored the requests.
  EXPECT_GT(testing::aravis(*daemon).statistics().missing_packets, 0u);
  EXPECT_GT(lab.simulators->camera().device_counters().resend_requests, 0u);
  EXPECT_EQ(lab.simulators->camera().device_counters().packets_resent, 0u);
  EXPECT_EQ(final.counters.resent_packets, 0u);
  auto info = daemon->session(started.id);
  EXPECT_EQ(info->record.counters.lost, final.counters.lost);  // the journal says the same
  for (const auto& frame : info->frames)
    EXPECT_EQ(session::read_tiff(std::filesystem::path(final.folder) / frame.file).data.size(), 160u * 120u * 2u);
}

TEST(Session, CameraPacketLossIsRecoveredByResendsCountedOnBothSides) {
  TestLab lab("resend");
  lab.config.frame_attempts = 30;
  auto daemon = lab.daemon();
  lab.simulators->camera().set_packet_loss_ratio(0.05);  // resend requests answered (the default)
  auto started = daemon->start_session(quick_standard_plan(2), "");
  auto final = wait_final(*daemon, started.id);
  ASSERT_EQ(final.state, session::OperationState::kSucceeded) << final.error;
  EXPECT_EQ(final.counters.stored, 14u);
  const auto device = lab.simulators->camera().device_counters();
  EXPECT_GT(device.packets_dropped, 0u);
  EXPECT_GT(device.resend_requests_answered, 0u);
  EXPECT_GT(device.packets_resent, 0u);
  // The session's counters carry the driver's: the resent packets arrived.
  EXPECT_GT(final.counters.resent_packets, 0u);
  EXPECT_LE(final.counters.resent_packets, device.packets_resent);
}

TEST(Session, CameraThatDisappearsPausesAndContinuesWhenItReturns) {
  TestLab lab("camera-gone");
  lab.config.frame_attempts = 2;
  lab.config.frame_timeout_ms = 500;
  auto daemon = lab.daemon();
  auto started = daemon->start_session(quick_standard_plan(4), "");
  wait_for(*daemon, started.id, [](const session::OperationRecord& r) { return r.counters.stored >= 3; });
  auto& camera = testing::aravis(*daemon);
  lab.simulators->camera().power_off();  // control and stream channels gone
  auto paused = wait_for(*daemon, started.id, [](const session::OperationRecord& r) { return r.state == session::OperationState::kPaused; },
                         std::chrono::seconds(20));
  ASSERT_EQ(paused.state, session::OperationState::kPaused);
  EXPECT_NE(paused.message.find("camera \"cam0\""), std::string::npos) << paused.message;
  // The driver's watchdog notices the loss (on a loaded machine possibly
  // only after the session paused on failed triggers).
  for (int i = 0; i < 200 && camera.link_up(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(camera.link_up());
  lab.simulators->camera().power_on();
  // The driver notices the camera is back, reopens it and restores its
  // settings; the operator resumes (again, if a trigger still met the
  // reconnect in progress).
  session::OperationRecord final;
  for (int round = 0; round < 5; ++round) {
    for (int i = 0; i < 200 && !camera.link_up(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    ASSERT_TRUE(camera.link_up());
    daemon->operations().control(started.id)->request_resume();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    final = wait_for(*daemon, started.id, [](const session::OperationRecord& r) {
      return session::is_final(r.state) || r.state == session::OperationState::kPaused;
    });
    if (session::is_final(final.state)) break;
  }
  ASSERT_EQ(final.state, session::OperationState::kSucceeded) << final.error << " / " << final.message;
  EXPECT_EQ(final.counters.stored, 28u);
  EXPECT_GE(final.counters.lost, 2u);
  EXPECT_GE(camera.statistics().reconnects, 1u);
}

TEST(Session, FullDiskStopsCleanlyAndKeepsWhatWasStored) {
  TestLab lab("full");
  // Each 160x120 16-bit frame is ~38.6 kB of TIFF plus ~0.7 kB of journal; allow about ten.
  lab.config.storage_limit_bytes = 400000;
  auto daemon = lab.daemon();
  auto started = daemon->start_session(quick_standard_plan(5), "");
  auto final = wait_final(*daemon, started.id);
  ASSERT_EQ(final.state, session::OperationState::kFailed);
  EXPECT_NE(final.error.find("storage full"), std::string::npos) << final.error;
  EXPECT_GT(final.counters.stored, 3u);
  EXPECT_LT(final.counters.stored, 35u);
  // Everything acknowledged reads back; no temporary file is left.
  auto info = daemon->store().read_session(final.folder);
  EXPECT_EQ(info.frames.size(), final.counters.stored);
  EXPECT_EQ(info.torn_journal_tail, false);
  for (const auto& frame : info.frames)
    EXPECT_EQ(session::read_tiff(std::filesystem::path(final.folder) / frame.file).data.size(), 160u * 120u * 2u);
  for (const auto& file : std::filesystem::recursive_directory_iterator(final.folder))
    EXPECT_EQ(file.path().string().find(".tmp-"), std::string::npos) << file.path();
  EXPECT_EQ(lab.emitted(), drivers::DriveLevels{});  // LEDs switched off
}

TEST(Session, RestartReportsFinishedSessionsFromTheFolder) {
  TestLab lab("restart");
  std::string id;
  {
    auto daemon = lab.daemon();
    id = daemon->start_session(quick_standard_plan(), "x").id;
    ASSERT_EQ(wait_final(*daemon, id).state, session::OperationState::kSucceeded);
  }
  auto daemon = lab.daemon();
  auto record = daemon->operations().get(id);
  ASSERT_TRUE(record);
  EXPECT_EQ(record->state, session::OperationState::kSucceeded);
  EXPECT_EQ(record->counters.stored, 7u);
  EXPECT_DOUBLE_EQ(record->progress, 1.0);
}

TEST(Session, InvalidPlansAndUnknownMixesAreRefusedBeforeAnythingIsWritten) {
  TestLab lab("invalid");
  lab.config.mixes.erase("w57+blue");
  auto daemon = lab.daemon();
  try {
    daemon->start_session(quick_standard_plan(), "");
    FAIL() << "accepted a plan whose mix has no weights";
  } catch (const std::invalid_argument& error) {
    EXPECT_EQ(std::string(error.what()).rfind("plan.steps[3].mix:", 0), 0u) << error.what();
  }
  auto plan = quick_standard_plan();
  plan.steps[1].settle_ms = 70000;
  EXPECT_THROW(daemon->start_session(plan, ""), std::invalid_argument);
  auto cross = quick_standard_plan();  // the lab's sphere has no polariser banks
  std::erase_if(cross.steps, [](const session::Step& step) { return step.illumination.mix == "w57+blue"; });
  for (auto& step : cross.steps)
    if (step.role != session::StepRole::kDark) step.polarisation = drivers::Polarisation::kCross;
  try {
    daemon->start_session(cross, "");
    FAIL() << "accepted a cross-polarised plan on a sphere without polarisers";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("plan.steps[1].polarisation: cross, but LED controller"),
              std::string::npos)
        << error.what();
  }
  EXPECT_TRUE(std::filesystem::is_empty(lab.config.sessions_dir));
}

}  // namespace
}  // namespace chromo::daemon
