// `chromo study` on this machine (--on local), through the real chromo binary
// on real session folders made for the test (tests/support/rendered_session_folder.hpp):
// every session's maps equal a serial `chromo estimate` of it, the table's
// values are the summaries', a corrupt session fails alone and is named,
// a resumed study estimates only what is not done, and bad input is refused
// naming it, changing nothing.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include <cmath>

#include "run_chromo.hpp"
#include "study_test_support.hpp"

namespace chromo {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using namespace study_testing;

struct LocalStudy : ::testing::Test {
  static inline fs::path root, manifest;
  static inline std::vector<fs::path> folders;
  static void SetUpTestSuite() {
    root = testing::fresh_directory("study-local");
    folders = make_study_sessions(root / "sessions", 3);
    manifest = root / "manifest.txt";
    write_manifest(manifest, folders);
  }
  static void TearDownTestSuite() {
    std::error_code ignored;
    fs::remove_all(root, ignored);
  }
  static std::string cache() { return " --cache-dir " + table_cache().string(); }
};

// Session name → the run ids in the records.
std::map<std::string, std::string> record_runs(const fs::path& dir) {
  std::map<std::string, std::string> runs;
  for (const auto& entry : fs::directory_iterator(dir / "records"))
    runs[entry.path().stem().string()] = read_json(entry.path()).value("run", "");
  return runs;
}

TEST_F(LocalStudy, MapsEqualSerialEstimatesAndTheTableHoldsTheSummaries) {
  const fs::path out = root / "study-a";
  const Result run = run_chromo("study run " + manifest.string() + " --out " + out.string() + " --threads 1" + cache());
  // One session failed: the study is incomplete (exit 1), the others are done.
  EXPECT_EQ(run.exit_status, 1) << run.output;
  EXPECT_THAT(run.output, HasSubstr("3 done, 1 failed"));
  EXPECT_THAT(run.output, HasSubstr("failed: broken: "));

  const auto rows = read_table(out / "study.csv");
  ASSERT_EQ(rows.size(), 5u);  // s1, s2 (two cameras), s3, broken
  std::map<std::string, int> rows_of;
  for (const auto& row : rows) ++rows_of[row.at("session")];
  EXPECT_EQ(rows_of, (std::map<std::string, int>{{"s1", 1}, {"s2", 2}, {"s3", 1}, {"broken", 1}}));

  for (const auto& folder : folders) {
    const std::string name = folder.filename().string();
    if (name == "broken") continue;
    // The serial estimate on every core; the study ran one thread per session.
    const fs::path reference = root / ("reference-" + name);
    const Result estimate = run_chromo("estimate " + folder.string() + " --out " + reference.string() + cache());
    ASSERT_EQ(estimate.exit_status, 0) << estimate.output;
    const fs::path maps_dir = out / "sessions" / name;
    const auto files = maps_files(reference);
    ASSERT_EQ(maps_files(maps_dir), files) << name;
    ASSERT_EQ(files.size(), name == "s2" ? 2u : 1u);
    for (const auto& file : files) {
      expect_identical_maps(reference / file, maps_dir / file);
      // The table's row of that camera holds the summary's numbers.
      const auto summary = read_json(maps_dir / file.parent_path() / "summary.json");
      const std::string camera = summary.value("camera", "");
      const auto row = std::find_if(rows.begin(), rows.end(), [&](const auto& r) {
        return r.at("session") == name && (files.size() == 1 || r.at("camera") == camera);
      });
      ASSERT_NE(row, rows.end()) << name << " " << camera;
      EXPECT_EQ(row->at("state"), "done");
      EXPECT_EQ(row->at("subject"), "subject " + name.substr(1));
      EXPECT_EQ(row->at("plan"), "standard");
      EXPECT_EQ(std::stoull(row->at("pixels")), summary["pixels"].get<std::uint64_t>());
      for (const auto& [flag, count] : summary["flag_counts"].items())
        EXPECT_EQ(std::stoull(row->at("flag_" + flag)), count.get<std::uint64_t>()) << flag;
      for (const auto& [illuminant, stats] : summary["relit_delta_e94"]["by_illuminant"].items())
        for (const char* stat : {"mean", "median", "p95"})
          EXPECT_EQ(std::stod(row->at("de94_" + illuminant + "_" + stat)), stats[stat].get<double>())
              << illuminant << " " << stat;
      // Cm's mean over the explained skin, from the maps.
      const files::FloatImage maps = files::read_exr(maps_dir / file);
      double sum = 0;
      std::size_t n = 0;
      for (std::size_t i = 0; i < maps.channel("flags").size(); ++i)
        if (maps.channel("flags")[i] == 0.0f) sum += maps.channel("Cm")[i], ++n;
      ASSERT_GT(n, 0u);
      EXPECT_NEAR(std::stod(row->at("Cm_mean")), sum / n, 1e-12 * std::abs(sum / n));
      EXPECT_LE(std::stod(row->at("Cm_p05")), std::stod(row->at("Cm_median")));
      EXPECT_LE(std::stod(row->at("Cm_median")), std::stod(row->at("Cm_p95")));
      EXPECT_EQ(row->at("maps"), "sessions/" + name + (files.size() == 1 ? "" : "/" + camera));
    }
  }
  const auto broken = std::find_if(rows.begin(), rows.end(), [](const auto& r) { return r.at("session") == "broken"; });
  EXPECT_EQ(broken->at("state"), "failed");
  EXPECT_THAT(broken->at("error"), HasSubstr("subject_w57"));
  EXPECT_FALSE(fs::exists(out / "sessions" / "broken"));

  // status names the failure.
  const Result status = run_chromo("study status " + out.string());
  EXPECT_EQ(status.exit_status, 0) << status.output;
  EXPECT_THAT(status.output, HasSubstr("4 sessions: 3 done, 1 failed, 0 not estimated"));
  EXPECT_THAT(status.output, HasSubstr("failed: broken: "));
}

TEST_F(LocalStudy, ResumeEstimatesOnlyWhatIsNotDoneWithTheSameInputs) {
  const fs::path out = root / "study-b";
  const std::string command = "study run " + manifest.string() + " --out " + out.string() + cache();
  ASSERT_EQ(run_chromo(command).exit_status, 1);
  const auto first = record_runs(out);
  ASSERT_EQ(first.size(), 4u);

  // Nothing to do: every session done (or failed on these inputs) is skipped.
  Result again = run_chromo(command);
  EXPECT_THAT(again.output, HasSubstr("estimated 0 (0 done, 0 failed), skipped 4"));
  EXPECT_EQ(record_runs(out), first);

  // An interrupted run: s3's record lost, its maps half replaced, a work folder left behind.
  fs::remove(out / "records" / "s3.json");
  fs::remove(out / "sessions" / "s3" / "maps.exr");
  fs::create_directories(out / "sessions" / ".work-s3@elsewhere-12345");
  // s2's record kept but one camera's maps gone: estimated again.
  fs::remove(out / "sessions" / "s2" / "cam1" / "maps.exr");
  // s1's inputs changed: its LED library rewritten (the same library, other bytes).
  std::ofstream(folders[0] / "results" / "led_library.json", std::ios::app) << "\n";
  again = run_chromo(command);
  EXPECT_THAT(again.output, HasSubstr("estimated 3 (3 done, 0 failed), skipped 1"));
  const auto second = record_runs(out);
  ASSERT_EQ(second.size(), 4u);
  for (const auto& [name, run] : second) {
    if (name == "s1" || name == "s2" || name == "s3") EXPECT_NE(run, first.at(name)) << name;
    else EXPECT_EQ(run, first.at(name)) << name;
  }
  EXPECT_TRUE(fs::exists(out / "sessions" / "s3" / "maps.exr"));
  EXPECT_TRUE(fs::exists(out / "sessions" / "s2" / "cam1" / "maps.exr"));
  EXPECT_FALSE(fs::exists(out / "sessions" / ".work-s3@elsewhere-12345"));
  EXPECT_EQ(read_table(out / "study.csv").size(), 5u);

  // Other options are other inputs: every session again, the failed one too.
  again = run_chromo(command + " --model 4d");
  EXPECT_THAT(again.output, HasSubstr("estimated 4 (3 done, 1 failed), skipped 0"));
}

TEST_F(LocalStudy, BadInputIsRefusedNamingItAndChangesNothing) {
  const fs::path out = root / "study-bad";
  auto expect_refused = [&](const std::string& arguments, const std::string& message) {
    const Result r = run_chromo("study run " + arguments);
    EXPECT_EQ(r.exit_status, 2) << arguments << "\n" << r.output;
    EXPECT_THAT(r.output, HasSubstr(message)) << arguments;
    EXPECT_FALSE(fs::exists(out)) << arguments;
  };
  expect_refused((root / "no-such-manifest.txt").string() + " --out " + out.string(), "no such manifest file");
  expect_refused((root / "nothing-*").string() + " --out " + out.string(), "the glob matches no session folder");
  const fs::path bad_line = root / "bad-line.txt";
  std::ofstream(bad_line) << folders[0].string() << "\n\n" << (root / "missing-session").string() << "\n";
  expect_refused(bad_line.string() + " --out " + out.string(), "bad-line.txt:3: \"" + (root / "missing-session").string());
  const fs::path twice = root / "twice.txt";
  std::ofstream(twice) << folders[0].string() << "\n" << folders[0].string() << "\n";
  expect_refused(twice.string() + " --out " + out.string(), "twice.txt:2: a second session named \"s1\"");
  expect_refused(manifest.string() + " --out " + out.string() + " --camera " + (root / "no-camera.csv").string(),
                 "no-camera.csv");
  expect_refused(manifest.string() + " --out " + out.string() + " --method fastest", "--method");
  expect_refused(manifest.string() + " --out " + out.string() + " --on cloud", "--on");
  // An output folder that is not a study is never written into.
  const fs::path other = root / "not-a-study";
  fs::create_directories(other);
  std::ofstream(other / "notes.txt") << "keep\n";
  const Result r = run_chromo("study run " + manifest.string() + " --out " + other.string());
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("not a study folder"));
  EXPECT_EQ(std::distance(fs::directory_iterator(other), fs::directory_iterator()), 1);
  // A glob manifest works as a listing does.
  const Result glob = run_chromo("study run '" + (root / "sessions" / "s[13]").string() + "' --out " +
                                 (root / "study-glob").string() + cache());
  EXPECT_EQ(glob.exit_status, 0) << glob.output;
  EXPECT_EQ(read_table(root / "study-glob" / "study.csv").size(), 2u);
}

// Regions: each session's own mask (relative to its folder, {camera} per
// camera); statistics over the explained cells inside it; a session without
// the mask has empty region cells; a mask of the wrong size fails its
// session alone, naming it; a changed mask is a changed input.
TEST_F(LocalStudy, RegionsGiveStatisticsOverEachSessionsMask) {
  constexpr int kCells = 48;  // the maps' size: the 96×96 sensor binned 2×2
  auto write_mask = [](const fs::path& file, int x0, int x1, int size) {
    fs::create_directories(file.parent_path());
    cv::Mat mask(size, size, CV_8U, cv::Scalar(0));
    mask.colRange(x0, x1).setTo(255);
    ASSERT_TRUE(cv::imwrite(file.string(), mask));
  };
  write_mask(folders[0] / "regions" / "cam0" / "cheek.png", 0, kCells / 2, kCells);       // s1: left half
  write_mask(folders[1] / "regions" / "cam0" / "cheek.png", kCells / 2, kCells, kCells);  // s2: right half
  write_mask(folders[1] / "regions" / "cam1" / "cheek.png", 0, kCells, kCells);           // s2 cam1: everything
  // s3: no mask.
  const fs::path out = root / "study-regions";
  const std::string command = "study run " + manifest.string() + " --out " + out.string() +
                              " --region 'cheek=regions/{camera}/cheek.png'" + cache();
  const Result run = run_chromo(command);
  EXPECT_EQ(run.exit_status, 1) << run.output;  // broken
  EXPECT_THAT(run.output, HasSubstr("3 done, 1 failed"));
  const auto rows = read_table(out / "study.csv");
  ASSERT_EQ(rows.size(), 5u);
  for (const auto& row : rows) {
    const std::string name = row.at("session");
    if (name == "broken") continue;
    if (name == "s3") {
      EXPECT_EQ(row.at("Cm_mean@cheek"), "");
      EXPECT_EQ(row.at("explained@cheek"), "");
      continue;
    }
    const std::string camera = row.at("camera");
    const fs::path maps_file = out / row.at("maps") / "maps.exr";
    const files::FloatImage maps = files::read_exr(maps_file);
    ASSERT_EQ(maps.width, kCells);
    const cv::Mat mask = cv::imread((fs::path(row.at("session_folder")) / "regions" / camera / "cheek.png").string(),
                                    cv::IMREAD_GRAYSCALE);
    double sum = 0;
    std::size_t n = 0, everywhere = 0;
    for (int i = 0; i < maps.width * maps.height; ++i)
      if (maps.channel("flags")[i] == 0.0f) {
        ++everywhere;
        if (mask.data[i] != 0) sum += maps.channel("Ch")[i], ++n;
      }
    ASSERT_GT(n, 0u) << name << " " << camera;
    EXPECT_EQ(std::stoull(row.at("explained@cheek")), n) << name << " " << camera;
    EXPECT_NEAR(std::stod(row.at("Ch_mean@cheek")), sum / n, 1e-12 * std::abs(sum / n)) << name << " " << camera;
    if (name == "s2" && camera == "cam1") EXPECT_EQ(n, everywhere);
    else EXPECT_LT(n, everywhere);
  }
  // A changed mask is a changed input: s1 only is estimated again.
  write_mask(folders[0] / "regions" / "cam0" / "cheek.png", 0, kCells / 4, kCells);
  Result again = run_chromo(command);
  EXPECT_THAT(again.output, HasSubstr("estimated 1 (1 done, 0 failed), skipped 3"));
  // A mask of the wrong size fails its session alone, naming the mask.
  write_mask(folders[2] / "regions" / "cam0" / "cheek.png", 0, 10, 20);
  again = run_chromo(command);
  EXPECT_THAT(again.output, HasSubstr("estimated 1 (0 done, 1 failed), skipped 3"));
  EXPECT_THAT(again.output, HasSubstr("failed: s3: region mask " + (folders[2] / "regions" / "cam0" / "cheek.png").string() +
                                      ": 20×20, the maps are 48×48"));
  // A bad --region is bad input.
  const Result bad = run_chromo("study run " + manifest.string() + " --out " + (root / "study-bad-region").string() +
                                " --region cheek");
  EXPECT_EQ(bad.exit_status, 2);
  EXPECT_THAT(bad.output, HasSubstr("--region: \"cheek\" is not NAME=PATH"));
  EXPECT_FALSE(fs::exists(root / "study-bad-region"));
}

}  // namespace
}  // namespace chromo
