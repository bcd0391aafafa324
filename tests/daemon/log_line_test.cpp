// chromod's own log lines, text and JSON (daemon/log_line.hpp, docs/observability.md).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "chromo/daemon/log_line.hpp"

namespace chromo::daemon {
namespace {

TEST(LogLine, TextIsTheProgramsPrefixAndJsonOneObjectALine) {
  const auto at = std::chrono::system_clock::from_time_t(1796601600) + std::chrono::milliseconds(42);  // 2026-12-07T00:00:00.042Z
  EXPECT_EQ(format_log_line(LogFormat::kText, LogLevel::kInfo, "listening on unix:/run/x.sock", at),
            "chromod: listening on unix:/run/x.sock\n");
  const std::string line = format_log_line(LogFormat::kJson, LogLevel::kWarning, "cam0: \"lost\"\nagain", at);
  ASSERT_EQ(line.back(), '\n');
  EXPECT_EQ(line.find('\n'), line.size() - 1);  // the message's newline is escaped: one line
  const auto json = nlohmann::json::parse(line);
  EXPECT_EQ(json["time"], "2026-12-07T00:00:00.042Z");
  EXPECT_EQ(json["level"], "warning");
  EXPECT_EQ(json["program"], "chromod");
  EXPECT_EQ(json["message"], "cam0: \"lost\"\nagain");
  // Bytes that are not UTF-8 (a device's answer) are replaced, never a broken line.
  EXPECT_NO_THROW(nlohmann::json::parse(format_log_line(LogFormat::kJson, LogLevel::kError, "serial \xff\xfe", at)));
}

TEST(LogLine, TheFormatIsTextOrJson) {
  EXPECT_EQ(parse_log_format("json"), LogFormat::kJson);
  EXPECT_EQ(parse_log_format("text"), LogFormat::kText);
  EXPECT_THROW(parse_log_format("xml"), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::daemon
