// Block-id bookkeeping of the camera driver: gaps, the 16-bit wrap, late
// frames taking a gap back, stale ids of failed buffers.
#include <gtest/gtest.h>

#include "../../drivers/camera/lost_frame_counter.hpp"

namespace chromo::drivers::detail {
namespace {

TEST(LostFrameCounter, CountsGapsAcrossThe16BitWrapWhichSkipsZero) {
  LostFrameCounter counter;
  EXPECT_EQ(counter.on_frame(65533), 0);
  EXPECT_EQ(counter.on_frame(65534), 0);
  EXPECT_EQ(counter.on_frame(1), 1);  // 65535 lost; 0 is never used
  EXPECT_EQ(counter.on_frame(2), 0);
  EXPECT_EQ(counter.on_frame(5), 2);
}

TEST(LostFrameCounter, ALateFrameTakesItsGapBackOnce) {
  LostFrameCounter counter;
  counter.on_frame(10);
  EXPECT_EQ(counter.on_frame(13), 2);  // 11 and 12 provisionally lost
  EXPECT_EQ(counter.on_frame(12), -1);  // 12 came late after all
  EXPECT_EQ(counter.on_frame(12), 0);   // not twice
  EXPECT_EQ(counter.on_frame(14), 0);
}

TEST(LostFrameCounter, StaleIdsOfFailedBuffersAreRecognised) {
  LostFrameCounter counter;
  counter.on_frame(20);
  counter.on_frame(21);
  EXPECT_TRUE(counter.is_stale(13));   // behind, not a gap we wait for
  EXPECT_TRUE(counter.is_stale(0));
  EXPECT_FALSE(counter.is_stale(22));  // ahead: a real id
  // A failed frame without an id is the next one...
  EXPECT_EQ(counter.on_frame_without_id(), 0);
  EXPECT_EQ(counter.on_frame(23), 0);  // ...so 23 follows without a gap
  // ...or the oldest frame already counted lost.
  EXPECT_EQ(counter.on_frame(26), 2);
  EXPECT_EQ(counter.on_frame_without_id(), -1);
}

TEST(LostFrameCounter, ACameraRestartCountsNothing) {
  LostFrameCounter counter;
  counter.on_frame(500);
  EXPECT_EQ(counter.on_frame(3), 0);
  EXPECT_EQ(counter.on_frame(5), 1);  // counting goes on from the restart
  counter.reset();
  EXPECT_EQ(counter.on_frame(65401), 0);
}

}  // namespace
}  // namespace chromo::drivers::detail
