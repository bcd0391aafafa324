#pragma once
// Crash-safe file writing, for every library that writes results a person
// relies on (session folders, LED libraries, camera references, estimate
// outputs).
//
// write_file_durably(): the bytes go to the temporary of <path>
// (temporary_file.hpp: DIR/.tmp-<pid>-<tid>-NAME), which is fsynced, renamed
// over <path>, and the directory fsynced: after a crash either the old file
// (or none) or the complete new one exists, never a torn one; the crash's
// temporary is left for remove_leftover_temporaries().
//
// StorageBudget: an optional cap on the bytes the storage layer may write,
// shared by every writer of one daemon. It exists so that the "disk full" path
// (ENOSPC) is exercised through the real files in tests without mounting a
// small filesystem: when a write would exceed the cap, the writer fails
// exactly as it does on ENOSPC (StorageFullError) before touching the target.
// Thread-safe.

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <stdexcept>
#include <string>

namespace chromo::files {

// The disk (or the configured budget) is full. Nothing already written was
// changed; the write that raised it left no file behind.
class StorageFullError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class StorageBudget {
 public:
  // limit_bytes 0 = unlimited.
  explicit StorageBudget(std::uint64_t limit_bytes = 0) : limit_bytes_(limit_bytes) {}
  // Reserves bytes or throws StorageFullError naming `what`.
  void reserve(std::uint64_t bytes, const std::string& what);
  std::uint64_t used_bytes() const { return used_bytes_.load(); }
  std::uint64_t limit_bytes() const { return limit_bytes_; }

 private:
  std::uint64_t limit_bytes_;
  std::atomic<std::uint64_t> used_bytes_{0};
};

// Writes all bytes to fd or throws (StorageFullError on ENOSPC/EDQUOT,
// std::runtime_error naming `what` otherwise).
void write_all(int fd, const void* data, std::size_t size, const std::string& what);
void fsync_or_throw(int fd, const std::string& what);
void fsync_directory(const std::filesystem::path& directory);
// fsync of a file written through another API (std::ofstream, OpenEXR...).
void fsync_file(const std::filesystem::path& file);

// Writes through a temporary file the `produce` callback fills (it gets the
// temporary path; e.g. libtiff or OpenEXR write it), then fsync, rename, fsync
// directory. The budget is charged with the temporary file's size before the
// rename. On any failure the temporary is removed and the target is untouched.
void commit_file_durably(const std::filesystem::path& path, StorageBudget* budget,
                         const std::function<void(const std::filesystem::path& temporary)>& produce);

void write_file_durably(const std::filesystem::path& path, std::span<const std::uint8_t> bytes,
                        StorageBudget* budget);
void write_file_durably(const std::filesystem::path& path, const std::string& text, StorageBudget* budget);

}  // namespace chromo::files
