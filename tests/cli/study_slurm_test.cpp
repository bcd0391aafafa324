// `chromo study run --on slurm` on a real single-node Slurm cluster started
// for this test in a folder of its own (tests/support/slurm_cluster.sh:
// Debian's slurmctld, slurmd and munge, no systemd). Seven small stored
// sessions, one of them corrupt, as a job array of three tasks of up to three
// sessions. Checks: every map identical to a serial `chromo estimate`; the
// corrupt session fails alone and is named; a task killed mid-way (held
// after its first session, then scancelled) leaves exactly its unfinished
// sessions, which the resumed study estimates (counted), and nothing is lost
// or duplicated. The cluster is stopped and its folder deleted even when a
// check fails (ClusterGuard). Ports 6817/6818 are fixed: ctest runs this
// test under the resource lock "slurm_cluster".
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <functional>
#include <thread>

#include "run_chromo.hpp"
#include "study_test_support.hpp"

namespace chromo {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using namespace study_testing;

const std::string kClusterScript = std::string(CHROMO_SOURCE_DIR) + "/tests/support/slurm_cluster.sh";

// Starts the cluster; stops it and deletes its folder when it goes out of scope.
struct ClusterGuard {
  fs::path dir;
  bool started = false;
  explicit ClusterGuard(fs::path folder) : dir(std::move(folder)) {
    const std::string command = kClusterScript + " start " + dir.string() + " > " + (dir.string() + ".log") + " 2>&1";
    started = std::system(command.c_str()) == 0;
    if (started) ::setenv("SLURM_CONF", (dir / "slurm.conf").c_str(), 1);
  }
  ~ClusterGuard() {
    const std::string command = kClusterScript + " stop " + dir.string() + " >/dev/null 2>&1";
    [[maybe_unused]] const int ignored = std::system(command.c_str());
    fs::remove(dir.string() + ".log");
  }
  std::string log() const {
    std::ifstream in(dir.string() + ".log");
    return {std::istreambuf_iterator<char>(in), {}};
  }
};

// Waits (up to 60 s of polling) for `condition`; false if it never held.
template <class F>
bool eventually(F&& condition) {
  for (int i = 0; i < 3000; ++i) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

nlohmann::json read_json_or_null(const fs::path& file) {
  try {
    return read_json(file);
  } catch (const std::exception&) {
    return nullptr;
  }
}

std::string job_of(const std::string& output) {
  const auto at = output.find("submitted job ");
  if (at == std::string::npos) return "";
  const auto start = at + std::string("submitted job ").size();
  return output.substr(start, output.find(':', start) - start);
}

// Deletes the test's folder last (after the cluster in it is stopped).
struct FolderGuard {
  fs::path dir;
  ~FolderGuard() {
    std::error_code ignored;
    fs::remove_all(dir, ignored);
  }
};

TEST(SlurmStudy, JobArrayMatchesSerialEstimatesSurvivesAKilledTaskAndResumes) {
  const FolderGuard root_guard{testing::fresh_directory("study-slurm")};
  const fs::path& root = root_guard.dir;
  ClusterGuard cluster(root / "cluster");
  ASSERT_TRUE(cluster.started) << cluster.log();

  const auto folders = make_study_sessions(root / "sessions", 6);
  const fs::path manifest = root / "manifest.txt", out = root / "study";
  write_manifest(manifest, folders);
  const std::string cache = table_cache().string();
  // The serial estimates first (all cores), which also fill the table cache the nodes use.
  for (const auto& folder : folders) {
    if (folder.filename() == "broken") continue;
    const Result r = run_chromo("estimate " + folder.string() + " --out " + (root / "reference" / folder.filename()).string() +
                                " --cache-dir " + cache);
    ASSERT_EQ(r.exit_status, 0) << r.output;
  }

  // Held from the start, so that task 0 can be stopped after exactly one session.
  ASSERT_EQ(run_chromo("study hold " + out.string()).exit_status, 0);
  const std::string run = "study run " + manifest.string() + " --out " + out.string() +
                          " --on slurm --sessions-per-task 3 --cpus-per-task 1 --node-cache " + cache +
                          " --poll-seconds 0.2";
  const Result submitted = run_chromo(run + " --no-wait");
  ASSERT_EQ(submitted.exit_status, 0) << submitted.output;
  EXPECT_THAT(submitted.output, HasSubstr("7 of 7 sessions to estimate"));
  EXPECT_THAT(submitted.output, HasSubstr(": 3 tasks of up to 3 sessions, 1 CPUs"));
  const std::string job = job_of(submitted.output);
  ASSERT_FALSE(job.empty()) << submitted.output;
  const std::string script = [&] {
    std::ifstream in(out / "slurm" / "study.sbatch");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  EXPECT_THAT(script, HasSubstr("#SBATCH --array=0-2\n"));
  EXPECT_THAT(script, HasSubstr("#SBATCH --cpus-per-task=1\n"));
  EXPECT_THAT(script, HasSubstr("#SBATCH --mem="));
  EXPECT_THAT(script, HasSubstr("--threads \"${SLURM_CPUS_PER_TASK:-1}\""));

  // Task 0: released, it starts s1; held again while s1 runs, it stops after
  // s1 (or, on a machine so loaded that s1 ended before the hold, after s2);
  // then it is killed: its unfinished sessions are left without records.
  const fs::path task0 = out / "tasks" / ("slurm-" + job + "-0.json");
  auto task0_record = [&] { return read_json_or_null(task0); };
  auto task0_is = [&](const std::function<bool(const nlohmann::json&)>& condition) {
    return eventually([&] {
      const auto t = task0_record();
      return t.is_object() && condition(t);
    });
  };
  ASSERT_TRUE(task0_is([](const auto& t) { return t["state"] == "held" && t["done"] == 0; })) << task0_record().dump();
  ASSERT_EQ(run_chromo("study release " + out.string()).exit_status, 0);
  ASSERT_TRUE(task0_is([](const auto& t) { return t["state"] == "running" && t["current"] == "s1"; }))
      << task0_record().dump();
  ASSERT_EQ(run_chromo("study hold " + out.string()).exit_status, 0);
  ASSERT_TRUE(task0_is([](const auto& t) { return t["state"] == "held" && t["done"].template get<int>() >= 1; }))
      << task0_record().dump();
  const int killed_after = task0_record()["done"].get<int>();
  ASSERT_LT(killed_after, 3) << "task 0 finished before it could be killed";
  const int unfinished = 3 - killed_after;
  const Result status = run_chromo("study status " + out.string());
  EXPECT_THAT(status.output, HasSubstr("; held (chromo study release)"));
  EXPECT_THAT(status.output, HasSubstr("task " + job + "_0 on "));
  ASSERT_EQ(std::system(("scancel " + job + "_0").c_str()), 0);
  ASSERT_TRUE(eventually([&] {
    const Result q = run_chromo("study status " + out.string());
    return q.output.find("task " + job + "_0 ") == std::string::npos;
  }));
  ASSERT_EQ(run_chromo("study release " + out.string()).exit_status, 0);

  const Result waited = run_chromo("study wait " + out.string() + " --poll-seconds 0.2");
  EXPECT_EQ(waited.exit_status, 1) << waited.output;  // broken failed, task 0's rest not estimated
  EXPECT_THAT(waited.output, HasSubstr("7 sessions: " + std::to_string(6 - unfinished) + " done, 1 failed, " +
                                       std::to_string(unfinished) + " not estimated"));
  EXPECT_THAT(waited.output, HasSubstr("failed: broken: "));
  const std::vector<std::string> task0_sessions{"s1", "s2", "s3"};
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(fs::exists(out / "records" / (task0_sessions[i] + ".json")), i < killed_after) << task0_sessions[i];
  EXPECT_EQ(read_json(out / "records" / "s1.json").value("task", -1), 0);

  // Resume: only the killed task's unfinished sessions go to the cluster.
  const Result resumed = run_chromo(run);
  EXPECT_EQ(resumed.exit_status, 1) << resumed.output;
  EXPECT_THAT(resumed.output, HasSubstr(std::to_string(unfinished) + " of 7 sessions to estimate"));
  EXPECT_THAT(resumed.output, HasSubstr(": 1 tasks of up to 3 sessions"));
  EXPECT_THAT(resumed.output, HasSubstr("7 sessions: 6 done, 1 failed, 0 not estimated"));
  const std::string resume_job = job_of(resumed.output);
  ASSERT_FALSE(resume_job.empty());
  std::map<std::string, int> by_run;
  for (const auto& folder : folders)
    ++by_run[read_json(out / "records" / (folder.filename().string() + ".json")).value("run", "")];
  EXPECT_EQ(by_run, (std::map<std::string, int>{{"slurm-" + job, 7 - unfinished}, {"slurm-" + resume_job, unfinished}}));
  for (int i = killed_after; i < 3; ++i)
    EXPECT_EQ(read_json(out / "records" / (task0_sessions[i] + ".json")).value("run", ""), "slurm-" + resume_job);

  // The table: every session once (s2 twice: two cameras), nothing lost or duplicated.
  const auto rows = read_table(out / "study.csv");
  std::map<std::string, int> rows_of;
  for (const auto& row : rows) ++rows_of[row.at("session") + "/" + row.at("state")];
  EXPECT_EQ(rows_of, (std::map<std::string, int>{{"s1/done", 1}, {"s2/done", 2}, {"s3/done", 1}, {"s4/done", 1},
                                                 {"s5/done", 1}, {"s6/done", 1}, {"broken/failed", 1}}));
  const auto broken = std::find_if(rows.begin(), rows.end(), [](const auto& r) { return r.at("session") == "broken"; });
  EXPECT_THAT(broken->at("error"), HasSubstr("subject_w57"));

  // Every map identical to the serial estimate's.
  for (const auto& folder : folders) {
    const std::string name = folder.filename().string();
    if (name == "broken") continue;
    const auto files = maps_files(root / "reference" / name);
    ASSERT_EQ(maps_files(out / "sessions" / name), files) << name;
    for (const auto& file : files) expect_identical_maps(root / "reference" / name / file, out / "sessions" / name / file);
  }
  // Nothing half-written is left in the study folder.
  for (const auto& entry : fs::recursive_directory_iterator(out))
    EXPECT_EQ(entry.path().filename().string().rfind(".work-", 0), std::string::npos) << entry.path();
}

}  // namespace
}  // namespace chromo
