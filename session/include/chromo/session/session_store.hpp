#pragma once
// SessionStore: the sessions folder. One folder per session, named by its id
// (docs/formats/session.md):
//
//   <sessions_dir>/<id>/session.json    written once, crash-safe: id, name, subject, plan, devices
//                       journal.jsonl   append-only, one fsynced JSON record per line
//                       frames/<step>/<camera>-<sequence>.tiff
//                       derived/<step>-<camera>-mean.exr
//                       results/        the estimator's maps and report
//
// read_session() rebuilds everything the API reports about a session from
// these files alone: state, counters, which steps completed, every frame. At
// start-up, recover() marks sessions whose journal has no final state as
// interrupted (appending that record), so a restart after kill -9 reports them.
//
// Format version: session.json's "format" is "chromosphere-session/<N>"
// (docs/formats/session.md says what each version changed). create() writes
// kSessionFormatVersion; readers accept every version from 1 to it and refuse
// others, naming the file and the field.
//
// Thread rules: create() and recover() from one thread; read_session() anywhere.

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/session/session_provenance.hpp"
#include "chromo/session/frame_record.hpp"
#include "chromo/session/journal.hpp"
#include "chromo/session/operation_record.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromo/session/session_timeline.hpp"

namespace chromo::session {

inline constexpr int kSessionFormatVersion = 2;
// The version of a parsed session.json (1 ... kSessionFormatVersion). Throws
// std::invalid_argument naming `file` and the "format" field otherwise.
int session_format_version(const nlohmann::json& session, const std::filesystem::path& file);

struct StepProgress {
  std::string name;
  StepRole role = StepRole::kSubject;
  bool completed = false;
  std::uint64_t frames_stored = 0;
};

struct SessionInfo {
  OperationRecord record;  // state, counters, folder...
  SessionPlan plan;
  int format_version = kSessionFormatVersion;
  std::string subject;
  SessionProvenance provenance;     // what it was made with (recorded false for an older session)
  std::vector<StepProgress> steps;
  std::vector<FrameRecord> frames;  // the journal's frame records, in storage order
  nlohmann::json results;           // the last "results" record (null if none)
  SessionTimeline timeline;         // where its time went (session_timeline.hpp)
  bool torn_journal_tail = false;
  // Frame records that did not parse (frame_record_from_json; should be 0):
  // counted as stored, left out of `frames`; the first one's error.
  int malformed_frame_records = 0;
  std::string malformed_frame_error;
};

// "20261122T183000Z-<name>-<6 hex>": ids of sessions and calibration runs
// (sortable by creation time, unique in practice, a valid folder name).
std::string new_session_id(const std::string& name);

class SessionStore {
 public:
  SessionStore(std::filesystem::path root, files::StorageBudget* budget);
  const std::filesystem::path& root() const { return root_; }

  struct Created {
    std::string id;
    std::filesystem::path folder;
    std::unique_ptr<Journal> journal;
  };
  // A new folder with session.json and the journal's first record. Throws
  // (StorageFullError included) leaving no folder behind: a refused start
  // (a full disk, the storage budget) removes the folder it had just made.
  // `provenance` (session_provenance.hpp), when given, goes into session.json.
  Created create(const SessionPlan& plan, const std::string& subject, const nlohmann::json& devices,
                 const SessionProvenance* provenance = nullptr);

  // Every session in the folder, newest first, with in-flight ones marked
  // interrupted on disk. A folder that cannot be recovered (a loop of
  // symbolic links, a file that cannot be read, a session.json whose id is
  // not the folder's name) is skipped, never fatal: "<folder>: <why>" goes
  // into `skipped` when given.
  std::vector<SessionInfo> recover(std::vector<std::string>* skipped = nullptr);

  // Throws std::runtime_error when the folder is not a session.
  SessionInfo read_session(const std::filesystem::path& folder) const;

 private:
  void fill_new_session_folder(Created& created, const SessionPlan& plan, const std::string& subject,
                               const nlohmann::json& devices, const SessionProvenance* provenance);
  std::filesystem::path root_;
  files::StorageBudget* budget_;
};

}  // namespace chromo::session
