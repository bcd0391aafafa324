// Estimating a study's sessions in this process (study_runner.hpp).
#include "study_runner.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <ostream>
#include <thread>

#include "chromo/files/bounded_read.hpp"
#include "chromo/files/durable_file.hpp"
#include "commands.hpp"
#include "study_inputs.hpp"
#include "study_table.hpp"

namespace chromo::cli::study {

namespace fs = std::filesystem;

namespace {

std::string utc_now() {
  const auto now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

// This process's CPU seconds so far (user + system, every thread).
double cpu_seconds() {
  rusage usage{};
  ::getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec + 1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

double max_rss_mb() {
  rusage usage{};
  ::getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;
}

// subject, created and plan name from session.json (empty when unreadable).
void describe_session(const fs::path& folder, nlohmann::ordered_json& record) {
  record["subject"] = "", record["created"] = "", record["plan"] = "";
  try {
    const auto json = nlohmann::json::parse(files::read_text_file(folder / "session.json", "session"));
    record["subject"] = json.value("subject", "");
    record["created"] = json.value("created", "");
    record["plan"] = json.contains("plan") ? json["plan"].value("name", json.value("name", "")) : json.value("name", "");
  } catch (const std::exception&) {
  }
}

// Removes what an interrupted estimate of `name` left in DIR/sessions.
void remove_work_folders(const fs::path& sessions, const std::string& name) {
  std::error_code error;
  const std::string prefix = ".work-" + name + "@";
  for (const auto& entry : fs::directory_iterator(sessions, error))
    if (entry.path().filename().string().rfind(prefix, 0) == 0) fs::remove_all(entry.path(), error);
}

struct TaskRecord {
  fs::path file;
  nlohmann::ordered_json json;
  void save() {
    json["updated"] = utc_now();
    write_json_durably(file, json);
  }
};

}  // namespace

std::string session_state(const Study& study, const std::string& name, const std::string& hash, bool retry_failed) {
  const auto record = read_record(study.dir, name);
  if (!record || hash.empty() || record->value("input_hash", "") != hash) return "pending";
  const std::string state = record->value("state", "");
  if (state == "done") {
    // Its maps in place: every estimated camera's maps.exr and summary.json.
    std::error_code error;
    const fs::path maps = session_maps_dir(study.dir, name);
    for (const auto& camera : record->value("cameras", nlohmann::ordered_json::array()))
      if (camera.value("state", "") == "ok")
        for (const char* file : {"maps.exr", "summary.json"})
          if (!fs::exists(maps / camera.value("folder", "") / file, error)) return "pending";
    return fs::is_directory(maps, error) ? "done" : "pending";
  }
  if (state == "failed" && !retry_failed && record->value("exit_status", 0) == kExitBadInput) return "failed";
  return "pending";
}

namespace {

// Waits while the study is held (DIR/hold), the task saying so.
void wait_while_held(const Study& study, TaskRecord& task, const std::string& name, const RunnerOptions& options,
                     std::ostream& log) {
  std::error_code error;
  if (!fs::exists(hold_file(study.dir), error)) return;
  task.json["state"] = "held";
  task.json["current"] = nullptr;
  task.save();
  log << "study: held before " << name << " (" << hold_file(study.dir).string() << ")\n" << std::flush;
  while (fs::exists(hold_file(study.dir), error))
    std::this_thread::sleep_for(std::chrono::duration<double>(options.hold_poll_seconds));
  task.json["state"] = "running";
}

// Estimates one session into work_dir and, when it succeeded, moves the maps
// to final_dir (record's "cameras" filled); a region mask that cannot be used
// is bad input, anything else thrown an internal failure.
SessionEstimate estimate_session_maps(const Study& study, const ManifestSession& session, const RunnerOptions& options,
                                      const fs::path& work_dir, const fs::path& final_dir, nlohmann::ordered_json& record) {
  SessionEstimate outcome;
  EstimateOptions eo = study.options;
  eo.input = session.folder.string();
  eo.out = work_dir.string();
  eo.threads = options.threads;
  eo.cache_dir = options.cache_dir;
  try {
    outcome = estimate_stored_session(eo, "chromo study");
    if (outcome.exit_status == kExitOk) {
      record["cameras"] = camera_rows(work_dir, outcome.cameras, session.folder, study.regions);
      fs::remove_all(final_dir);
      fs::rename(work_dir, final_dir);
      files::fsync_directory(work_dir.parent_path());
    }
  } catch (const std::invalid_argument& e) {  // a region mask that cannot be used
    outcome.exit_status = kExitBadInput;
    outcome.errors.push_back(e.what());
  } catch (const std::exception& e) {
    outcome.exit_status = kExitFailure;
    outcome.errors.push_back(std::string("internal error: ") + e.what());
  }
  return outcome;
}

// The record's outcome fields (state, exit status, errors, time and memory), written durably; its errors joined.
std::string finish_record(const Study& study, const std::string& name, const SessionEstimate& outcome,
                          std::chrono::steady_clock::time_point start, double cpu_start, nlohmann::ordered_json& record) {
  std::string errors;
  for (const auto& line : outcome.errors) errors += (errors.empty() ? "" : "; ") + line;
  record["state"] = outcome.exit_status == kExitOk ? "done" : "failed";
  record["exit_status"] = outcome.exit_status;
  record["error"] = errors;
  record["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  record["cpu_seconds"] = cpu_seconds() - cpu_start;
  record["max_rss_mb"] = max_rss_mb();
  record["finished"] = utc_now();
  if (!record.contains("cameras")) record["cameras"] = nlohmann::ordered_json::array();
  write_json_durably(record_file(study.dir, name), record);
  return errors;
}

}  // namespace

RunCounts run_sessions(const Study& study, const std::vector<std::string>& names, const RunnerOptions& options,
                       std::ostream& log) {
  RunCounts counts;
  const std::string host = host_name();
  const std::string version = estimator_version();
  const std::string label = options.task >= 0 ? options.run + "-" + std::to_string(options.task) : options.run;
  TaskRecord task{study.dir / "tasks" / (label + ".json"),
                  {{"run", options.run}, {"task", options.task >= 0 ? nlohmann::json(options.task) : nlohmann::json()},
                   {"host", host}, {"pid", ::getpid()}, {"state", "running"}, {"sessions", names},
                   {"current", nullptr}, {"estimated", 0}, {"done", 0}, {"failed", 0}, {"skipped", 0},
                   {"started", utc_now()}}};
  task.save();
  const fs::path sessions_dir = study.dir / "sessions";
  fs::create_directories(sessions_dir);
  for (const std::string& name : names) {
    const ManifestSession* session = study.find(name);
    if (!session) throw std::invalid_argument("the study has no session \"" + name + "\"");
    wait_while_held(study, task, name, options, log);
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = cpu_seconds();
    nlohmann::ordered_json record{{"format", "chromosphere-study-record/1"}, {"session", name},
                                  {"folder", session->folder.string()}};
    std::string hash;
    std::string hash_error;
    try {
      hash = input_hash(session->folder, study.options, version, study.regions);
    } catch (const std::exception& e) {
      hash_error = e.what();
    }
    const std::string state = session_state(study, name, hash, options.retry_failed);
    if (state != "pending") {
      ++counts.skipped;
      task.json["skipped"] = counts.skipped;
      log << "study: " << name << ": " << state << " with these inputs, not estimated again\n" << std::flush;
      continue;
    }
    task.json["current"] = name;
    task.save();
    log << "study: " << name << ": estimating\n" << std::flush;
    describe_session(session->folder, record);
    record["input_hash"] = hash;
    record["estimator_version"] = version;
    record["run"] = options.run;
    record["task"] = options.task >= 0 ? nlohmann::json(options.task) : nlohmann::json();
    record["host"] = host;
    const fs::path final_dir = session_maps_dir(study.dir, name);
    const fs::path work_dir = sessions_dir / (".work-" + name + "@" + host + "-" + std::to_string(::getpid()));
    remove_work_folders(sessions_dir, name);
    SessionEstimate outcome;
    if (!hash_error.empty()) {
      outcome.exit_status = kExitBadInput;
      outcome.errors.push_back(hash_error);
    } else {
      outcome = estimate_session_maps(study, *session, options, work_dir, final_dir, record);
    }
    std::error_code error;
    fs::remove_all(work_dir, error);
    const std::string errors = finish_record(study, name, outcome, start, cpu_start, record);
    ++counts.estimated;
    if (outcome.exit_status == kExitOk) ++counts.done;
    else ++counts.failed;
    log << "study: " << name << ": " << record["state"].get<std::string>()
        << (errors.empty() ? "" : " (" + errors + ")") << "\n" << std::flush;
    task.json["estimated"] = counts.estimated;
    task.json["done"] = counts.done;
    task.json["failed"] = counts.failed;
    task.json["current"] = nullptr;
    task.save();
  }
  task.json["state"] = "finished";
  task.save();
  return counts;
}

}  // namespace chromo::cli::study
