#pragma once
// TableCacheReferences: which table-cache entries (forward_table_<key>.bin,
// inverse_table_<key>.bin) each session's results name, so that deleting a
// session removes the entries no other session still names.
//
// A session's entries come from its results/summary.json ("table": key and
// inverse_key) and, for a several-camera session (whose index has no
// top-level table), each camera's results/<folder>/summary.json. They are
// read once per results: each session's are kept with the index's inode,
// modification time and size, and read again only when those change (the
// results were re-estimated, here or by `chromo estimate`). A delete then
// stats every session's index and parses only what changed since the last.
//
// Thread rules: one caller at a time (the daemon's delete lock).

#include <cstdint>
#include <filesystem>
#include <map>
#include <set>
#include <string>

namespace chromo::daemon {

class TableCacheReferences {
 public:
  // The cache file names the results of the session folder `folder` name;
  // none when it has no (readable, JSON) results. A "folder" of the index
  // that is not a plain name is not followed.
  const std::set<std::string>& entries_of(const std::filesystem::path& folder);

  // The entries of `folder` that no other session folder under `root` names.
  std::set<std::string> named_only_by(const std::filesystem::path& root, const std::filesystem::path& folder);

  // Drops what is kept of `folder` (after it is deleted).
  void forget(const std::filesystem::path& folder);

  // Summaries parsed so far (for tests: a second delete re-reads only the changed).
  int summaries_read() const { return summaries_read_; }

 private:
  struct Kept {
    std::uint64_t inode = 0;
    std::int64_t modified_ns = 0;
    std::int64_t bytes = 0;
    bool present = false;
    std::set<std::string> entries;
  };
  std::map<std::filesystem::path, Kept> kept_;
  int summaries_read_ = 0;
};

}  // namespace chromo::daemon
