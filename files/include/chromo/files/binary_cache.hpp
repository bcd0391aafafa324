#pragma once
// Versioned binary cache files: what a slow computation (a forward table, an
// inverse table, a rendered session) leaves on disk so that the next run with
// the same inputs loads it instead of computing it again.
//
// A cache file is never a source of truth: when anything about it is not
// exactly what this build would have written for these inputs, read_cache()
// says "miss" and the caller computes the content again. It never throws for
// a bad file and never hands back bytes that were not written whole by
// write_cache() with the same format and key.
//
// File layout (native byte order; a cache belongs to one machine):
//
//   offset  size  field
//   0       8     magic          names the kind of content, e.g. "CHROMOFT"
//   8       4     version        of the payload's encoding (CacheFormat)
//   12      8     key            64-bit Fnv1a of every input of the content
//   20      8     payload_bytes  n
//   28      n     payload        the caller's encoding (CacheWriter/CacheReader)
//   28+n    8     checksum       Fnv1a of the payload
//
// A read is a miss (std::nullopt) when the file is missing or unreadable, its
// magic, version or key differ from the caller's, payload_bytes disagrees with
// the file's size (a truncated file, a corrupted length, trailing bytes) or
// the checksum differs (corrupted bytes). Bump CacheFormat::version whenever
// the payload's encoding changes: old files then read as misses and are
// rebuilt, never misread.
//
// Writing goes through the one durable-write path (durable_file.hpp): the
// temporary of the rule (temporary_file.hpp), fsync, rename, fsync of the
// directory. Readers see the old file, no file or the whole new file.
//
// Bounded: a cache folder holds at most cache_limit_bytes() of cache files
// (default 2 GiB; $CHROMO_CACHE_LIMIT_BYTES, or set_cache_limit_bytes, e.g.
// from chromod's estimation.cache_limit_bytes). After each write_cache the
// folder's cache files ("<stem>_<16 hex digits>.bin", nothing else) are
// counted and the least recently used are removed until the total is within
// the bound; the file just written is kept even when it alone is larger. A
// hit in read_cache marks its file used (its modification time is set to
// now: the recency stamp, independent of noatime mounts).
//
// Thread rules: free functions, reentrant. Any number of threads and
// processes may read and write the same cache file at once: each writer
// writes its own temporary, the last rename wins, and every file it leaves
// is complete. CacheWriter and CacheReader are plain values (one thread each).

#include <array>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace chromo::files {

// What kind of cache a file is, and which encoding of its payload.
struct CacheFormat {
  std::array<char, 8> magic;
  std::uint32_t version;
};

// "<stem>_<key as 16 hex digits>.bin", e.g. "forward_table_00ab…ef.bin".
std::string cache_file_name(const std::string& stem, std::uint64_t key);

// A cache key as the 16 lower-case hex digits file names and reports show.
std::string cache_key_hex(std::uint64_t key);

// The payload of `file` when it is intact and of this format and key;
// std::nullopt otherwise (see above), with *why (optional) saying which check
// failed, e.g. "another key", "checksum mismatch (corrupted bytes)", for a
// caller that warns. Never throws (but std::bad_alloc).
std::optional<std::vector<std::uint8_t>> read_cache(const std::filesystem::path& file, const CacheFormat& format,
                                                    std::uint64_t key, std::string* why = nullptr);

// Writes the cache file durably, creating its folder if needed. Throws
// std::runtime_error naming the file when it cannot; the target is then
// untouched and no temporary is left. Callers for
// whom the cache only saves time catch it and go on with the content in memory.
void write_cache(const std::filesystem::path& file, const CacheFormat& format, std::uint64_t key,
                 std::span<const std::uint8_t> payload);

inline constexpr std::uint64_t kDefaultCacheLimitBytes = 2ull << 30;
// The bound every write_cache keeps its folder within (process-wide).
std::uint64_t cache_limit_bytes();
void set_cache_limit_bytes(std::uint64_t limit);

// Removes the least recently used cache files of `dir` until their total is
// at most `limit_bytes`, never `keep`; returns the bytes removed. Files that
// are not named as cache files are neither counted nor touched.
std::uint64_t trim_cache_folder(const std::filesystem::path& dir, std::uint64_t limit_bytes,
                                const std::filesystem::path& keep = {});

// Builds a payload: values are appended as their bytes.
class CacheWriter {
 public:
  void put_bytes(const void* data, std::size_t size) {
    const auto* p = static_cast<const std::uint8_t*>(data);
    bytes_.insert(bytes_.end(), p, p + size);
  }
  template <class T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    put_bytes(&value, sizeof value);
  }
  // The element count (uint64) followed by the elements.
  template <class T>
  void put_vector(const std::vector<T>& values) {
    static_assert(std::is_trivially_copyable_v<T>);
    put<std::uint64_t>(values.size());
    put_bytes(values.data(), values.size() * sizeof(T));
  }
  void reserve(std::size_t size) { bytes_.reserve(size); }
  const std::vector<std::uint8_t>& bytes() const { return bytes_; }
  // The payload, moved out (the writer is empty afterwards).
  std::vector<std::uint8_t> take_bytes() { return std::move(bytes_); }

 private:
  std::vector<std::uint8_t> bytes_;
};

// Reads a payload back in the order it was written. A read past the end (or
// a vector longer than its limit) fails softly: it yields zeros, and ok()
// stays false from then on, so a decoder reads everything and checks once.
class CacheReader {
 public:
  explicit CacheReader(std::span<const std::uint8_t> payload) : payload_(payload) {}
  void get_bytes(void* out, std::size_t size) {
    if (!ok_ || size > payload_.size() - at_) {
      ok_ = false;
      std::memset(out, 0, size);
      return;
    }
    std::memcpy(out, payload_.data() + at_, size);
    at_ += size;
  }
  template <class T>
  T get() {
    static_assert(std::is_trivially_copyable_v<T>);
    T value;
    get_bytes(&value, sizeof value);
    return value;
  }
  // A vector written by put_vector, of at most max_count elements.
  template <class T>
  std::vector<T> get_vector(std::uint64_t max_count) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto count = get<std::uint64_t>();
    if (!ok_ || count > max_count || count > (payload_.size() - at_) / sizeof(T)) {
      ok_ = false;
      return {};
    }
    std::vector<T> values(count);
    get_bytes(values.data(), count * sizeof(T));
    return values;
  }
  bool ok() const { return ok_; }
  // Every byte read, none left over.
  bool at_end() const { return ok_ && at_ == payload_.size(); }

 private:
  std::span<const std::uint8_t> payload_;
  std::size_t at_ = 0;
  bool ok_ = true;
};

}  // namespace chromo::files
