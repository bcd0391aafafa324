// The Slurm backend of a study (study_slurm.hpp).
#include "study_slurm.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <ostream>
#include <sstream>
#include <thread>

#include "chromo/files/bounded_read.hpp"
#include "chromo/files/durable_file.hpp"

namespace chromo::cli::study {

namespace fs = std::filesystem;

std::string shell_quote(const std::string& text) {
  std::string out = "'";
  for (char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

CommandOutput run_command(const std::string& command_line) {
  CommandOutput result;
  FILE* pipe = ::popen((command_line + " 2>&1").c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buffer{};
  while (std::size_t n = std::fread(buffer.data(), 1, buffer.size(), pipe)) result.output.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  result.exit_status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

std::uint64_t largest_camera_frame_bytes(const fs::path& session_folder) {
  std::map<std::string, std::uint64_t> per_camera;  // frames/<step>/<camera>-<sequence>.tiff
  std::error_code error;
  for (auto it = fs::recursive_directory_iterator(session_folder / "frames", error); !error && it != fs::end(it);
       it.increment(error)) {
    if (!it->is_regular_file(error)) continue;
    const std::string name = it->path().filename().string();
    const auto dash = name.rfind('-');
    per_camera[dash == std::string::npos ? name : name.substr(0, dash)] += it->file_size(error);
  }
  std::uint64_t largest = 0;
  for (const auto& [camera, bytes] : per_camera) largest = std::max(largest, bytes);
  return largest;
}

int memory_request_mb(std::uint64_t frame_bytes) {
  // Measured peak RSS (docs/study.md "Memory"): a base for the tables and the
  // program, and a multiple of one camera's frame bytes for its captures,
  // measurement, estimates and maps; rounded up to 256 MB.
  constexpr double kBaseMb = 700, kPerFrameByte = 12;
  const double mb = kBaseMb + kPerFrameByte * static_cast<double>(frame_bytes) / (1 << 20);
  return static_cast<int>(std::ceil(mb / 256.0) * 256);
}

namespace {

std::string this_chromo() {
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  return error ? "chromo" : self.string();
}

nlohmann::ordered_json read_jobs(const fs::path& dir) {
  std::error_code error;
  const fs::path file = dir / "slurm" / "jobs.json";
  if (!fs::exists(file, error)) return nlohmann::ordered_json::array();
  try {
    return nlohmann::ordered_json::parse(files::read_text_file(file, "study jobs"));
  } catch (const std::exception&) {
    return nlohmann::ordered_json::array();
  }
}

std::string sbatch_script(const Study& study, const SlurmOptions& options, const fs::path& submission, int tasks,
                          int mem_mb) {
  const std::string chromo = options.chromo.empty() ? this_chromo() : options.chromo;
  const fs::path logs = study.dir / "slurm" / "logs";
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "# A study's job array, written by `chromo study run --on slurm` (docs/study.md).\n"
    << "# Each task estimates its share of the sessions listed in " << submission.filename().string() << "\n"
    << "# with `chromo study task`, skipping those already done with the same inputs,\n"
    << "# and writes each session's maps and record into the study folder atomically.\n"
    << "#SBATCH --job-name=chromo-study\n"
    << "#SBATCH --array=0-" << tasks - 1 << "\n"
    << "#SBATCH --ntasks=1\n"
    << "#SBATCH --cpus-per-task=" << options.cpus_per_task << "\n"
    << "#SBATCH --mem=" << mem_mb << "M\n"
    << "#SBATCH --output=" << (logs / "task-%A_%a.out").string() << "\n";
  if (!options.partition.empty()) s << "#SBATCH --partition=" << options.partition << "\n";
  if (!options.time_limit.empty()) s << "#SBATCH --time=" << options.time_limit << "\n";
  s << "set -eu\n"
    << "# chromo on the nodes: a shared install or the lab PC's package (override with CHROMO=...).\n"
    << "CHROMO=${CHROMO:-" << shell_quote(chromo) << "}\n"
    << "STUDY=" << shell_quote(study.dir.string()) << "\n"
    << "# A node-local table cache: tables are built or read once per node, not over the shared folder.\n"
    << "CACHE=${CHROMO_STUDY_CACHE:-"
    << (options.cache_dir.empty() ? std::string("${TMPDIR:-/tmp}/chromo-study-cache-$(id -u)")
                                  : shell_quote(options.cache_dir))
    << "}\n"
    << "mkdir -p \"$CACHE\"\n"
    << "exec \"$CHROMO\" study task \"$STUDY\" --submission " << shell_quote(submission.string())
    << " --task \"$SLURM_ARRAY_TASK_ID\" --threads \"${SLURM_CPUS_PER_TASK:-1}\" --cache-dir \"$CACHE\""
    << (options.retry_failed ? " --retry-failed" : "") << "\n";
  return s.str();
}

}  // namespace

SubmittedJob submit_study(const Study& study, const std::vector<std::string>& pending, const SlurmOptions& options) {
  const fs::path slurm = study.dir / "slurm";
  fs::create_directories(slurm / "logs");
  nlohmann::ordered_json jobs = read_jobs(study.dir);
  const std::size_t k = jobs.size() + 1;
  const std::size_t per_task = static_cast<std::size_t>(std::max(1, options.sessions_per_task));
  nlohmann::ordered_json tasks = nlohmann::ordered_json::array();
  std::uint64_t largest = 0;
  for (std::size_t i = 0; i < pending.size(); i += per_task)
    tasks.push_back(std::vector<std::string>(pending.begin() + static_cast<std::ptrdiff_t>(i),
                                             pending.begin() + static_cast<std::ptrdiff_t>(std::min(i + per_task, pending.size()))));
  for (const auto& name : pending)
    largest = std::max(largest, largest_camera_frame_bytes(study.find(name)->folder));
  SubmittedJob job;
  job.tasks = static_cast<int>(tasks.size());
  job.mem_mb = options.mem_mb > 0 ? options.mem_mb : memory_request_mb(largest);
  const fs::path submission = slurm / ("submission-" + std::to_string(k) + ".json");
  write_json_durably(submission, {{"submission", k}, {"tasks", tasks}});
  job.script = slurm / "study.sbatch";
  files::write_file_durably(job.script, sbatch_script(study, options, submission, job.tasks, job.mem_mb), nullptr);
  const CommandOutput out = run_command("sbatch --parsable " + shell_quote(job.script.string()));
  std::string id = out.output.substr(0, out.output.find_first_of(";\n"));
  if (out.exit_status != 0 || id.empty() || id.find_first_not_of("0123456789") != std::string::npos)
    throw std::runtime_error("sbatch " + job.script.string() + " failed (exit " + std::to_string(out.exit_status) +
                             "): " + out.output);
  job.job_id = id;
  jobs.push_back({{"job", id}, {"submission", submission.filename().string()}, {"tasks", job.tasks},
                  {"mem_mb", job.mem_mb}, {"sessions", pending.size()}});
  write_json_durably(slurm / "jobs.json", jobs);
  return job;
}

std::optional<std::string> last_job(const fs::path& dir) {
  const auto jobs = read_jobs(dir);
  if (jobs.empty()) return std::nullopt;
  return jobs.back().value("job", "");
}

std::vector<QueuedTask> squeue_job(const std::string& job_id) {
  const CommandOutput out = run_command("squeue --noheader --array --jobs " + shell_quote(job_id) +
                                        " --states PD,R,CG,CF,S,RQ,RS,RH,SI,SO,ST --format '%i %T'");
  std::vector<QueuedTask> tasks;
  if (out.exit_status != 0) {
    // A job the controller has already forgotten is over.
    if (out.output.find("Invalid job id") != std::string::npos) return tasks;
    throw std::runtime_error("squeue --jobs " + job_id + " failed (exit " + std::to_string(out.exit_status) +
                             "): " + out.output);
  }
  std::istringstream lines(out.output);
  std::string id, state;
  while (lines >> id >> state) tasks.push_back({id, state});
  return tasks;
}

void wait_for_job(const Study& study, const std::string& job_id, double poll_seconds, std::ostream& log) {
  std::string last;
  int squeue_failures = 0;
  for (;;) {
    std::vector<QueuedTask> queued;
    try {
      queued = squeue_job(job_id);
      squeue_failures = 0;
    } catch (const std::runtime_error&) {
      if (++squeue_failures >= 5) throw;  // the controller is gone, not busy
      std::this_thread::sleep_for(std::chrono::duration<double>(poll_seconds));
      continue;
    }
    std::map<std::string, int> states;
    for (const auto& task : queued) ++states[task.state];
    std::size_t done = 0, failed = 0;
    for (const auto& session : study.sessions)
      if (const auto record = read_record(study.dir, session.name)) {
        if (record->value("run", "") != "slurm-" + job_id) continue;
        (record->value("state", "") == "done" ? done : failed) += 1;
      }
    std::string line = "study: job " + job_id + ":";
    for (const auto& [state, count] : states) line += " " + std::to_string(count) + " " + state;
    if (queued.empty()) line += " over";
    line += "; this job's sessions: " + std::to_string(done) + " done, " + std::to_string(failed) + " failed";
    if (line != last) log << line << "\n" << std::flush;
    last = line;
    if (queued.empty()) return;
    std::this_thread::sleep_for(std::chrono::duration<double>(poll_seconds));
  }
}

}  // namespace chromo::cli::study
