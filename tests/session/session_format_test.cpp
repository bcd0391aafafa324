// Session folders of an earlier format still load: data/test/session-format-1
// is a folder chromod wrote before session.json's "format" went to version 2
// (the standard plan, one 192×144 BayerRG12 frame per step, its journal and
// the LED library the on-line estimator used; data/README.md).
#include <gtest/gtest.h>

#include <fstream>

#include "../support/fresh_directory.hpp"
#include "../support/session_sample.hpp"
#include "chromo/calibration/led_library_io.hpp"
#include "chromo/maps/estimate_report.hpp"
#include "chromo/session/operation_record.hpp"
#include "chromo/session/session_captures.hpp"
#include "chromo/session/session_store.hpp"

namespace chromo::session {
namespace {

namespace fs = std::filesystem;

// The sources the daemon used for the sample: its LED library (results/),
// the built-in camera, ρ_white 0.99.
CaptureSources sample_sources() {
  return resolve_capture_sources((testing::kSessionFormatOneSample / "results" / "led_library.json").string(), "builtin:nikon_d5100", 0.99);
}

// The end-of-session counters: one pair writes and reads the journal's
// record, so a field the daemon writes is one SessionStore reads back.
TEST(CountersRecord, RoundTripsEveryRecordedFieldAndNamesABadOne) {
  PipelineCounters c;
  c.received = 41, c.stored = 40, c.estimated = 38, c.estimator_skipped = 2, c.lost = 1, c.resent_packets = 77;
  c.lost_reasons = {{"timeout", 1}};
  c.skipped_reasons = {{"queue_full", 2}};
  c.max_estimator_queue_depth = 8, c.estimator_read_back = 2;
  c.mean_trigger_to_stored_ms = 12.5, c.max_trigger_to_stored_ms = 80.25;
  c.estimator_queue_depth = 3, c.storage_cpu_ms = 9;  // live only: not recorded
  const nlohmann::json record = counters_record(c);
  EXPECT_EQ(record["type"], "counters");
  EXPECT_FALSE(record.contains("storage_cpu_ms"));
  const PipelineCounters back = counters_from_record(nlohmann::json::parse(record.dump()));
  EXPECT_EQ(back.received, 41u);
  EXPECT_EQ(back.stored, 40u);
  EXPECT_EQ(back.estimated, 38u);
  EXPECT_EQ(back.estimator_skipped, 2u);
  EXPECT_EQ(back.lost, 1u);
  EXPECT_EQ(back.resent_packets, 77u);
  EXPECT_EQ(back.lost_reasons, c.lost_reasons);
  EXPECT_EQ(back.skipped_reasons, c.skipped_reasons);
  EXPECT_EQ(back.max_estimator_queue_depth, 8u);
  EXPECT_EQ(back.estimator_read_back, 2u);
  EXPECT_EQ(back.mean_trigger_to_stored_ms, 12.5);
  EXPECT_EQ(back.max_trigger_to_stored_ms, 80.25);
  EXPECT_EQ(back.estimator_queue_depth, 0u);
  EXPECT_EQ(counters_from_record({{"type", "counters"}}).estimated, 0u);  // an older journal's record
  try {
    counters_from_record({{"type", "counters"}, {"estimated", "many"}});
    ADD_FAILURE() << "a count that is text was read";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("\"estimated\""), std::string::npos) << e.what();
  }
}

TEST(SessionFormat, FormatOneFolderReadsBackWithItsPlanAndFrames) {
  files::StorageBudget budget;
  SessionStore store(testing::fresh_directory("session-format-store"), &budget);
  const SessionInfo info = store.read_session(testing::kSessionFormatOneSample);
  EXPECT_EQ(info.format_version, 1);
  EXPECT_EQ(info.record.state, OperationState::kSucceeded);
  EXPECT_EQ(info.subject, "sample forearm");
  ASSERT_EQ(info.plan.steps.size(), 7u);
  EXPECT_EQ(info.plan.steps[0].role, StepRole::kDark);
  EXPECT_DOUBLE_EQ(info.plan.steps[0].exposure_us, 4000.0);
  ASSERT_EQ(info.frames.size(), 7u);
  for (const auto& step : info.steps) {
    EXPECT_TRUE(step.completed) << step.name;
    EXPECT_EQ(step.frames_stored, 1u) << step.name;
  }
  EXPECT_EQ(info.record.counters.stored, 7u);
  EXPECT_EQ(info.results.value("state", ""), "available");
}

TEST(SessionFormat, FormatOneFolderGivesTheCapturesAndEstimates) {
  const Captures captures = read_session_captures(testing::kSessionFormatOneSample, sample_sources());
  // BayerRG12 192×144 binned 2×2.
  EXPECT_EQ(captures.dark.width, 96);
  EXPECT_EQ(captures.dark.height, 72);
  EXPECT_EQ(captures.captures[0].subject.width, 96);
  // The white reference is brighter than the dark in every channel.
  for (int c = 0; c < 3; ++c)
    EXPECT_GT(captures.captures[0].white.planes[c][0], captures.dark.planes[c][0] + 0.01) << c;

  const fs::path out = testing::fresh_directory("session-format-estimate");
  maps::MethodEstimationOptions options;
  options.estimator.threads = 2;
  options.cache_dir = fs::temp_directory_path() / "chromo-test-forward-tables";
  const auto result = maps::estimate_captures(
      captures, options, out,
      [](const fs::path& path, const std::function<void(const fs::path&)>& produce) { produce(path); });
  EXPECT_EQ(result.summary.pixels, 96u * 72u);
  // Most of the sample's skin is explained, as the daemon's own estimate said.
  EXPECT_GT(result.summary.flag_counts[static_cast<int>(estimation::PixelFlag::kExplained)], 96u * 72u / 2);
  EXPECT_TRUE(fs::exists(out / "maps.exr"));
}

TEST(SessionFormat, NewFoldersAreWrittenInTheCurrentVersion) {
  files::StorageBudget budget;
  SessionStore store(testing::fresh_directory("session-format-new"), &budget);
  auto created = store.create(standard_plan(), "", nlohmann::json::array());
  std::ifstream in(created.folder / "session.json");
  EXPECT_EQ(nlohmann::json::parse(in)["format"], "chromosphere-session/2");
  EXPECT_EQ(store.read_session(created.folder).format_version, kSessionFormatVersion);
}

// Issue 19: a full disk (here the storage budget, which fails exactly as one)
// refusing a start left an empty session folder behind on every try.
TEST(SessionFormat, ARefusedStartLeavesNoFolder) {
  const fs::path root = testing::fresh_directory("session-format-refused");
  files::StorageBudget budget(10);  // not even session.json fits
  SessionStore store(root, &budget);
  for (int attempt = 0; attempt < 3; ++attempt)
    EXPECT_THROW(store.create(standard_plan(), "", nlohmann::json::array()), files::StorageFullError);
  EXPECT_TRUE(fs::is_empty(root)) << fs::directory_iterator(root)->path();
  EXPECT_TRUE(store.recover().empty());
}

TEST(SessionFormat, UnknownFormatIsRefusedNamingTheField) {
  const fs::path folder = testing::fresh_directory("session-format-future");
  fs::copy(testing::kSessionFormatOneSample, folder, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
  std::ifstream in(folder / "session.json");
  auto session = nlohmann::json::parse(in);
  in.close();
  session["format"] = "chromosphere-session/99";
  std::ofstream(folder / "session.json") << session.dump(2);
  files::StorageBudget budget;
  SessionStore store(testing::fresh_directory("session-format-store-2"), &budget);
  try {
    store.read_session(folder);
    FAIL() << "a format-99 folder was read";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("session.json: format: \"chromosphere-session/99\""), std::string::npos)
        << error.what();
  }
  EXPECT_THROW(read_session_captures(folder, sample_sources()), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::session
