#pragma once
// Journal: the session folder's append-only log, one JSON object per line
// (docs/formats/session.md lists the record types).
//
// append() writes the line with O_APPEND and fsyncs before returning: a record
// whose append() returned survives a crash or kill -9. A crash during append()
// can leave a torn last line (no '\n'); read_journal() ignores it and says so.
// A journal is never rewritten.
//
// Thread rules: append() is serialised internally (any thread).

#include <filesystem>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/files/durable_file.hpp"

namespace chromo::session {

class Journal {
 public:
  // Opens (creating if needed) for appending; the directory is fsynced when
  // the file is created. Throws std::runtime_error naming the path.
  Journal(std::filesystem::path path, files::StorageBudget* budget);
  ~Journal();
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;

  // Adds "t" (UTC, ISO 8601 with microseconds) if absent. Throws
  // StorageFullError when the disk or budget is full (nothing is written).
  void append(nlohmann::json record);
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  files::StorageBudget* budget_;
  int fd_ = -1;
  std::mutex mutex_;
};

struct JournalContents {
  std::vector<nlohmann::json> records;
  bool torn_tail = false;   // the last line was incomplete (crash during append)
  int malformed_lines = 0;  // complete lines that are not JSON objects (should be 0)
};

// Every record of the journal at `path` (none when it does not exist), in
// order. Throws files::InputFileError (a std::runtime_error) naming the path
// when it is not a regular file, is longer than files::kMaxJournalBytes or
// cannot be read.
JournalContents read_journal(const std::filesystem::path& path);

// What read_journal() reads, one record at a time: `each` gets every record
// in order, and only the line being parsed is held (a long session's journal
// is tens of MB; its records as JSON several times that). Returns the torn
// tail and malformed line counts with `records` left empty. Same errors.
JournalContents for_each_journal_record(const std::filesystem::path& path,
                                        const std::function<void(nlohmann::json&& record)>& each);

// "2026-11-22T16:04:47.123456Z"
std::string utc_timestamp_now();

}  // namespace chromo::session
