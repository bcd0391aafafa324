// FramePipeline (daemon/internal/capture/frame_pipeline.hpp) on a real session folder: a step
// is complete once its frames are stored (drain_storage), while the on-line
// estimator may still be busy with them (drain waits for both). The
// estimator here is a FrameConsumer that holds its first frame until the
// test lets it go, standing for the table preparation that once held the
// subject steps back.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <future>

#include "chromo/daemon/internal/capture/frame_pipeline.hpp"
#include "chromo/session/session_store.hpp"

namespace chromo::daemon {
namespace {

namespace fs = std::filesystem;

class HeldConsumer : public FrameConsumer {
 public:
  void consume(const CapturedFrame&, const StoredFrame& stored) override {
    inside_.store(true);
    EXPECT_FALSE(stored.file.empty());
    released_.wait();
    ++consumed_;
    inside_.store(false);
  }
  std::promise<void> release_;
  std::shared_future<void> released_ = release_.get_future().share();
  std::atomic<bool> inside_{false};
  std::atomic<int> consumed_{0};
};

CapturedFrame small_frame(const std::string& step, std::uint64_t sequence) {
  CapturedFrame captured;
  captured.record.camera = "cam0";
  captured.record.step = step;
  captured.record.role = session::StepRole::kWhite;
  captured.record.sequence = sequence;
  captured.record.width = 8;
  captured.record.height = 4;
  captured.record.pixel_format = drivers::PixelFormat::kMono8;
  captured.samples.assign(8 * 4, 100);
  captured.trigger_time = std::chrono::steady_clock::now();
  return captured;
}

TEST(FramePipeline, AStepIsCompleteOnceStoredWhileTheEstimatorIsStillBusy) {
  const fs::path sessions = fs::temp_directory_path() / ("chromo_pipeline_test_" + std::to_string(::getpid()));
  fs::remove_all(sessions);
  files::StorageBudget budget;
  session::SessionStore store(sessions, &budget);
  auto created = store.create(session::standard_plan(), "pipeline", nlohmann::json::array());
  HeldConsumer estimator;
  {
    FramePipeline pipeline(created.folder, *created.journal, &budget, {64, 8}, &estimator, {});
    pipeline.submit(small_frame("white_d65", 0));
    pipeline.submit(small_frame("white_d65", 1));
    pipeline.drain_storage();  // returns although the estimator holds the first frame
    const session::PipelineCounters stored = pipeline.counters();
    EXPECT_EQ(stored.stored, 2u);
    EXPECT_EQ(estimator.consumed_.load(), 0);
    EXPECT_TRUE(fs::exists(created.folder / "frames" / "white_d65" / "cam0-000000.tiff"));
    EXPECT_TRUE(fs::exists(created.folder / "frames" / "white_d65" / "cam0-000001.tiff"));
    estimator.release_.set_value();
    pipeline.drain();  // now both frames were consumed
    EXPECT_EQ(estimator.consumed_.load(), 2);
    EXPECT_EQ(pipeline.counters().estimated, 2u);
    EXPECT_EQ(pipeline.counters().estimator_skipped, 0u);
  }
  fs::remove_all(sessions);
}

}  // namespace
}  // namespace chromo::daemon
