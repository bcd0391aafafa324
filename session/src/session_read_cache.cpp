// The sessions last read, while their files are unchanged (session_read_cache.hpp).
#include "chromo/session/session_read_cache.hpp"

namespace chromo::session {

namespace fs = std::filesystem;

SessionReadCache::Stamp SessionReadCache::stamp_of(const fs::path& folder) {
  const auto file_stamp = [](const fs::path& file) -> std::optional<FileStamp> {
    std::error_code error;
    const auto size = fs::file_size(file, error);
    if (error) return std::nullopt;
    const auto modified = fs::last_write_time(file, error);
    if (error) return std::nullopt;
    return FileStamp{size, modified};
  };
  return {file_stamp(folder / "session.json"), file_stamp(folder / "journal.jsonl")};
}

SessionInfo SessionReadCache::get(const fs::path& folder, const std::function<SessionInfo(const fs::path&)>& read) {
  const Stamp before = stamp_of(folder);
  {
    std::lock_guard lock(mutex_);
    for (auto it = entries_.begin(); it != entries_.end(); ++it)
      if (it->folder == folder) {
        if (it->stamp == before) {
          entries_.splice(entries_.begin(), entries_, it);
          return entries_.front().info;
        }
        entries_.erase(it);
        break;
      }
    ++reads_;
  }
  SessionInfo info = read(folder);
  // Cached only when nothing changed while it was read (a journal appended
  // meanwhile could be half in the copy read).
  if (stamp_of(folder) == before && before.session_json) {
    std::lock_guard lock(mutex_);
    std::erase_if(entries_, [&folder](const Entry& entry) { return entry.folder == folder; });
    entries_.push_front({folder, before, info});
    if (entries_.size() > capacity_) entries_.pop_back();
  }
  return info;
}

std::size_t SessionReadCache::reads() const {
  std::lock_guard lock(mutex_);
  return reads_;
}

}  // namespace chromo::session
