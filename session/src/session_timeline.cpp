#include "chromo/session/session_timeline.hpp"

#include "chromo/session/operation_record.hpp"

#include <cstdint>
#include <cstdio>
#include <ctime>
#include <optional>
#include <string>

namespace chromo::session {
namespace {

// "2026-11-22T16:04:47.123456Z" → microseconds since the Unix epoch (exact,
// so differences are too); nullopt otherwise.
std::optional<std::int64_t> microseconds_of(const nlohmann::json& record) {
  const auto t = record.find("t");
  if (t == record.end() || !t->is_string()) return std::nullopt;
  const std::string& text = t->get_ref<const std::string&>();
  std::tm tm{};
  int micros = 0, consumed = 0;
  if (std::sscanf(text.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d.%6dZ%n", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &tm.tm_hour,
                  &tm.tm_min, &tm.tm_sec, &micros, &consumed) != 7 ||
      consumed != static_cast<int>(text.size()))
    return std::nullopt;
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  return static_cast<std::int64_t>(timegm(&tm)) * 1000000 + micros;
}

std::string type_of(const nlohmann::json& record) {
  const auto type = record.find("type");
  return type != record.end() && type->is_string() ? type->get<std::string>() : std::string();
}

bool is_final_state(const nlohmann::json& record) {
  const auto state = record.find("state");
  if (state == record.end() || !state->is_string()) return false;
  const auto parsed = parse_state(state->get<std::string>());
  return parsed && is_final(*parsed);
}

bool is_subject_frame(const nlohmann::json& record) {
  const auto role = record.find("role");
  return role != record.end() && role->is_string() && role->get_ref<const std::string&>() == "subject";
}

}  // namespace

void SessionTimelineBuilder::add(const nlohmann::json& record) {
  const std::string type = type_of(record);
  const std::optional<std::int64_t> t = microseconds_of(record);
  if (!t) return;
  if (type == "step_started" && !first_step_) first_step_ = t;
  if (type == "frame") {
    last_frame_ = t;
    if (is_subject_frame(record)) {
      if (!first_subject_) first_subject_ = t;
      last_subject_ = t;
    }
  }
  if (type == "derived") last_derived_ = t;
  if (type == "results") results_ = t;
  if (type == "state" && is_final_state(record)) final_state_ = t;
}

SessionTimeline SessionTimelineBuilder::result() const {
  auto seconds = [](std::int64_t from, std::int64_t to) { return static_cast<double>(to - from) * 1e-6; };
  SessionTimeline timeline;
  if (first_step_ && last_frame_) timeline.capture_s = seconds(*first_step_, *last_frame_);
  if (first_subject_ && last_subject_) timeline.subject_s = seconds(*first_subject_, *last_subject_);
  if (last_frame_ && last_derived_) timeline.derived_s = seconds(*last_frame_, *last_derived_);
  if (last_frame_ && results_) timeline.estimation_s = seconds(*last_frame_, *results_);
  if (first_step_ && final_state_) timeline.total_s = seconds(*first_step_, *final_state_);
  return timeline;
}

SessionTimeline session_timeline(const std::vector<nlohmann::json>& journal_records) {
  SessionTimelineBuilder builder;
  for (const nlohmann::json& record : journal_records) builder.add(record);
  return builder.result();
}

}  // namespace chromo::session
