// The camera's trigger count (issue 21, synchronised capture): the camera
// simulator counts the triggers it receives since AcquisitionStart and sends
// the count with each triggered frame as GVSP chunk data (ChunkTriggerCount);
// the driver reads it through Aravis' chunk parser (Frame::trigger_count).
// The simulator's trigger faults make it ignore chosen triggers.
#include "camera_fixture.hpp"

namespace chromo::testing {
namespace {

using drivers::FrameStatus;
using drivers::PixelFormat;
using drivers::TriggerMode;

std::vector<std::uint64_t> counts_of(const std::vector<drivers::Frame>& frames) {
  std::vector<std::uint64_t> counts;
  for (const auto& frame : frames) {
    EXPECT_EQ(frame.status, FrameStatus::kComplete);
    EXPECT_TRUE(frame.trigger_count.has_value());
    counts.push_back(frame.trigger_count.value_or(0));
  }
  return counts;
}

TEST_F(CameraOnLoopback, LineTriggeredFramesCarryTheTriggerTheyAnswered) {
  auto s = settings(PixelFormat::kMono8);
  s.trigger_mode = TriggerMode::kHardware;  // TriggerSource Line0
  camera_->configure(s);
  simulators::TriggerFaultOptions faults;
  faults.ignore_triggers = {2};  // the camera's second trigger: received, not answered
  simulator_->set_trigger_faults(faults);
  FrameSink sink;
  camera_->start_stream(sink.callback());
  for (int k = 0; k < 4; ++k) {
    simulator_->pulse_trigger_input();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(sink.wait_for_count(3, std::chrono::seconds(10)));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // no frame for the ignored trigger comes later
  auto frames = sink.take();
  EXPECT_EQ(counts_of(frames), (std::vector<std::uint64_t>{1, 3, 4}));
  EXPECT_EQ(simulator_->triggers_received(), 4u);
  EXPECT_EQ(simulator_->triggers_ignored(), 1u);
  for (const auto& frame : frames) EXPECT_EQ(frame.data.size(), 256u * 256u);  // the image only, chunks stripped
  EXPECT_GT(frames.back().camera_timestamp_ns, frames.front().camera_timestamp_ns);
  // A new stream (AcquisitionStart) counts from 1 again.
  camera_->stop_stream();
  camera_->start_stream(sink.callback());
  simulator_->pulse_trigger_input();
  ASSERT_TRUE(sink.wait_for_count(1, std::chrono::seconds(10)));
  camera_->stop_stream();
  EXPECT_EQ(counts_of(sink.take()), (std::vector<std::uint64_t>{1}));
  EXPECT_EQ(simulator_->triggers_received(), 5u);
}

TEST_F(CameraOnLoopback, SoftwareTriggersAreCountedTooAndFreeRunningFramesCarryNone) {
  camera_->configure(settings(PixelFormat::kBayerRG12));
  FrameSink sink;
  camera_->start_stream(sink.callback());
  ASSERT_TRUE(trigger_and_wait(sink));
  ASSERT_TRUE(trigger_and_wait(sink));
  camera_->stop_stream();
  auto frames = sink.take();
  EXPECT_EQ(counts_of(frames), (std::vector<std::uint64_t>{1, 2}));
  for (const auto& frame : frames) EXPECT_EQ(frame.data.size(), 256u * 256u * 2u);
  // Random ignoring, seeded: over 40 triggers some are ignored, every one is
  // either answered with its own count or counted as ignored.
  simulators::TriggerFaultOptions faults;
  faults.ignore_probability = 0.2;
  faults.seed = 5;
  simulator_->set_trigger_faults(faults);
  camera_->start_stream(sink.callback());
  for (int k = 0; k < 40; ++k) {
    camera_->software_trigger();
    std::this_thread::sleep_for(std::chrono::milliseconds(15));
  }
  const std::uint64_t ignored = simulator_->triggers_ignored();
  ASSERT_TRUE(sink.wait_for_count(40 - ignored, std::chrono::seconds(20)));
  camera_->stop_stream();
  const auto counts = counts_of(sink.take());
  EXPECT_GT(ignored, 0u);
  EXPECT_LT(ignored, 20u);
  EXPECT_EQ(counts.size(), 40u - ignored);
  for (std::size_t i = 1; i < counts.size(); ++i) EXPECT_GT(counts[i], counts[i - 1]);
  EXPECT_LE(counts.back(), 40u);

  auto free_run = settings(PixelFormat::kMono8);
  free_run.trigger_mode = TriggerMode::kFreeRun;
  free_run.frame_rate_hz = 20;
  camera_->configure(free_run);
  camera_->start_stream(sink.callback());
  ASSERT_TRUE(sink.wait_for_count(2, std::chrono::seconds(10)));
  camera_->stop_stream();
  for (const auto& frame : sink.take())
    if (frame.status == FrameStatus::kComplete) EXPECT_FALSE(frame.trigger_count.has_value());
}

TEST(TriggerFaultOptions, RefusesBadValuesNamingThem) {
  simulators::TriggerFaultOptions faults;
  std::string error;
  EXPECT_TRUE(faults.IsValid(&error));
  faults.ignore_probability = 0.6;
  EXPECT_FALSE(faults.IsValid(&error));
  EXPECT_NE(error.find("ignore_probability"), std::string::npos);
  faults.ignore_probability = 0;
  faults.ignore_triggers = {0};
  EXPECT_FALSE(faults.IsValid(&error));
  EXPECT_NE(error.find("ignore_triggers"), std::string::npos);
}

}  // namespace
}  // namespace chromo::testing
