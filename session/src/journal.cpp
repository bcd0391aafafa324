#include "chromo/session/journal.hpp"
#include "chromo/files/bounded_read.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>

namespace chromo::session {

Journal::Journal(std::filesystem::path path, files::StorageBudget* budget) : path_(std::move(path)), budget_(budget) {
  bool existed = std::filesystem::exists(path_);
  fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd_ < 0) throw std::runtime_error("open journal " + path_.string() + ": " + std::strerror(errno));
  if (!existed) {
    files::fsync_directory(path_.parent_path());
    return;
  }
  // A torn last line (crash during an append) is closed with a newline so
  // that it stays one malformed line instead of corrupting the next record.
  auto size = std::filesystem::file_size(path_);
  if (size > 0) {
    std::ifstream in(path_, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(size - 1));
    if (in.get() != '\n') {
      files::write_all(fd_, "\n", 1, path_.string());
      files::fsync_or_throw(fd_, path_.string());
    }
  }
}

Journal::~Journal() {
  if (fd_ >= 0) ::close(fd_);
}

void Journal::append(nlohmann::json record) {
  if (!record.contains("t")) record["t"] = utc_timestamp_now();
  std::string line = record.dump() + "\n";
  std::lock_guard lock(mutex_);
  if (budget_) budget_->reserve(line.size(), path_.string());
  files::write_all(fd_, line.data(), line.size(), path_.string());
  files::fsync_or_throw(fd_, path_.string());
}

JournalContents for_each_journal_record(const std::filesystem::path& path,
                                        const std::function<void(nlohmann::json&& record)>& each) {
  JournalContents contents;
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return contents;
  files::check_regular_file(path, files::kMaxJournalBytes, "journal");  // a FIFO is refused before open() blocks
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path.string() + ": cannot open the journal");
  std::string line;
  while (std::getline(in, line)) {
    if (in.eof()) {  // the last line has no '\n': an append a crash interrupted
      contents.torn_tail = !line.empty();
      break;
    }
    auto parsed = nlohmann::json::parse(line, nullptr, false);
    if (parsed.is_object())
      each(std::move(parsed));
    else
      ++contents.malformed_lines;
  }
  if (in.bad()) throw std::runtime_error(path.string() + ": reading the journal failed");
  return contents;
}

JournalContents read_journal(const std::filesystem::path& path) {
  std::vector<nlohmann::json> records;
  JournalContents contents = for_each_journal_record(path, [&records](nlohmann::json&& record) {
    records.push_back(std::move(record));
  });
  contents.records = std::move(records);
  return contents;
}

std::string utc_timestamp_now() {
  auto now = std::chrono::system_clock::now();
  auto seconds = std::chrono::system_clock::to_time_t(now);
  auto micros = std::chrono::duration_cast<std::chrono::microseconds>(now.time_since_epoch()).count() % 1000000;
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char text[96];
  std::snprintf(text, sizeof text, "%04d-%02d-%02dT%02d:%02d:%02d.%06lldZ", tm.tm_year + 1900, tm.tm_mon + 1,
                tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<long long>(micros));
  return text;
}

}  // namespace chromo::session
