#include "chromo/session/operation_record.hpp"

#include <stdexcept>
#include <type_traits>

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

nlohmann::json counters_record(const PipelineCounters& counters) {
  return {{"type", "counters"},
          {"received", counters.received},
          {"stored", counters.stored},
          {"estimated", counters.estimated},
          {"estimator_skipped", counters.estimator_skipped},
          {"lost", counters.lost},
          {"resent_packets", counters.resent_packets},
          {"lost_reasons", counters.lost_reasons},
          {"max_estimator_queue_depth", counters.max_estimator_queue_depth},
          {"estimator_read_back", counters.estimator_read_back},
          {"skipped_reasons", counters.skipped_reasons},
          {"mean_trigger_to_stored_ms", counters.mean_trigger_to_stored_ms},
          {"max_trigger_to_stored_ms", counters.max_trigger_to_stored_ms}};
}

PipelineCounters counters_from_record(const nlohmann::json& record) {
  PipelineCounters c;
  auto field = [&](const char* name, auto& value) {
    const auto found = record.find(name);
    if (found == record.end()) return;
    try {
      found->get_to(value);
    } catch (const nlohmann::json::exception&) {
      throw std::invalid_argument(std::string("counters record: \"") + name + "\": " + found->dump() +
                                  " is not " + (std::is_floating_point_v<std::decay_t<decltype(value)>> ? "a number"
                                                : std::is_integral_v<std::decay_t<decltype(value)>> ? "a count"
                                                                                                   : "an object of counts"));
    }
  };
  if (!record.is_object()) throw std::invalid_argument("counters record: not a JSON object");
  field("received", c.received);
  field("stored", c.stored);
  field("estimated", c.estimated);
  field("estimator_skipped", c.estimator_skipped);
  field("lost", c.lost);
  field("resent_packets", c.resent_packets);
  field("lost_reasons", c.lost_reasons);
  field("max_estimator_queue_depth", c.max_estimator_queue_depth);
  field("estimator_read_back", c.estimator_read_back);
  field("skipped_reasons", c.skipped_reasons);
  field("mean_trigger_to_stored_ms", c.mean_trigger_to_stored_ms);
  field("max_trigger_to_stored_ms", c.max_trigger_to_stored_ms);
  return c;
}

bool is_final(OperationState state) {
  return state == OperationState::kSucceeded || state == OperationState::kFailed ||
         state == OperationState::kCancelled || state == OperationState::kInterrupted;
}

}  // namespace chromo::session
