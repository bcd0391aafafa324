#include "chromo/files/temporary_file.hpp"

#include <signal.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <system_error>

namespace chromo::files {
namespace fs = std::filesystem;

namespace {

constexpr char kPrefix[] = ".tmp-";

// Reads the decimal number at name[*at] up to the next '-', moving *at past
// the '-'. std::nullopt when there is no digit or no '-' after them.
std::optional<long> read_number_and_dash(const std::string& name, std::size_t* at) {
  std::size_t end = *at;
  long value = 0;
  while (end < name.size() && std::isdigit(static_cast<unsigned char>(name[end])) && end - *at < 10)
    value = value * 10 + (name[end++] - '0');
  if (end == *at || end >= name.size() || name[end] != '-') return std::nullopt;
  *at = end + 1;
  return value;
}

// True when `pid` names a running process other than the caller.
bool another_process_runs(long pid) {
  if (pid == static_cast<long>(::getpid())) return false;
  return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM;
}

}  // namespace

fs::path temporary_path_for(const fs::path& path) {
  const std::string name = kPrefix + std::to_string(::getpid()) + "-" + std::to_string(::gettid()) + "-" +
                           path.filename().string();
  return path.parent_path() / name;
}

std::optional<long> temporary_writer_pid(const std::string& file_name) {
  if (file_name.rfind(kPrefix, 0) != 0) return std::nullopt;
  std::size_t at = sizeof kPrefix - 1;
  const auto pid = read_number_and_dash(file_name, &at);
  if (!pid || !read_number_and_dash(file_name, &at) || at >= file_name.size()) return std::nullopt;
  return pid;
}

std::size_t remove_leftover_temporaries(const fs::path& directory, Subfolders subfolders) {
  std::error_code missing;
  if (!fs::is_directory(directory, missing)) return 0;
  std::size_t removed = 0;
  auto visit = [&](const fs::directory_entry& entry) {
    // The entry itself, never what a link names: a temporary is a regular
    // file, and a link (a loop of links included) is left alone.
    std::error_code unreadable;
    if (!fs::is_regular_file(entry.symlink_status(unreadable)) || unreadable) return;
    const auto pid = temporary_writer_pid(entry.path().filename().string());
    if (!pid || another_process_runs(*pid)) return;
    fs::remove(entry.path());  // throws filesystem_error naming the file
    ++removed;
  };
  if (subfolders == Subfolders::kInclude)
    for (const auto& entry : fs::recursive_directory_iterator(directory)) visit(entry);
  else
    for (const auto& entry : fs::directory_iterator(directory)) visit(entry);
  return removed;
}

}  // namespace chromo::files
