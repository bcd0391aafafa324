// chromo study: a study of many stored sessions (docs/study.md). `run`
// estimates every session of a manifest as `chromo estimate SESSION_DIR`
// does, here (--on local) or as a Slurm job array (--on slurm), resumable;
// `status`, `wait`, `hold`, `release`; `task` is what the job array's tasks run.
#include <chrono>
#include <ctime>
#include <iostream>
#include <memory>

#include "chromo/files/bounded_read.hpp"
#include "chromo/session/session_captures.hpp"
#include "commands.hpp"
#include "study_inputs.hpp"
#include "study_runner.hpp"
#include "study_slurm.hpp"
#include "study_table.hpp"

namespace chromo::cli {
namespace {

namespace fs = std::filesystem;
using study::Study;

struct StudyRunOptions {
  std::string manifest, out, on = "local";
  EstimateOptions estimate;
  std::vector<std::string> regions;  // NAME=PATH
  bool retry_failed = false;
  bool wait = true;
  double poll_seconds = 10;
  study::SlurmOptions slurm;
};

// Bad options named before anything is written: the LED library and camera
// sensitivities load (as every session will load them).
void check_estimation_options(const EstimateOptions& options) {
  const std::map<std::string, std::string> camera_of = parse_camera_of(options.camera_of);
  if (!(options.white_reflectance > 0 && options.white_reflectance <= 1))
    throw std::invalid_argument("--white-reflectance: " + std::to_string(options.white_reflectance) +
                                " is not in (0, 1]");
  session::resolve_capture_sources(options.led_library, options.camera, options.white_reflectance, camera_of);
}

std::string run_id() {
  const auto now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y%m%dT%H%M%SZ", &tm);
  return "local-" + std::string(text) + "-" + std::to_string(::getpid());
}

struct StudyCounts {
  std::size_t done = 0, failed = 0, pending = 0;
  std::vector<std::string> failures;  // "name: error"
};
StudyCounts count_records(const Study& s) {
  StudyCounts counts;
  for (const auto& session : s.sessions) {
    const auto record = study::read_record(s.dir, session.name);
    const std::string state = record ? record->value("state", "") : "";
    if (state == "done") ++counts.done;
    else if (state == "failed") {
      ++counts.failed;
      counts.failures.push_back(session.name + ": " + record->value("error", ""));
    } else ++counts.pending;
  }
  return counts;
}

// Gathers the table and says how the study stands; the exit status of run and wait.
int finish(const Study& s) {
  const std::size_t rows = study::write_study_table(s, study::estimator_version());
  const StudyCounts counts = count_records(s);
  std::cout << "study: " << s.sessions.size() << " sessions: " << counts.done << " done, " << counts.failed
            << " failed, " << counts.pending << " not estimated; table " << (s.dir / "study.csv").string() << " ("
            << rows << " rows)\n";
  for (const auto& failure : counts.failures) std::cout << "study: failed: " << failure << "\n";
  return counts.failed == 0 && counts.pending == 0 ? kExitOk : kExitFailure;
}

int run_study(const StudyRunOptions& options) {
  Study s;
  try {
    study::check_output_folder(options.out);
    s.sessions = study::read_manifest(options.manifest);
    check_estimation_options(options.estimate);
    s.dir = fs::absolute(options.out).lexically_normal();
    s.options = options.estimate;
    s.regions = study::parse_regions(options.regions);
    const bool have_squeue = study::run_command("command -v squeue").exit_status == 0;
    if (options.on == "slurm" && (study::run_command("command -v sbatch").exit_status != 0 || !have_squeue))
      throw std::invalid_argument("--on slurm: sbatch or squeue is not on PATH (a Slurm client is needed)");
    // One run of a study at a time: not while its last job is queued or running.
    if (have_squeue && fs::exists(s.dir / "study.json"))
      if (const auto job = study::last_job(s.dir); job && !study::squeue_job(*job).empty())
        throw std::invalid_argument("--out " + s.dir.string() + ": the study's job " + *job +
                                    " is still queued or running (chromo study status); wait for it or scancel it");
  } catch (const std::invalid_argument& e) {
    std::cerr << "chromo study run: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const files::InputFileError& e) {
    std::cerr << "chromo study run: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {  // a data file (LED library, camera CSV) at fault
    std::cerr << "chromo study run: " << e.what() << "\n";
    return kExitBadInput;
  }
  study::write_study(s);
  std::vector<std::string> names;
  for (const auto& session : s.sessions) names.push_back(session.name);
  if (options.on == "local") {
    study::RunnerOptions runner;
    runner.threads = options.estimate.threads;
    runner.cache_dir = options.estimate.cache_dir;
    runner.run = run_id();
    runner.retry_failed = options.retry_failed;
    const study::RunCounts counts = study::run_sessions(s, names, runner, std::cout);
    std::cout << "study: run " << runner.run << ": estimated " << counts.estimated << " (" << counts.done << " done, "
              << counts.failed << " failed), skipped " << counts.skipped << "\n";
    return finish(s);
  }
  // Slurm: only the sessions not done with these inputs go to the cluster.
  std::vector<std::string> pending;
  const std::string version = study::estimator_version();
  for (const auto& session : s.sessions) {
    std::string hash;
    try {
      hash = study::input_hash(session.folder, s.options, version, s.regions);
    } catch (const std::exception&) {
    }
    if (study::session_state(s, session.name, hash, options.retry_failed) == "pending") pending.push_back(session.name);
  }
  std::cout << "study: " << pending.size() << " of " << names.size() << " sessions to estimate\n";
  if (pending.empty()) return finish(s);
  study::SlurmOptions slurm = options.slurm;
  slurm.retry_failed = options.retry_failed;
  const study::SubmittedJob job = study::submit_study(s, pending, slurm);
  std::cout << "study: submitted job " << job.job_id << ": " << job.tasks << " tasks of up to "
            << slurm.sessions_per_task << " sessions, " << slurm.cpus_per_task << " CPUs and " << job.mem_mb
            << " MB each (" << job.script.string() << ")\n" << std::flush;
  if (!options.wait) return kExitOk;
  study::wait_for_job(s, job.job_id, options.poll_seconds, std::cout);
  return finish(s);
}

template <class F>
int guarded(const char* command, F&& body) {
  try {
    return body();
  } catch (const std::invalid_argument& e) {
    std::cerr << "chromo study " << command << ": " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "chromo study " << command << ": " << e.what() << "\n";
    return kExitFailure;
  }
}

int study_status(const std::string& dir) {
  const Study s = study::read_study(dir);
  const StudyCounts counts = count_records(s);
  std::cout << "study " << s.dir.string() << ": " << s.sessions.size() << " sessions: " << counts.done << " done, "
            << counts.failed << " failed, " << counts.pending << " not estimated"
            << (fs::exists(study::hold_file(s.dir)) ? "; held (chromo study release)" : "") << "\n";
  for (const auto& failure : counts.failures) std::cout << "failed: " << failure << "\n";
  if (const auto job = study::last_job(s.dir)) {
    const auto queued = study::squeue_job(*job);
    std::map<std::string, int> states;
    for (const auto& task : queued) ++states[task.state];
    std::cout << "job " << *job << ":";
    for (const auto& [state, count] : states) std::cout << " " << count << " " << state;
    std::cout << (queued.empty() ? " over (squeue lists none of its tasks)" : "") << "\n";
    for (const auto& task : queued) {
      const auto underscore = task.id.find('_');
      if (underscore == std::string::npos) continue;
      const fs::path file = s.dir / "tasks" / ("slurm-" + *job + "-" + task.id.substr(underscore + 1) + ".json");
      std::error_code error;
      if (!fs::exists(file, error)) continue;
      try {
        const auto t = nlohmann::json::parse(files::read_text_file(file, "task record"));
        std::cout << "task " << task.id << " on " << t.value("host", "?") << ": " << t.value("state", "?") << ", "
                  << t.value("done", 0) << " done, " << t.value("failed", 0) << " failed, " << t.value("skipped", 0)
                  << " skipped of " << t["sessions"].size()
                  << (t["current"].is_string() ? ", estimating " + t["current"].get<std::string>() : "") << "\n";
      } catch (const std::exception&) {
      }
    }
  }
  return kExitOk;
}

int study_wait(const std::string& dir, double poll_seconds) {
  const Study s = study::read_study(dir);
  if (const auto job = study::last_job(s.dir)) study::wait_for_job(s, *job, poll_seconds, std::cout);
  return finish(s);
}

int study_task(const std::string& dir, const std::string& submission, int task, int threads,
               const std::string& cache_dir, bool retry_failed) {
  const Study s = study::read_study(dir);
  const auto json = nlohmann::json::parse(files::read_text_file(submission, "study submission"));
  const auto& tasks = json.at("tasks");
  if (task < 0 || static_cast<std::size_t>(task) >= tasks.size())
    throw std::invalid_argument("--task " + std::to_string(task) + ": the submission has tasks 0-" +
                                std::to_string(tasks.size() - 1));
  study::RunnerOptions runner;
  runner.threads = threads;
  runner.cache_dir = cache_dir;
  const char* job = std::getenv("SLURM_ARRAY_JOB_ID");
  runner.run = job ? "slurm-" + std::string(job) : fs::path(submission).stem().string();
  runner.task = task;
  runner.retry_failed = retry_failed;
  const auto counts = study::run_sessions(s, tasks[task].get<std::vector<std::string>>(), runner, std::cout);
  std::cout << "study task " << task << ": estimated " << counts.estimated << " (" << counts.done << " done, "
            << counts.failed << " failed), skipped " << counts.skipped << "\n";
  return kExitOk;
}

void add_estimation_options(CLI::App* cmd, EstimateOptions& e) {
  cmd->add_option("--method", e.method, "inverter")->check(CLI::IsMember({"exhaustive", "fast", "2d", "subspace"}))->capture_default_str();
  cmd->add_option("--model", e.model, "model order")->check(CLI::IsMember({"auto", "2d", "4d"}))->capture_default_str();
  cmd->add_option("--discrepancy", e.discrepancy,
                  "the skin model's shortfall on real skin, added to the noise wherever a residual is weighed: learned "
                  "(from the NIST forearm spectra, docs/estimation.md 'Real skin') or none (camera noise alone)")
      ->check(CLI::IsMember({"learned", "none"}))
      ->capture_default_str();
  cmd->add_flag("--neighbourhood-flags,!--no-neighbourhood-flags", e.neighbourhood_flags,
                "flag pixels from their neighbourhood (as chromo estimate; on by default)");
  cmd->add_flag("!--no-order-pooling", e.order_pooling, "with --model auto, decide the order per pixel only");
  cmd->add_option("--led-library", e.led_library, "LED library (default: each session's results/led_library.json)");
  cmd->add_option("--camera", e.camera, "camera sensitivity, builtin:NAME or a CSV")->capture_default_str();
  cmd->add_option("--camera-of", e.camera_of, "one camera's sensitivity, NAME=builtin:NAME or NAME=CSV (repeatable)");
  cmd->add_option("--white-reflectance", e.white_reflectance, "ρ of the white target")->capture_default_str();
}

}  // namespace

void add_study_command(CLI::App& app, int& exit_status) {
  CLI::App* study_cmd = app.add_subcommand("study", "A study: many stored sessions estimated here or on a Slurm cluster");
  study_cmd->require_subcommand(1);

  auto run = std::make_shared<StudyRunOptions>();
  CLI::App* run_cmd = study_cmd->add_subcommand("run", "Estimate every session of a manifest (resumable)");
  run_cmd->add_option("manifest", run->manifest, "a file listing session folders, or a glob matching them")->required();
  run_cmd->add_option("--out", run->out, "the study folder (new, empty, or a study to resume)")->required();
  run_cmd->add_option("--on", run->on, "where: local (this machine, every core) or slurm (a job array)")
      ->check(CLI::IsMember({"local", "slurm"}))->capture_default_str();
  add_estimation_options(run_cmd, run->estimate);
  run_cmd->add_option("--threads", run->estimate.threads, "local: threads per session (0 = all cores)")->capture_default_str();
  run_cmd->add_option("--cache-dir", run->estimate.cache_dir, "local: the table cache (default as chromo estimate)");
  run_cmd->add_option("--region", run->regions,
                      "NAME=PATH: a region's PNG mask per session (relative to its folder; {camera}: the camera's "
                      "name), statistics over it in the table (repeatable)");
  run_cmd->add_flag("--retry-failed", run->retry_failed, "estimate again sessions that failed on the same inputs");
  run_cmd->add_option("--sessions-per-task", run->slurm.sessions_per_task, "slurm: sessions per array task")
      ->check(CLI::Range(1, 10000))->capture_default_str();
  run_cmd->add_option("--cpus-per-task", run->slurm.cpus_per_task, "slurm: CPUs (threads) per task")
      ->check(CLI::Range(1, 1024))->capture_default_str();
  run_cmd->add_option("--chromo", run->slurm.chromo, "slurm: chromo's path on the nodes (default: this chromo)");
  run_cmd->add_option("--partition", run->slurm.partition, "slurm: partition");
  run_cmd->add_option("--time", run->slurm.time_limit, "slurm: time limit per task (sbatch --time)");
  run_cmd->add_option("--mem-mb", run->slurm.mem_mb, "slurm: memory per task in MB (default: from the sessions' sizes)")
      ->check(CLI::Range(0, 16 << 20));
  run_cmd->add_option("--node-cache", run->slurm.cache_dir,
                      "slurm: the node-local table cache (default ${TMPDIR:-/tmp}/chromo-study-cache-UID)");
  run_cmd->add_flag("!--no-wait", run->wait, "slurm: submit and return (chromo study status / wait later)");
  run_cmd->add_option("--poll-seconds", run->poll_seconds, "slurm: seconds between squeue polls")
      ->check(CLI::Range(0.05, 3600.0))->capture_default_str();
  run_cmd->callback([run, &exit_status] { exit_status = run_study(*run); });

  auto dir = std::make_shared<std::string>();
  CLI::App* status_cmd = study_cmd->add_subcommand("status", "How a study stands: sessions, its job's tasks");
  status_cmd->add_option("dir", *dir, "the study folder")->required();
  status_cmd->callback([dir, &exit_status] { exit_status = guarded("status", [&] { return study_status(*dir); }); });

  auto poll = std::make_shared<double>(10);
  CLI::App* wait_cmd = study_cmd->add_subcommand("wait", "Wait for the study's job to end, then gather the table");
  wait_cmd->add_option("dir", *dir, "the study folder")->required();
  wait_cmd->add_option("--poll-seconds", *poll, "seconds between squeue polls")->check(CLI::Range(0.05, 3600.0));
  wait_cmd->callback([dir, poll, &exit_status] {
    exit_status = guarded("wait", [&] { return study_wait(*dir, *poll); });
  });

  CLI::App* hold_cmd = study_cmd->add_subcommand("hold", "Make the study's runs and tasks wait before their next session");
  hold_cmd->add_option("dir", *dir, "the study folder (created when absent)")->required();
  hold_cmd->callback([dir, &exit_status] {
    exit_status = guarded("hold", [&] {
      study::check_output_folder(*dir);
      study::write_json_durably(study::hold_file(*dir), {{"held", true}});
      return kExitOk;
    });
  });
  CLI::App* release_cmd = study_cmd->add_subcommand("release", "Let a held study go on");
  release_cmd->add_option("dir", *dir, "the study folder")->required();
  release_cmd->callback([dir, &exit_status] {
    exit_status = guarded("release", [&] {
      fs::remove(study::hold_file(*dir));
      return kExitOk;
    });
  });

  struct TaskOptions {
    std::string dir, submission, cache_dir;
    int task = 0, threads = 0;
    bool retry_failed = false;
  };
  auto task = std::make_shared<TaskOptions>();
  CLI::App* task_cmd = study_cmd->add_subcommand("task", "One Slurm array task's sessions (the sbatch script runs it)");
  task_cmd->add_option("dir", task->dir, "the study folder")->required();
  task_cmd->add_option("--submission", task->submission, "DIR/slurm/submission-K.json")->required();
  task_cmd->add_option("--task", task->task, "the array task")->required();
  task_cmd->add_option("--threads", task->threads, "threads per session (0 = all cores)");
  task_cmd->add_option("--cache-dir", task->cache_dir, "the node-local table cache");
  task_cmd->add_flag("--retry-failed", task->retry_failed, "estimate again sessions that failed on the same inputs");
  task_cmd->callback([task, &exit_status] {
    exit_status = guarded("task", [&] {
      return study_task(task->dir, task->submission, task->task, task->threads, task->cache_dir, task->retry_failed);
    });
  });
}

}  // namespace chromo::cli
