#include "chromo/session/operation_record.hpp"

namespace chromo::session {

std::string state_name(OperationState state) {
  switch (state) {
    case OperationState::kPending: return "pending";
    case OperationState::kRunning: return "running";
    case OperationState::kPaused: return "paused";
    case OperationState::kSucceeded: return "succeeded";
    case OperationState::kFailed: return "failed";
    case OperationState::kCancelled: return "cancelled";
    case OperationState::kInterrupted: return "interrupted";
  }
  return "unknown";
}

std::optional<OperationState> parse_state(const std::string& name) {
  for (auto state : {OperationState::kPending, OperationState::kRunning, OperationState::kPaused,
                     OperationState::kSucceeded, OperationState::kFailed, OperationState::kCancelled,
                     OperationState::kInterrupted})
    if (state_name(state) == name) return state;
  return std::nullopt;
}

bool is_final(OperationState state) {
  return state == OperationState::kSucceeded || state == OperationState::kFailed ||
         state == OperationState::kCancelled || state == OperationState::kInterrupted;
}

}  // namespace chromo::session
