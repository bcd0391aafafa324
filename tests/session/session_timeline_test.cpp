// Where a session's time went (session/session_timeline.hpp), from journal
// records as the daemon writes them: each phase between its records, phases
// not reached -1, and hostile records (wrong types, bad times) ignored.
#include <gtest/gtest.h>

#include "chromo/session/session_timeline.hpp"

namespace chromo::session {
namespace {

nlohmann::json at(const std::string& time, nlohmann::json record) {
  record["t"] = "2026-12-02T15:" + time + "Z";
  return record;
}

TEST(SessionTimeline, EachPhaseIsMeasuredBetweenItsRecords) {
  const std::vector<nlohmann::json> journal{
      at("00:00.000000", {{"type", "state"}, {"state", "running"}}),
      at("00:00.500000", {{"type", "step_started"}, {"step", "dark"}}),
      at("00:01.000000", {{"type", "frame"}, {"role", "dark"}}),
      at("00:02.000000", {{"type", "step_started"}, {"step", "subject_d65"}}),
      at("00:03.250000", {{"type", "frame"}, {"role", "subject"}}),
      at("00:05.750000", {{"type", "frame"}, {"role", "subject"}}),
      at("00:06.000000", {{"type", "frame"}, {"role", "white"}}),
      at("00:08.000000", {{"type", "derived"}, {"file", "derived/dark-cam0-mean.exr"}}),
      at("00:09.000000", {{"type", "derived"}, {"file", "derived/albedo-d65-cam0.exr"}}),
      at("00:16.125000", {{"type", "results"}, {"state", "available"}}),
      at("00:16.200000", {{"type", "state"}, {"state", "succeeded"}}),
  };
  const SessionTimeline timeline = session_timeline(journal);
  EXPECT_DOUBLE_EQ(timeline.capture_s, 5.5);
  EXPECT_DOUBLE_EQ(timeline.subject_s, 2.5);
  EXPECT_DOUBLE_EQ(timeline.derived_s, 3.0);
  EXPECT_DOUBLE_EQ(timeline.estimation_s, 10.125);
  EXPECT_NEAR(timeline.total_s, 15.7, 1e-9);
}

TEST(SessionTimeline, PhasesNotReachedAreMinusOneAndHostileRecordsAreIgnored) {
  const std::vector<nlohmann::json> running{
      at("00:00.500000", {{"type", "step_started"}, {"step", "dark"}}),
      at("00:01.000000", {{"type", "frame"}, {"role", "dark"}}),
      at("00:01.500000", {{"type", "state"}, {"state", "paused"}}),  // not final
      {{"type", "frame"}, {"role", "subject"}},                         // no time
      {{"type", "frame"}, {"role", "subject"}, {"t", 12}},              // a time that is not text
      at("00:02.5Z", {{"type", "frame"}, {"role", "subject"}}),         // not the journal's format
      at("00:03.000000", {{"type", 7}, {"role", "subject"}}),           // a type that is not text
      at("00:04.000000", {{"type", "frame"}, {"role", 3}}),             // a frame, of no known role
  };
  const SessionTimeline timeline = session_timeline(running);
  EXPECT_DOUBLE_EQ(timeline.capture_s, 3.5);
  EXPECT_EQ(timeline.subject_s, -1);
  EXPECT_EQ(timeline.derived_s, -1);
  EXPECT_EQ(timeline.estimation_s, -1);
  EXPECT_EQ(timeline.total_s, -1);
  EXPECT_EQ(session_timeline({}), SessionTimeline{});
}

}  // namespace
}  // namespace chromo::session
