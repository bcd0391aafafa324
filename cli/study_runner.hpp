#pragma once
// Estimating a study's sessions in this process: the local backend (`chromo
// study run --on local`, every session) and each Slurm task (`chromo study
// task`, its share). Both call estimate_stored_session() per session, exactly
// as `chromo estimate SESSION_DIR` does.
//
// A session is skipped when its record is "done" with the hash of its
// current inputs (study_inputs.hpp) and its maps are in place, or "failed"
// on bad input (exit 2) with that hash (the same inputs fail the same way;
// --retry-failed estimates them again). Otherwise its maps go to
// DIR/sessions/.work-<name>@<host>-<pid>/, are renamed to DIR/sessions/<name>/
// (replacing what an interrupted run left), and then its record is written.
// A session that fails is recorded with its error; the others go on.
//
// Progress: the run's own record DIR/tasks/<label>.json (state running, held
// or finished; the session in hand; counts), rewritten at each session.
// While DIR/hold exists a run waits before its next session (state "held").
//
// Thread rules: one runner per session at a time (the sessions of a study are
// split between tasks, never shared).

#include <cstddef>
#include <iosfwd>
#include <string>
#include <vector>

#include "study_folder.hpp"

namespace chromo::cli::study {

struct RunnerOptions {
  int threads = 0;           // per session (0 = all cores)
  std::string cache_dir;     // the table cache (empty: the default)
  std::string run;           // the run's id ("local-<time>", "slurm-<job id>")
  int task = -1;             // the Slurm array task, -1 for a local run
  bool retry_failed = false;
  double hold_poll_seconds = 0.2;
};

struct RunCounts {
  std::size_t estimated = 0;  // sessions estimated now (done or failed)
  std::size_t done = 0;       // of them, done
  std::size_t failed = 0;     // of them, failed
  std::size_t skipped = 0;    // already done (or failed on the same inputs)
};

// What a session needs: "done" / "failed" when its record stands for these
// inputs, "pending" otherwise (hash: the current inputs', "" when unknown).
std::string session_state(const Study& study, const std::string& name, const std::string& hash, bool retry_failed);

// Estimates `names` (sessions of `study`) in order; progress lines on `log`.
RunCounts run_sessions(const Study& study, const std::vector<std::string>& names, const RunnerOptions& options,
                       std::ostream& log);

}  // namespace chromo::cli::study
