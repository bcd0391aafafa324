// A study's throughput on this machine (docs/study.md "Throughput"): the
// same stored sessions estimated by `chromo study run` on a single-node
// Slurm cluster started for the bench (tests/support/slurm_cluster.sh) as
// one array task with every core and as two tasks with one core each, and
// by the local backend; then one large session of each plan (`--large-plans`:
// the method's standard plan and the six-LED multispectral plan; two cameras,
// a 2448×2048 sensor each: the lab's 5-MP cameras) through the local backend,
// for the per-session cost (on 2 threads and on 1) and peak memory a study
// of many such sessions is estimated from.
//
//   study_bench [--sessions N] [--scene-size S] [--cameras C] [--no-slurm] [--no-large]
//               [--work DIR] [--out FILE]
//
// Sessions: the method's standard plan rendered in the virtual lab
// (tests/support/rendered_session_folder.hpp), an S×S scene on a 2S×2S
// sensor, C cameras. The table cache is warmed first (one `chromo estimate`),
// so every run loads the same tables. Wall clock from `chromo study run`'s
// start to its end (hashing, submission, Slurm's scheduling, the estimates,
// the table); the records' seconds per session and peak RSS.
#include "bench_cli.hpp"
#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <sys/wait.h>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "../tests/support/rendered_session_folder.hpp"
#include "guarded_main.hpp"

namespace {

namespace fs = std::filesystem;
using namespace chromo;

std::string run(const std::string& command, int* status = nullptr) {
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  std::string output;
  char buffer[4096];
  while (std::size_t n = std::fread(buffer, 1, sizeof buffer, pipe)) output.append(buffer, n);
  const int s = ::pclose(pipe);
  if (status) *status = WIFEXITED(s) ? WEXITSTATUS(s) : -1;
  return output;
}

struct Measured {
  std::string label;
  double wall_s = 0;
  std::size_t sessions = 0;
  double mean_session_s = 0, max_session_s = 0, max_rss_mb = 0, mean_cpu_s = 0;
};

Measured measure(const std::string& label, const std::string& command, const fs::path& study, std::size_t sessions) {
  const auto start = std::chrono::steady_clock::now();
  int status = 0;
  const std::string output = run(command, &status);
  Measured m{label, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), sessions};
  if (status != 0) throw std::runtime_error(label + ": chromo study run exited " + std::to_string(status) + ":\n" + output);
  for (const auto& entry : fs::directory_iterator(study / "records")) {
    std::ifstream in(entry.path());
    const auto record = nlohmann::json::parse(in);
    m.mean_session_s += record.value("seconds", 0.0) / sessions;
    m.max_session_s = std::max(m.max_session_s, record.value("seconds", 0.0));
    m.mean_cpu_s += record.value("cpu_seconds", 0.0) / sessions;
    m.max_rss_mb = std::max(m.max_rss_mb, record.value("max_rss_mb", 0.0));
  }
  return m;
}

int bench_main(int argc, char** argv) {
  CLI::App app{"study_bench: a study's throughput against Slurm tasks on this machine"};
  int sessions = 8, scene_size = 192, cameras = 2;
  bool slurm = true, large = true;
  std::vector<std::string> large_plans{"standard", "multispectral"};
  std::vector<int> large_scene{1224, 1024};
  std::string work = (fs::temp_directory_path() / "chromo-study-bench").string();
  std::string out_file = std::string(CHROMO_BENCH_RESULTS) + "/study_bench_output.txt";
  app.add_option("--sessions", sessions, "sessions of the small study")->check(CLI::Range(2, 1000));
  app.add_option("--scene-size", scene_size, "scene pixels per side (the sensor has twice as many)")->check(CLI::Range(16, 2048));
  app.add_option("--cameras", cameras, "cameras per session")->check(CLI::Range(1, 4));
  app.add_flag("!--no-slurm", slurm, "skip the Slurm runs");
  app.add_flag("!--no-large", large, "skip the 5-MP two-camera sessions");
  app.add_option("--large-scene", large_scene, "the large sessions' scene W H (the sensor has twice as many per side)")
      ->expected(2);
  app.add_option("--large-plans", large_plans, "the 5-MP sessions' plans (standard, multispectral)")->delimiter(',');
  app.add_option("--work", work, "scratch folder (deleted first)");
  app.add_option("--out", out_file, "where the printout goes too");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  const fs::path root(work);
  fs::remove_all(root);
  fs::create_directories(root / "sessions");
  const std::string chromo = CHROMO_CLI, cache = (root / "cache").string();
  std::ostringstream report;
  auto say = [&report](const std::string& line) {
    std::cout << line << std::endl;
    report << line << "\n";
  };
  say(fmt::format("study_bench: {} sessions, {}x{} sensor, {} camera(s), the method's standard plan; {} cores; load average {}",
                  sessions, 2 * scene_size, 2 * scene_size, cameras, std::thread::hardware_concurrency(),
                  run("cut -d' ' -f1-3 /proc/loadavg").substr(0, 14)));
  std::ofstream manifest(root / "manifest.txt");
  for (int i = 0; i < sessions; ++i) {
    testing::RenderedSessionFolder spec;
    spec.name = fmt::format("v{:03d}", i);
    spec.seed = 300 + i;
    spec.scene_size = scene_size;
    spec.cameras = cameras;
    manifest << testing::write_rendered_session_folder(root / "sessions", spec).string() << "\n";
  }
  manifest.close();
  run(chromo + " estimate " + (root / "sessions" / "v000").string() + " --out " + (root / "warm").string() +
      " --cache-dir " + cache);
  std::vector<Measured> results;
  const std::string common = chromo + " study run " + (root / "manifest.txt").string() + " --poll-seconds 0.2";
  results.push_back(measure("local, 2 threads", common + " --on local --threads 2 --cache-dir " + cache + " --out " +
                                                    (root / "local").string(), root / "local", sessions));
  if (slurm) {
    const std::string script = std::string(CHROMO_SOURCE_DIR) + "/tests/support/slurm_cluster.sh";
    const fs::path cluster = root / "cluster";
    int status = 0;
    const std::string started = run(script + " start " + cluster.string(), &status);
    if (status != 0) throw std::runtime_error("starting the Slurm cluster: " + started);
    ::setenv("SLURM_CONF", (cluster / "slurm.conf").c_str(), 1);
    try {
      for (int tasks : {1, 2}) {
        const fs::path study = root / fmt::format("slurm-{}", tasks);
        const int per_task = (sessions + tasks - 1) / tasks;
        results.push_back(measure(fmt::format("slurm, {} task(s) x {} CPU(s)", tasks, 2 / tasks),
                                  common + fmt::format(" --on slurm --sessions-per-task {} --cpus-per-task {}", per_task,
                                                       2 / tasks) +
                                      " --node-cache " + cache + " --out " + study.string(),
                                  study, sessions));
      }
    } catch (...) {
      run(script + " stop " + cluster.string());
      throw;
    }
    run(script + " stop " + cluster.string());
  }
  say("backend                       wall s   sessions/min   mean s/session   max s/session   CPU s/session   peak RSS MB");
  for (const auto& m : results)
    say(fmt::format("{:<28} {:8.2f} {:13.2f} {:16.2f} {:15.2f} {:15.2f} {:13.0f}", m.label, m.wall_s,
                    60.0 * m.sessions / m.wall_s, m.mean_session_s, m.max_session_s, m.mean_cpu_s, m.max_rss_mb));
  for (const std::string& plan : large ? large_plans : std::vector<std::string>{}) {
    testing::RenderedSessionFolder spec;
    spec.name = "large-" + plan;
    spec.seed = 400;
    spec.scene_size = large_scene.at(0);
    spec.scene_height = large_scene.at(1);
    spec.cameras = 2;
    spec.plan = plan;
    const auto render_start = std::chrono::steady_clock::now();
    const fs::path folder = testing::write_rendered_session_folder(root / "large-sessions", spec);
    const double render_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - render_start).count();
    const fs::path manifest_file = root / ("large-manifest-" + plan + ".txt");
    std::ofstream(manifest_file) << folder.string() << "\n";
    std::uint64_t frame_bytes = 0;
    std::size_t frames = 0;
    for (const auto& entry : fs::recursive_directory_iterator(folder / "frames"))
      if (entry.is_regular_file()) frame_bytes += entry.file_size(), ++frames;
    say(fmt::format("large session, {} plan: 2 cameras, {}x{} BayerRG12, {} frames each: {:.0f} MB of frames "
                    "(rendered in {:.1f} s)", plan, 2 * spec.scene_size, 2 * spec.scene_height, frames / 2,
                    frame_bytes / 1048576.0, render_s));
    // The first run builds the tables of this session's sets (the node-local
    // cache's first use); then warm; then on one thread (the session's cost as
    // an array task of one CPU runs it).
    const char* labels[] = {"tables cold", "tables warm", "1 thread"};
    for (int pass = 0; pass < 3; ++pass) {
      const fs::path study = root / fmt::format("large-{}-{}", plan, pass);
      const Measured m = measure(labels[pass],
                                 chromo + " study run " + manifest_file.string() + " --on local --threads " +
                                     (pass == 2 ? "1" : "2") + " --cache-dir " + cache + " --out " + study.string(),
                                 study, 1);
      say(fmt::format("  {:<12} {:7.2f} s in the record, {:7.2f} s wall, {:7.2f} CPU s, peak RSS {:.0f} MB", m.label,
                      m.mean_session_s, m.wall_s, m.mean_cpu_s, m.max_rss_mb));
      // Where each camera's time went (its summary.json; writing is not in it).
      for (const char* camera : {"cam0", "cam1"}) {
        std::ifstream in(study / "sessions" / spec.name / camera / "summary.json");
        const auto summary = nlohmann::ordered_json::parse(in);
        std::string split;
        for (const auto& [stage, seconds] : summary["timings_s"].items())
          split += fmt::format(" {} {:.2f}", stage, seconds.get<double>());
        say(fmt::format("    {}:{}", camera, split));
      }
    }
  }
  std::ofstream(out_file) << report.str();
  fs::remove_all(root);
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return chromo::bench::guarded_main("study_bench", bench_main, argc, argv); }
