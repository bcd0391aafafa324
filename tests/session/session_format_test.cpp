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
  const MethodCaptures captures = read_session_captures(testing::kSessionFormatOneSample, sample_sources());
  // BayerRG12 192×144 binned 2×2.
  EXPECT_EQ(captures.dark.width, 96);
  EXPECT_EQ(captures.dark.height, 72);
  EXPECT_EQ(captures.broadband.subject.width, 96);
  // The white reference is brighter than the dark in every channel.
  for (int c = 0; c < 3; ++c)
    EXPECT_GT(captures.broadband.white.planes[c][0], captures.dark.planes[c][0] + 0.01) << c;

  const fs::path out = testing::fresh_directory("session-format-estimate");
  maps::MethodEstimationOptions options;
  options.estimator.threads = 2;
  options.cache_dir = fs::temp_directory_path() / "chromo-test-forward-tables";
  const auto result = maps::estimate_method_captures(
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
