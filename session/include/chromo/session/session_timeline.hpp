#pragma once
// Where a session's time went, from its journal's record times ("t": UTC,
// microseconds, session/journal.hpp): what `chromo session show` prints and
// the API's SessionDetail.timeline carries, so the main job and an operator
// see the split between capturing, writing derived data and estimating.
//
// Every phase is measured between journal records (docs/formats/session.md):
//   capture     first "step_started" → last "frame" (the last frame stored)
//   subject     first → last "frame" of a subject step: how long the subject
//               holds still, less the first subject frame's exposure and readout
//   derived     last "frame" → last "derived" record
//   estimation  last "frame" → "results" (maps published, or not available)
//   total       first "step_started" → the final "state" record
// A phase the journal does not show (a session still running, one that
// failed before its first frame, a hand-made folder) is -1. Records whose
// "type" or "t" is missing or not a string are ignored.
//
// Thread rules: a pure function.

#include <cstdint>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

namespace chromo::session {

struct SessionTimeline {
  double capture_s = -1;
  double subject_s = -1;
  double derived_s = -1;
  double estimation_s = -1;
  double total_s = -1;
  bool operator==(const SessionTimeline&) const = default;
};

SessionTimeline session_timeline(const std::vector<nlohmann::json>& journal_records);

// The same, one record at a time, for a journal read as a stream
// (for_each_journal_record): add() each record in order, then result().
class SessionTimelineBuilder {
 public:
  void add(const nlohmann::json& record);
  SessionTimeline result() const;

 private:
  std::optional<std::int64_t> first_step_, last_frame_, first_subject_, last_subject_, last_derived_, results_,
      final_state_;
};

}  // namespace chromo::session
