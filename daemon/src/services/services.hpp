#pragma once
// The gRPC services of proto/chromosphere/v1/, one file each, and what they
// share: the Guard every handler runs in, and the checks of ids and names.
// Private to the daemon library: server.cpp makes one of each and registers
// them (server.hpp).
//
//   device_service.cpp       DeviceService       devices.proto
//   led_service.cpp          LedService          leds.proto
//   operation_service.cpp    OperationService    operations.proto
//   session_service.cpp      SessionService      sessions.proto
//   calibration_service.cpp  CalibrationService  calibration.proto
//   results_service.cpp      ResultsService      estimation.proto
//   event_service.cpp        EventService        events.proto
//   maps_service.cpp         MapsService         maps.proto (docs/maps.md)
//
// Thread rules: gRPC calls the handlers on its own threads, concurrently; a
// service holds references to the Daemon (thread-safe) and the Guard.

#include <atomic>
#include <cctype>
#include <memory>
#include <stdexcept>
#include <string>

#include <grpcpp/grpcpp.h>
#include <grpcpp/impl/service_type.h>

#include "chromo/daemon/api_conversions.hpp"
#include "chromo/daemon/daemon.hpp"
#include "chromo/drivers/device_error.hpp"

namespace chromo::daemon::services {

// The daemon's API conversions (api_conversions.hpp) and the plan and
// drive-level ones (chromo/proto/plan_messages.hpp), as one overload set.
using daemon::from_proto;
using daemon::to_proto;
using proto::from_proto;
using proto::to_proto;

namespace pb = chromosphere::v1;
using grpc::ServerContext;
using grpc::Status;
using grpc::StatusCode;

inline Status invalid(const std::string& message) { return {StatusCode::INVALID_ARGUMENT, message}; }

// Common guard of every handler: authentication on TCP, then the handler;
// exceptions become the right status code.
class Guard {
 public:
  Guard(const DaemonConfig& config, std::atomic<bool>& stopping) : config_(config), stopping_(stopping) {}

  template <typename Body>
  Status operator()(ServerContext* context, Body&& body) const {
    if (Status auth = authenticate(context); !auth.ok()) return auth;
    try {
      return body();
    } catch (const std::invalid_argument& error) {
      return invalid(error.what());
    } catch (const std::logic_error& error) {
      return {StatusCode::FAILED_PRECONDITION, error.what()};
    } catch (const drivers::DeviceError& error) {
      bool unanswered = error.kind() == drivers::DeviceError::Kind::kTimeout ||
                        error.kind() == drivers::DeviceError::Kind::kDisconnected;
      if (error.kind() == drivers::DeviceError::Kind::kInvalidRequest) return invalid(error.what());
      return {unanswered ? StatusCode::UNAVAILABLE : StatusCode::FAILED_PRECONDITION, error.what()};
    } catch (const std::exception& error) {
      return {StatusCode::INTERNAL, error.what()};
    }
  }
  // True once the server shuts down: streaming handlers end.
  bool stopping() const { return stopping_; }

 private:
  Status authenticate(ServerContext* context) const;
  const DaemonConfig& config_;
  std::atomic<bool>& stopping_;
};

// An operation or session id: INVALID_ARGUMENT naming `field` unless it is one.
Status check_id(const std::string& field, const std::string& id);
// A device name: INVALID_ARGUMENT naming `field` when longer than 128 bytes.
Status check_device_name(const std::string& field, const std::string& name);

std::unique_ptr<grpc::Service> make_device_service(Daemon& daemon, Guard& guard);
std::unique_ptr<grpc::Service> make_led_service(Daemon& daemon, Guard& guard);
std::unique_ptr<grpc::Service> make_operation_service(Daemon& daemon, Guard& guard);
std::unique_ptr<grpc::Service> make_session_service(Daemon& daemon, Guard& guard);
std::unique_ptr<grpc::Service> make_calibration_service(Daemon& daemon, Guard& guard);
std::unique_ptr<grpc::Service> make_results_service(Daemon& daemon, Guard& guard);
std::unique_ptr<grpc::Service> make_event_service(Daemon& daemon, Guard& guard);
// MapsService: relight, flush, import-maps and profile export over the maps
// library's map operations (maps/map_operations.hpp), on files of a session
// folder. Paths: with session_id set, every file field is a relative path
// inside <sessions_dir>/<session_id>/ (no "..", no absolute path); with
// session_id empty, an absolute path. Calls run synchronously on the gRPC
// handler thread (the operation's own threads: all cores); the library
// writes crash-safe.
std::unique_ptr<grpc::Service> make_maps_service(Daemon& daemon, Guard& guard);

}  // namespace chromo::daemon::services
