#pragma once
// Conversions between the API's messages (chromosphere.v1) and the daemon's
// types (plans and drive levels: chromo/proto/plan_messages.hpp). from_proto()
// validates and names the offending field in its status.

#include <grpcpp/support/status.h>

#include "chromo/daemon/daemon.hpp"
#include "chromo/proto/plan_messages.hpp"
#include "chromosphere/v1/devices.pb.h"
#include "chromosphere/v1/estimation.pb.h"
#include "chromosphere/v1/events.pb.h"
#include "chromosphere/v1/leds.pb.h"
#include "chromosphere/v1/operations.pb.h"
#include "chromosphere/v1/sessions.pb.h"

namespace chromo::daemon {

void to_proto(const DeviceReport& report, chromosphere::v1::Device* out);
void to_proto(const std::string& controller, const drivers::LedStatus& status, chromosphere::v1::LedStatus* out);
grpc::Status from_proto(const chromosphere::v1::LedState& state, const std::string& field, drivers::LedState* out);
void to_proto(const session::OperationRecord& record, chromosphere::v1::Operation* out);
void to_proto(const session::SessionInfo& info, bool include_frames, chromosphere::v1::SessionDetail* out);
// A session's list entry: id, name, folder, operation, subject, study, operator.
void summary_to_proto(const session::OperationRecord& record, chromosphere::v1::SessionSummary* out);
void to_proto(const session::SessionProvenance& provenance, chromosphere::v1::SessionProvenance* out);
void results_to_proto(const session::SessionInfo& info, chromosphere::v1::Results* out);
void to_proto(const Event& event, chromosphere::v1::Event* out);

}  // namespace chromo::daemon
