// Sessions end to end inside one process: Daemon + sequencer + pipeline +
// storage on the loopback devices, with faults switched on demand.
#include "chromo/daemon/image_files.hpp"
#include "test_lab.hpp"

namespace chromo::daemon {
namespace {

using testing::quick_standard_plan;
using testing::TestLab;
using testing::wait_final;
using testing::wait_for;

TEST(Session, StandardSessionStoresEveryFrameWithMetadataAndDerivedData) {
  TestLab lab("standard");
  auto daemon = lab.daemon();
  auto started = daemon->start_session(quick_standard_plan(2), "forearm");
  auto final = wait_final(*daemon, started.id);
  ASSERT_EQ(final.state, OperationState::kSucceeded) << final.error;
  EXPECT_EQ(final.counters.stored, 14u);
  EXPECT_EQ(final.counters.lost, 0u);
  EXPECT_EQ(final.counters.estimated, 14u);  // consumed by the on-line estimator (mono frames: no maps)
  EXPECT_DOUBLE_EQ(final.progress, 1.0);

  auto info = daemon->session(started.id);
  ASSERT_TRUE(info);
  EXPECT_EQ(info->subject, "forearm");
  ASSERT_EQ(info->frames.size(), 14u);
  for (const auto& step : info->steps) EXPECT_TRUE(step.completed) << step.name;
  // Every frame: its file reads back, and the metadata names the LED state.
  for (const auto& frame : info->frames) {
    auto image = read_tiff(std::filesystem::path(final.folder) / frame["file"].get<std::string>());
    EXPECT_EQ(image.width, 32);
    EXPECT_EQ(image.bits_per_sample, 16);
    EXPECT_TRUE(frame.contains("camera_timestamp_ns"));
    EXPECT_EQ(frame["led"]["temperature_C"].size(), 6u);
    EXPECT_DOUBLE_EQ(frame["exposure_us"].get<double>(), 1000.0);
  }
  // The W57+blue subject frames were taken under the configured mix.
  const auto& last = info->frames.back();
  EXPECT_EQ(last["step"], "subject_w57+blue");
  EXPECT_DOUBLE_EQ(last["led"]["drive"]["B"].get<double>(), lab.config.mixes["w57+blue"][5]);
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(final.folder) / "derived/albedo-d65-cam0.exr"));
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(final.folder) / "derived/dark-cam0-mean.exr"));
}

TEST(Session, HardwareTimedSequenceAdvancesOnTheCameraExposure) {
  TestLab lab("hardware");
  auto daemon = lab.daemon();
  auto plan = quick_standard_plan(2);
  plan.timing = Timing::kHardware;
  auto started = daemon->start_session(plan, "");
  auto final = wait_final(*daemon, started.id);
  ASSERT_EQ(final.state, OperationState::kSucceeded) << final.error;
  auto info = daemon->session(started.id);
  // The controller showed state k for the k-th frame: the blue level follows the plan.
  for (const auto& frame : info->frames) {
    const std::string step = frame["step"];
    double blue = frame["led"]["drive"]["B"];
    if (step == "dark") {
      EXPECT_EQ(blue, 0.0);
    } else if (step.find("w57+blue") != std::string::npos) {
      EXPECT_DOUBLE_EQ(blue, lab.config.mixes["w57+blue"][5]);
    }
  }
  EXPECT_EQ(lab.lab->sequence_position(), -1);  // disarmed at the end
}

TEST(Session, CancelInTheMiddleKeepsStoredFramesAndEndsCancelled) {
  TestLab lab("cancel");
  auto daemon = lab.daemon();
  auto started = daemon->start_session(quick_standard_plan(20, 2000), "");
  wait_for(*daemon, started.id, [](const OperationRecord& r) { return r.counters.stored >= 5; });
  daemon->operations().control(started.id)->request_cancel();
  auto final = wait_final(*daemon, started.id);
  EXPECT_EQ(final.state, OperationState::kCancelled);
  EXPECT_LT(final.counters.stored, 140u);
  auto info = daemon->session(started.id);
  EXPECT_EQ(info->record.state, OperationState::kCancelled);
  EXPECT_EQ(info->frames.size(), final.counters.stored);
  EXPECT_FALSE(info->steps.back().completed);
  EXPECT_EQ(lab.lab->emitted(), drivers::DriveLevels{});  // LEDs dark after the cancel
  // A new session may start once the first ended.
  auto second = daemon->start_session(quick_standard_plan(), "");
  EXPECT_EQ(wait_final(*daemon, second.id).state, OperationState::kSucceeded);
}

TEST(Session, SecondSessionWhileOneRunsIsRefused) {
  TestLab lab("busy");
  auto daemon = lab.daemon();
  auto started = daemon->start_session(quick_standard_plan(10, 2000), "");
  EXPECT_THROW(daemon->start_session(quick_standard_plan(), ""), std::logic_error);
  daemon->operations().control(started.id)->request_cancel();
  wait_final(*daemon, started.id);
}

TEST(Session, PauseFinishesTheStepAndResumeContinues) {
  TestLab lab("pause");
  auto daemon = lab.daemon();
  auto started = daemon->start_session(quick_standard_plan(3), "");
  daemon->operations().control(started.id)->request_pause();
  auto paused = wait_for(*daemon, started.id, [](const OperationRecord& r) { return r.state == OperationState::kPaused; });
  ASSERT_EQ(paused.state, OperationState::kPaused);
  auto stored = paused.counters.stored;
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(daemon->operations().get(started.id)->counters.stored, stored);  // nothing taken while paused
  daemon->operations().control(started.id)->request_resume();
  auto final = wait_final(*daemon, started.id);
  EXPECT_EQ(final.state, OperationState::kSucceeded);
  EXPECT_EQ(final.counters.stored, 21u);
}

TEST(Session, LedControllerThatStopsAnsweringPausesWithAClearStatus) {
  TestLab lab("led-silent");
  auto daemon = lab.daemon();
  lab.lab->led_responding = false;
  auto started = daemon->start_session(quick_standard_plan(), "");
  auto paused = wait_for(*daemon, started.id, [](const OperationRecord& r) { return r.state == OperationState::kPaused; });
  ASSERT_EQ(paused.state, OperationState::kPaused);
  EXPECT_NE(paused.message.find("LED controller \"sphere\" stopped answering"), std::string::npos) << paused.message;
  lab.lab->led_responding = true;
  daemon->operations().control(started.id)->request_resume();
  auto final = wait_final(*daemon, started.id);
  EXPECT_EQ(final.state, OperationState::kSucceeded);
  EXPECT_EQ(final.counters.stored, 7u);
}

TEST(Session, CameraPacketLossIsCountedWithItsReasonAndRetaken) {
  TestLab lab("loss");
  auto daemon = lab.daemon();
  lab.lab->drop_every_nth_frame = 3;
  auto started = daemon->start_session(quick_standard_plan(3), "");
  auto final = wait_final(*daemon, started.id);
  ASSERT_EQ(final.state, OperationState::kSucceeded) << final.error;
  EXPECT_EQ(final.counters.stored, 21u);  // every wanted frame, retaken
  EXPECT_GE(final.counters.lost, 7u);
  EXPECT_EQ(final.counters.lost_reasons.at("missing_packets"), final.counters.lost);
  auto info = daemon->session(started.id);
  EXPECT_EQ(info->record.counters.lost, final.counters.lost);  // the journal says the same
}

TEST(Session, CameraThatDisappearsPausesAndContinuesWhenItReturns) {
  TestLab lab("camera-gone");
  lab.config.frame_attempts = 2;
  auto daemon = lab.daemon();
  lab.lab->camera_present = false;
  auto started = daemon->start_session(quick_standard_plan(), "");
  auto paused = wait_for(*daemon, started.id, [](const OperationRecord& r) { return r.state == OperationState::kPaused; });
  ASSERT_EQ(paused.state, OperationState::kPaused);
  EXPECT_NE(paused.message.find("camera \"cam0\""), std::string::npos) << paused.message;
  lab.lab->camera_present = true;
  daemon->operations().control(started.id)->request_resume();
  auto final = wait_final(*daemon, started.id);
  EXPECT_EQ(final.state, OperationState::kSucceeded);
  EXPECT_EQ(final.counters.stored, 7u);
  EXPECT_GE(final.counters.lost_reasons.at("camera_unreachable"), 2u);
}

TEST(Session, FullDiskStopsCleanlyAndKeepsWhatWasStored) {
  TestLab lab("full");
  // Each 64x48 16-bit frame is ~6.4 kB of TIFF plus ~0.6 kB of journal; allow about ten.
  lab.config.storage_limit_bytes = 75000;
  auto daemon = lab.daemon({{"width", 64}, {"height", 48}});
  auto started = daemon->start_session(quick_standard_plan(5), "");
  auto final = wait_final(*daemon, started.id);
  ASSERT_EQ(final.state, OperationState::kFailed);
  EXPECT_NE(final.error.find("storage full"), std::string::npos) << final.error;
  EXPECT_GT(final.counters.stored, 3u);
  EXPECT_LT(final.counters.stored, 35u);
  // Everything acknowledged reads back; no temporary file is left.
  auto info = daemon->store().read_session(final.folder);
  EXPECT_EQ(info.frames.size(), final.counters.stored);
  EXPECT_EQ(info.torn_journal_tail, false);
  for (const auto& frame : info.frames)
    EXPECT_NO_THROW(read_tiff(std::filesystem::path(final.folder) / frame["file"].get<std::string>()));
  for (const auto& file : std::filesystem::recursive_directory_iterator(final.folder))
    EXPECT_EQ(file.path().string().find(".tmp-"), std::string::npos) << file.path();
}

TEST(Session, RestartReportsFinishedSessionsFromTheFolder) {
  TestLab lab("restart");
  std::string id;
  {
    auto daemon = lab.daemon();
    id = daemon->start_session(quick_standard_plan(), "x").id;
    ASSERT_EQ(wait_final(*daemon, id).state, OperationState::kSucceeded);
  }
  auto daemon = lab.daemon();
  auto record = daemon->operations().get(id);
  ASSERT_TRUE(record);
  EXPECT_EQ(record->state, OperationState::kSucceeded);
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
  EXPECT_TRUE(std::filesystem::is_empty(lab.config.sessions_dir));
}

}  // namespace
}  // namespace chromo::daemon
