// Derived data written one file after another and on several threads
// (derived_data.hpp, DerivedDataOptions): the same files, pixels and journal
// records (in the background too, on threads at the lowest priority), and a
// bad setting refused before anything is written; its albedo
// is the estimator's (albedo.hpp), the subject's exposure ratio included.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <sstream>
#include <atomic>
#include <chrono>
#include <fstream>
#include <thread>

#include <sys/resource.h>
#include <unistd.h>

#include "../support/fresh_directory.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/session/derived_data.hpp"
#include "chromo/session/frame_sums.hpp"
#include "chromo/session/journal.hpp"

namespace chromo::session {
namespace {

namespace fs = std::filesystem;

// Every step of the standard plan, two cameras, one noisy 12-bit frame each.
SessionFrameSums sums_of(const SessionPlan& plan, int width, int height) {
  SessionFrameSums sums;
  std::uint64_t index = 0;
  std::uint32_t seed = 99;
  for (std::size_t s = 0; s < plan.steps.size(); ++s)
    for (const char* camera : {"cam0", "cam1"}) {
      FrameRecord record;
      record.index = index++;
      record.step = plan.steps[s].name;
      record.step_index = static_cast<int>(s);
      record.role = plan.steps[s].role;
      record.camera = camera;
      record.width = width, record.height = height;
      record.pixel_format = drivers::PixelFormat::kBayerRG12;
      std::vector<std::uint8_t> samples(static_cast<std::size_t>(width) * height * 2);
      const std::uint16_t base = record.role == StepRole::kDark ? 64 : record.role == StepRole::kWhite ? 3000 : 1500;
      for (std::size_t i = 0; i < samples.size() / 2; ++i) {
        seed = seed * 1664525u + 1013904223u;
        const auto value = static_cast<std::uint16_t>(base + (seed >> 24));
        std::memcpy(&samples[2 * i], &value, 2);
      }
      sums.add(record, samples);
    }
  return sums;
}

std::vector<nlohmann::json> derived_records(const fs::path& journal) {
  std::vector<nlohmann::json> out;
  std::ifstream in(journal);
  for (std::string line; std::getline(in, line);) {
    auto record = nlohmann::json::parse(line);
    record.erase("t");
    out.push_back(record);
  }
  return out;
}

TEST(DerivedData, EveryThreadCountWritesTheSameFilesAndRecordsInTheSameOrder) {
  const SessionPlan plan = standard_plan();
  const SessionFrameSums sums = sums_of(plan, 64, 48);
  const fs::path root = testing::fresh_directory("derived-threads");
  std::vector<std::vector<nlohmann::json>> records;
  int variant = 0;
  for (const DerivedDataOptions options : {DerivedDataOptions{1, -1}, DerivedDataOptions{0, -1}, DerivedDataOptions{3, 1},
                                           DerivedDataOptions{2, -1, true}}) {
    const fs::path folder = root / std::to_string(variant++);
    fs::create_directories(folder);
    {
      Journal journal(folder / "journal.jsonl", nullptr);
      write_derived_data(folder, plan, sums, 0.99, journal, nullptr, options);
    }
    records.push_back(derived_records(folder / "journal.jsonl"));
  }
  ASSERT_EQ(records[0].size(), 7u * 2 + 3 * 2);  // a mean per step and camera, an albedo per mix and camera
  EXPECT_EQ(records[1], records[0]);
  EXPECT_EQ(records[2], records[0]);
  EXPECT_EQ(records[3], records[0]);  // in the background
  for (const auto& record : records[0]) {
    const std::string file = record["file"];
    const auto first = files::read_exr(root / "0" / file);
    for (const char* other : {"1", "2", "3"}) {
      const auto read = files::read_exr(root / other / file);
      ASSERT_EQ(read.channel_names, first.channel_names) << file;
      for (std::size_t c = 0; c < read.channels.size(); ++c)
        EXPECT_EQ(0, std::memcmp(read.channels[c].data(), first.channels[c].data(), read.channels[c].size() * 4))
            << other << " " << file;
    }
  }
  const fs::path bad = root / "bad";
  fs::create_directories(bad);
  Journal journal(bad / "journal.jsonl", nullptr);
  EXPECT_THROW(write_derived_data(bad, plan, sums, 0.99, journal, nullptr, {-1, -1}), std::invalid_argument);
  EXPECT_FALSE(fs::exists(bad / "derived"));
  fs::remove_all(root);
}

// The nice value of each of this process's threads but the caller's, from /proc/self/task/<tid>/stat
// (field 19, after the command name's closing parenthesis).
std::vector<int> other_threads_nice(pid_t caller) {
  std::vector<int> nice;
  for (const auto& task : fs::directory_iterator("/proc/self/task")) {
    if (task.path().filename() == std::to_string(caller)) continue;
    std::ifstream in(task.path() / "stat");
    std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto close = stat.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream fields(stat.substr(close + 2));
    std::string field;
    for (int f = 3; f <= 19 && fields >> field; ++f)
      if (f == 19) nice.push_back(std::stoi(field));
  }
  return nice;
}

// In the background the files are made by threads at nice 19 (seen in
// /proc while they work) and the caller's own priority is what it was.
TEST(DerivedData, InTheBackgroundTheWorkersRunAtTheLowestPriorityAndTheCallerKeepsItsOwn) {
  const SessionPlan plan = standard_plan();
  const SessionFrameSums sums = sums_of(plan, 48, 32);
  const fs::path folder = testing::fresh_directory("derived-background");
  const pid_t caller = gettid();
  const int caller_nice = getpriority(PRIO_PROCESS, static_cast<id_t>(caller));
  std::atomic<bool> writing{true};
  int highest_nice_seen = -21;
  std::thread watcher([&] {
    while (writing) {
      for (int nice : other_threads_nice(caller)) highest_nice_seen = std::max(highest_nice_seen, nice);
      std::this_thread::sleep_for(std::chrono::microseconds(500));  // the workers get the cores between looks
    }
  });
  {
    Journal journal(folder / "journal.jsonl", nullptr);
    write_derived_data(folder, plan, sums, 0.99, journal, nullptr, {1, -1, true});
  }
  writing = false;
  watcher.join();
  EXPECT_EQ(highest_nice_seen, 19);
  EXPECT_EQ(getpriority(PRIO_PROCESS, static_cast<id_t>(caller)), caller_nice);
  EXPECT_EQ(derived_records(folder / "journal.jsonl").size(), 7u * 2 + 3 * 2);
  fs::remove_all(folder);
}

// A write that fails (the storage budget is full) is thrown after the files
// before it were recorded, and no record names a file that is not there.
TEST(DerivedData, AFailedWriteRecordsOnlyTheFilesThatExist) {
  const SessionPlan plan = standard_plan();
  const SessionFrameSums sums = sums_of(plan, 64, 48);
  const fs::path folder = testing::fresh_directory("derived-full");
  files::StorageBudget budget(20000);  // a few of the small files
  {
    Journal journal(folder / "journal.jsonl", nullptr);
    EXPECT_THROW(write_derived_data(folder, plan, sums, 0.99, journal, &budget, {2, -1}), files::StorageFullError);
  }
  const auto records = derived_records(folder / "journal.jsonl");
  EXPECT_LT(records.size(), 20u);
  for (const auto& record : records) EXPECT_TRUE(fs::exists(folder / record["file"].get<std::string>())) << record;
  fs::remove_all(folder);
}

// One albedo (albedo.hpp): derived/albedo-*.exr is ρ/g·(subject − dark)/(white − dark)
// with g the subject's exposure over its white's, as the estimator's
// captures are normalised; NaN where the white is no brighter than the dark.
TEST(DerivedData, AlbedoDividesByTheSubjectsExposureRatioAsTheEstimatorDoes) {
  const SessionPlan plan = standard_plan();
  SessionFrameSums sums;
  std::uint64_t index = 0;
  for (std::size_t s = 0; s < plan.steps.size(); ++s) {
    const Step& step = plan.steps[s];
    FrameRecord record;
    record.index = index++;
    record.step = step.name, record.step_index = static_cast<int>(s), record.role = step.role;
    record.camera = "cam0";
    record.width = 4, record.height = 2;
    record.pixel_format = drivers::PixelFormat::kBayerRG12;
    // The D65' subject at twice its white's exposure; the others at one.
    const bool long_subject = step.role == StepRole::kSubject && step.illumination.mix == "d65";
    record.exposure_us = long_subject ? 2000 : 1000;
    const std::uint16_t level = step.role == StepRole::kDark ? 64 : step.role == StepRole::kWhite ? 3000 : 1500;
    std::vector<std::uint8_t> samples(4 * 2 * 2);
    for (std::size_t i = 0; i < 8; ++i) {
      // Sample 0: a white no brighter than the dark (no reference).
      const std::uint16_t value = i == 0 && step.role == StepRole::kWhite ? 64 : level;
      std::memcpy(&samples[2 * i], &value, 2);
    }
    sums.add(record, samples);
  }
  const fs::path folder = testing::fresh_directory("derived-albedo");
  {
    Journal journal(folder / "journal.jsonl", nullptr);
    write_derived_data(folder, plan, sums, 0.99, journal, nullptr, {1, -1});
  }
  const double unit = 0.99 * (1500.0 - 64) / (3000.0 - 64);
  std::map<std::string, double> ratio_of;  // by file
  for (const auto& record : derived_records(folder / "journal.jsonl"))
    if (record["kind"] == "albedo") ratio_of[record["file"]] = record["exposure_ratio"];
  ASSERT_EQ(ratio_of.size(), 3u);
  EXPECT_EQ(ratio_of.at("derived/albedo-d65-cam0.exr"), 2.0);
  for (const auto& [file, ratio] : ratio_of) {
    if (file != "derived/albedo-d65-cam0.exr") EXPECT_EQ(ratio, 1.0) << file;
    const auto image = files::read_exr(folder / file);
    ASSERT_EQ(image.channels.size(), 1u) << file;
    EXPECT_TRUE(std::isnan(image.channels[0][0])) << file;
    for (std::size_t i = 1; i < 8; ++i) EXPECT_NEAR(image.channels[0][i], unit / ratio, 1e-6) << file << " sample " << i;
  }
  fs::remove_all(folder);
}

}  // namespace
}  // namespace chromo::session
