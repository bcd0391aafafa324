// chromod's own log lines, text or JSON (log_line.hpp).
#include "chromo/daemon/log_line.hpp"

#include <atomic>
#include <ctime>
#include <iostream>
#include <mutex>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace chromo::daemon {
namespace {

std::atomic<LogFormat> process_format{LogFormat::kText};
std::mutex write_mutex;

const char* level_name(LogLevel level) {
  switch (level) {
    case LogLevel::kInfo: return "info";
    case LogLevel::kWarning: return "warning";
    case LogLevel::kError: return "error";
  }
  return "info";
}

}  // namespace

LogFormat parse_log_format(const std::string& name) {
  if (name == "text") return LogFormat::kText;
  if (name == "json") return LogFormat::kJson;
  throw std::invalid_argument("\"" + name.substr(0, 64) + "\" is not text or json");
}

std::string format_log_line(LogFormat format, LogLevel level, std::string_view message,
                            std::chrono::system_clock::time_point now) {
  if (format == LogFormat::kText) return fmt::format("chromod: {}\n", message);
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  nlohmann::ordered_json line;
  line["time"] = fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}.{:03}Z", utc.tm_year + 1900, utc.tm_mon + 1, utc.tm_mday,
                             utc.tm_hour, utc.tm_min, utc.tm_sec, ms);
  line["level"] = level_name(level);
  line["program"] = "chromod";
  line["message"] = std::string(message);
  return line.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

void set_log_format(LogFormat format) { process_format = format; }

void log_line(LogLevel level, std::string_view message) {
  const std::string line = format_log_line(process_format, level, message, std::chrono::system_clock::now());
  std::lock_guard lock(write_mutex);
  std::ostream& out = level == LogLevel::kInfo ? std::cout : std::cerr;
  out << line << std::flush;
}

}  // namespace chromo::daemon
