#pragma once
// The record of a long operation (a capture session or a calibration run) as
// its folder's journal states it and the API reports it: kind, state,
// progress, frame counters. Plain data; the daemon's OperationRegistry
// (daemon/internal/operations/operations.hpp) keeps the live ones, SessionStore reads them back.

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace chromo::session {

// What the frame pipeline counted for one session (daemon/internal/capture/frame_pipeline.hpp).
struct PipelineCounters {
  std::uint64_t received = 0, stored = 0, estimated = 0, estimator_skipped = 0, lost = 0, resent_packets = 0;
  std::map<std::string, std::uint64_t> lost_reasons, skipped_reasons;
  double max_trigger_to_stored_ms = 0, mean_trigger_to_stored_ms = 0;
  double storage_cpu_ms = 0, estimator_cpu_ms = 0;  // CPU time of the pipeline's own threads
  // Frames waiting for the estimator now and at most; frames it read back
  // from storage after skipping them (set by the daemon after end_session).
  std::uint64_t estimator_queue_depth = 0, max_estimator_queue_depth = 0, estimator_read_back = 0;
};

// The journal's {"type": "counters"} record of a session's end
// (docs/formats/session.md) and back: the pair the daemon writes and
// SessionStore reads. The live-only fields (estimator_queue_depth, the CPU
// times) are not recorded. from_json: absent fields are 0 (an older
// journal); a field of the wrong type throws std::invalid_argument naming it.
nlohmann::json counters_record(const PipelineCounters& counters);
PipelineCounters counters_from_record(const nlohmann::json& record);

enum class OperationKind { kSession, kCalibration };
enum class OperationState { kPending, kRunning, kPaused, kSucceeded, kFailed, kCancelled, kInterrupted };
std::string state_name(OperationState state);
std::optional<OperationState> parse_state(const std::string& name);
bool is_final(OperationState state);

struct OperationRecord {
  std::string id;
  OperationKind kind = OperationKind::kSession;
  std::string name;
  OperationState state = OperationState::kPending;
  double progress = 0;
  double eta_seconds = -1;
  std::string message, error;
  std::chrono::system_clock::time_point created, updated;
  PipelineCounters counters;
  std::uint64_t expected_frames = 0;
  std::string folder;
  int step_index = -1, step_count = 0;
  // A session's subject, study and operator (session.json), so that lists tell sessions apart.
  std::string subject, study, operator_name;
};

}  // namespace chromo::session
