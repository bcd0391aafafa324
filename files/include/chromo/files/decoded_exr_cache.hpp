#pragma once
// Decoded EXR files kept in memory (issue 42: the web view's GetMap decoded
// maps.exr again on every channel switch): one entry per path, checked
// against the file on every read (size, modification time, inode; a durable
// rewrite renames a new file in: a new inode) and decoded again when it
// changed; bounded by the decoded floats' bytes, the least recently read
// entry dropped first. A file larger than the bound alone is decoded and
// not kept.
//
// Thread rules: every member may be called from any thread (one mutex; a
// file is decoded outside it, so two readers of a new file may both decode).

#include <cstdint>
#include <filesystem>
#include <list>
#include <memory>
#include <mutex>
#include <string>

#include "chromo/files/float_image.hpp"

namespace chromo::files {

class DecodedExrCache {
 public:
  explicit DecodedExrCache(std::uint64_t max_bytes) : max_bytes_(max_bytes) {}

  // The file decoded (read_exr's errors when it cannot be read); the same
  // object as the last read while the file is unchanged.
  std::shared_ptr<const FloatImage> read(const std::filesystem::path& path);

  std::uint64_t bytes() const;     // decoded bytes held
  std::size_t entries() const;
  std::uint64_t decodes() const;   // files decoded since construction (hits do not count)

 private:
  struct Stamp {
    std::uintmax_t size = 0;
    std::int64_t modified_ns = 0;
    std::uint64_t inode = 0;
    bool operator==(const Stamp&) const = default;
  };
  struct Entry {
    std::string path;
    Stamp stamp;
    std::shared_ptr<const FloatImage> image;
    std::uint64_t bytes = 0;
  };
  static Stamp stamp_of(const std::filesystem::path& path);
  void insert_locked(Entry entry);

  const std::uint64_t max_bytes_;
  mutable std::mutex mutex_;
  std::list<Entry> entries_;  // most recently read first
  std::uint64_t bytes_ = 0, decodes_ = 0;
};

}  // namespace chromo::files
