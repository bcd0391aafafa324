#include "chromo/files/durable_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "chromo/files/temporary_file.hpp"

namespace chromo::files {

void StorageBudget::reserve(std::uint64_t bytes, const std::string& what) {
  if (limit_bytes_ == 0) {
    used_bytes_ += bytes;
    return;
  }
  std::uint64_t used = used_bytes_.load();
  do {
    if (used + bytes > limit_bytes_)
      throw StorageFullError(what + ": storage full (budget of " + std::to_string(limit_bytes_) +
                             " bytes reached, " + std::to_string(used) + " used)");
  } while (!used_bytes_.compare_exchange_weak(used, used + bytes));
}

namespace {
[[noreturn]] void throw_errno(int error, const std::string& what) {
  if (error == ENOSPC || error == EDQUOT) throw StorageFullError(what + ": " + std::strerror(error));
  throw std::runtime_error(what + ": " + std::strerror(error));
}
}  // namespace

void write_all(int fd, const void* data, std::size_t size, const std::string& what) {
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  while (size > 0) {
    ssize_t written = ::write(fd, bytes, size);
    if (written < 0) {
      if (errno == EINTR) continue;
      throw_errno(errno, "write " + what);
    }
    bytes += written;
    size -= static_cast<std::size_t>(written);
  }
}

void fsync_or_throw(int fd, const std::string& what) {
  if (::fsync(fd) != 0) throw_errno(errno, "fsync " + what);
}

void fsync_directory(const std::filesystem::path& directory) {
  int fd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) throw_errno(errno, "open directory " + directory.string());
  int result = ::fsync(fd);
  int error = errno;
  ::close(fd);
  if (result != 0) throw_errno(error, "fsync directory " + directory.string());
}

void fsync_file(const std::filesystem::path& file) {
  int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw_errno(errno, "open " + file.string());
  int result = ::fsync(fd);
  int error = errno;
  ::close(fd);
  if (result != 0) throw_errno(error, "fsync " + file.string());
}

void commit_file_durably(const std::filesystem::path& path, StorageBudget* budget,
                         const std::function<void(const std::filesystem::path&)>& produce) {
  const auto temporary = temporary_path_for(path);
  try {
    produce(temporary);
    int fd = ::open(temporary.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw_errno(errno, "open " + temporary.string());
    struct CloseFd {
      int fd;
      ~CloseFd() { ::close(fd); }
    } closer{fd};
    if (budget) budget->reserve(std::filesystem::file_size(temporary), path.string());
    fsync_or_throw(fd, temporary.string());
    std::filesystem::rename(temporary, path);
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    throw;
  }
  fsync_directory(path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path());
}

void write_file_durably(const std::filesystem::path& path, std::span<const std::uint8_t> bytes,
                        StorageBudget* budget) {
  commit_file_durably(path, budget, [&](const std::filesystem::path& temporary) {
    int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) throw_errno(errno, "create " + temporary.string());
    try {
      write_all(fd, bytes.data(), bytes.size(), temporary.string());
    } catch (...) {
      ::close(fd);
      throw;
    }
    ::close(fd);
  });
}

void write_file_durably(const std::filesystem::path& path, const std::string& text, StorageBudget* budget) {
  write_file_durably(path, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()), budget);
}

}  // namespace chromo::files
