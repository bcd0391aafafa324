#pragma once
// The sessions last read (SessionStore::read_session), kept while their files
// are unchanged: GetSession of a long session re-read and re-parsed its whole
// journal on every call (issue 40: a 67 MB journal took 2.6 s a call).
//
// An entry is used only while session.json and journal.jsonl have the size
// and modification time they had when it was read; any append to the journal
// (a running session) reads the folder again. At most `capacity` sessions are
// kept, the least recently used dropped first.
//
// Thread rules: get() may be called from any thread (one mutex; the read
// itself happens outside it, so a slow read does not hold other sessions up).

#include <cstddef>
#include <filesystem>
#include <functional>
#include <list>
#include <mutex>
#include <optional>
#include <string>

#include "chromo/session/session_store.hpp"

namespace chromo::session {

class SessionReadCache {
 public:
  explicit SessionReadCache(std::size_t capacity = 8) : capacity_(capacity) {}

  // The session in `folder`: the cached one while its files are unchanged,
  // else `read(folder)` (its exceptions pass through, nothing is cached).
  SessionInfo get(const std::filesystem::path& folder,
                  const std::function<SessionInfo(const std::filesystem::path&)>& read);

  std::size_t reads() const;  // how many times get() had to read a folder

 private:
  struct FileStamp {
    std::uintmax_t size = 0;
    std::filesystem::file_time_type modified{};
    bool operator==(const FileStamp&) const = default;
  };
  struct Stamp {
    std::optional<FileStamp> session_json, journal;
    bool operator==(const Stamp&) const = default;
  };
  struct Entry {
    std::filesystem::path folder;
    Stamp stamp;
    SessionInfo info;
  };
  static Stamp stamp_of(const std::filesystem::path& folder);

  std::size_t capacity_;
  mutable std::mutex mutex_;
  std::list<Entry> entries_;  // most recently used first
  std::size_t reads_ = 0;
};

}  // namespace chromo::session
