#pragma once
// The Slurm backend of a study (docs/study.md "On a Slurm cluster"): a job
// array whose tasks each run `chromo study task` on a few sessions.
//
// submit_study() writes DIR/slurm/submission-<k>.json (the run's sessions,
// split into tasks of sessions_per_task) and DIR/slurm/study.sbatch (kept for
// the lab to read and adapt: #SBATCH lines, the chromo path, a node-local
// table cache), submits it with `sbatch --parsable` and appends the job's id
// to DIR/slurm/jobs.json. Threads per task come from SLURM_CPUS_PER_TASK;
// --mem from the sessions' sizes (memory_request_mb()).
//
// Progress comes from `squeue` (the job's tasks still queued or running) and
// the tasks' own records (DIR/tasks/, DIR/records/): no `sacct`, which needs
// slurmdbd. A job is over when squeue lists none of its tasks.
//
// Thread rules: free functions; they run sbatch and squeue as child processes.

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "study_folder.hpp"

namespace chromo::cli::study {

struct SlurmOptions {
  int sessions_per_task = 4;
  int cpus_per_task = 4;
  std::string chromo;       // chromo on the nodes (default: this chromo's absolute path)
  std::string partition;    // empty: the cluster's default
  std::string time_limit;   // empty: the partition's default
  int mem_mb = 0;           // 0: from the sessions' sizes
  std::string cache_dir;    // the node-local table cache (empty: $TMPDIR or /tmp, per user)
  bool retry_failed = false;
};

// The frames' bytes of a session's largest camera (0 when unreadable).
std::uint64_t largest_camera_frame_bytes(const std::filesystem::path& session_folder);
// --mem for a task whose largest session has that many frame bytes per camera.
int memory_request_mb(std::uint64_t largest_camera_frame_bytes);

struct SubmittedJob {
  std::string job_id;
  int tasks = 0;
  int mem_mb = 0;
  std::filesystem::path script;
};
// Throws std::runtime_error with sbatch's message when the submission fails.
SubmittedJob submit_study(const Study& study, const std::vector<std::string>& pending, const SlurmOptions& options);

// The last job submitted for the study (DIR/slurm/jobs.json), if any.
std::optional<std::string> last_job(const std::filesystem::path& dir);

struct QueuedTask {
  std::string id;     // "<job>_<task>"
  std::string state;  // squeue's: PENDING, RUNNING, COMPLETING, ...
};
// The job's tasks squeue still lists (none once it is over). Throws
// std::runtime_error when squeue itself fails.
std::vector<QueuedTask> squeue_job(const std::string& job_id);

// Polls squeue every poll_seconds until the job is over, printing progress
// lines (the queue and the records) on `log` when they change.
void wait_for_job(const Study& study, const std::string& job_id, double poll_seconds, std::ostream& log);

// Runs a command line through the shell: exit status and stdout+stderr.
struct CommandOutput {
  int exit_status = -1;
  std::string output;
};
CommandOutput run_command(const std::string& command_line);
std::string shell_quote(const std::string& text);

}  // namespace chromo::cli::study
