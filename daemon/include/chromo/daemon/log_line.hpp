#pragma once
// chromod's own log lines (not the audit log, not session journals): plain
// "chromod: <message>" lines, or with log_format "json" one JSON object a
// line, {"time": RFC 3339 UTC with ms, "level": "info|warning|error",
// "program": "chromod", "message": ...}, for journald or a log shipper
// (docs/observability.md). Info goes to stdout, warnings and errors to stderr.
// Thread-safe: each line is written whole.

#include <chrono>
#include <string>
#include <string_view>

namespace chromo::daemon {

enum class LogFormat { kText, kJson };
enum class LogLevel { kInfo, kWarning, kError };

// "text" or "json"; std::invalid_argument otherwise.
LogFormat parse_log_format(const std::string& name);

// One line, with its newline.
std::string format_log_line(LogFormat format, LogLevel level, std::string_view message,
                            std::chrono::system_clock::time_point now);

// The process's format (text until set).
void set_log_format(LogFormat format);
void log_line(LogLevel level, std::string_view message);

}  // namespace chromo::daemon
