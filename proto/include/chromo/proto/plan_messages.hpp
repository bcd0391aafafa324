#pragma once
// Conversions between the API's session-plan and drive-level messages
// (chromosphere.v1) and the libraries' types, shared by chromod (which checks
// what clients send) and `chromo session run` (which sends a plan file).
// from_proto() validates and names the offending field in its status.
// Thread rules: free functions, reentrant.

#include <string>

#include <grpcpp/support/status.h>

#include "chromo/drivers/led_controller.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromosphere/v1/common.pb.h"
#include "chromosphere/v1/sessions.pb.h"

namespace chromo::proto {

chromosphere::v1::StepRole role_to_proto(session::StepRole role);
chromosphere::v1::Polarisation polarisation_to_proto(drivers::Polarisation polarisation);

void to_proto(const drivers::DriveLevels& levels, chromosphere::v1::DriveLevels* out);
drivers::DriveLevels from_proto(const chromosphere::v1::DriveLevels& levels);
// OK, or INVALID_ARGUMENT naming `field`.<led> when a level is outside [0, 1].
grpc::Status check_levels(const drivers::DriveLevels& levels, const std::string& field);

grpc::Status from_proto(const chromosphere::v1::SessionPlan& plan, const std::string& field, session::SessionPlan* out);
void to_proto(const session::SessionPlan& plan, chromosphere::v1::SessionPlan* out);

}  // namespace chromo::proto
