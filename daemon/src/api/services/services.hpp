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
//   plan_service.cpp         PlanService         planning.proto (docs/plan-advisor.md)
//   camera_service.cpp       CameraService       cameras.proto (docs/web.md)
//
// Thread rules: gRPC calls the handlers on its own threads, concurrently; a
// service holds references to the Daemon (thread-safe) and the Guard.

#include <atomic>
#include <cctype>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>

#include <grpcpp/grpcpp.h>
#include <grpcpp/impl/service_type.h>
#include <nlohmann/json.hpp>

#include "chromo/daemon/internal/api/api_conversions.hpp"
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

// Who called, for the audit log: "uid:<n>" for a Unix-socket peer (its
// SO_PEERCRED, taken when server.cpp's Unix listener accepted the connection
// and handed it to gRPC, whose peer string is then "fd:<fd>") or
// "token:<8 hex>" for TCP (token_id(): names the credential, never reveals it).
class Peers {
 public:
  // A connection accepted on the Unix socket, handed to gRPC as "fd:<fd>".
  void accepted(int fd, unsigned uid);
  // "uid:<n>", "token:<hex>" or "" when unknown.
  std::string who(const ServerContext& context) const;
  void set_token_id(std::string id) { token_id_ = std::move(id); }
  const std::string& token_id() const { return token_id_; }

 private:
  mutable std::mutex mutex_;
  std::map<int, unsigned> uid_by_fd_;
  std::string token_id_;
};

// UNAUTHENTICATED unless `metadata` carries "authorization: Bearer
// <config.token>" (constant-time comparison). Run by the TCP credentials'
// metadata processor before a call's message is parsed, and again by the Guard.
Status check_bearer(const DaemonConfig& config, const std::multimap<grpc::string_ref, grpc::string_ref>& metadata);
// The token's id in the audit log: 8 hex digits of its FNV-1a hash.
std::string token_id(const std::string& token);

// The append-only audit log <sessions_dir>/audit.jsonl: one fsynced JSON line
// per action that starts, cancels, deletes or changes something (docs/daemon.md).
class AuditLog {
 public:
  explicit AuditLog(std::filesystem::path file) : file_(std::move(file)) {}
  // Appends {"time", "who", "action", ...details, "outcome"[, "error"]};
  // throws std::runtime_error when the line cannot be written and fsynced.
  void record(const std::string& who, const std::string& action, const Status& outcome, const nlohmann::json& details);
  const std::filesystem::path& file() const { return file_; }

 private:
  std::mutex mutex_;
  std::filesystem::path file_;
};

// Common guard of every handler: authentication on TCP, then the handler;
// exceptions become the right status code.
class Guard {
 public:
  Guard(const DaemonConfig& config, std::atomic<bool>& stopping, Peers& peers, AuditLog& audit)
      : config_(config), stopping_(stopping), peers_(peers), audit_(audit) {}

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
  // A server-streaming handler: as operator(), holding one of
  // config.max_streams slots while it runs; RESOURCE_EXHAUSTED naming the
  // limit when all are taken.
  template <typename Body>
  Status stream(ServerContext* context, Body&& body) {
    return (*this)(context, [&]() -> Status {
      if (streams_.fetch_add(1) >= config_.max_streams) {
        streams_.fetch_sub(1);
        return {StatusCode::RESOURCE_EXHAUSTED, "max_streams: " + std::to_string(config_.max_streams) +
                                                    " streaming calls are open already; close one or retry later"};
      }
      struct Release {
        std::atomic<std::uint32_t>& count;
        ~Release() { count.fetch_sub(1); }
      } release{streams_};
      return body();
    });
  }
  // An action that starts, cancels, deletes or changes something: runs
  // body(details) as operator() runs a body (details: a JSON object the body
  // fills, e.g. "session"), then appends the outcome to the audit log,
  // refusals included. A call whose audit line cannot be
  // written after a refusal still returns the refusal; after a success it
  // returns INTERNAL naming the log (the change itself stands).
  template <typename Body>
  Status audited(ServerContext* context, const std::string& action, Body&& body) {
    nlohmann::json details = nlohmann::json::object();
    Status status = (*this)(context, [&]() -> Status { return body(details); });
    try {
      audit_.record(peers_.who(*context), action, status, details);
    } catch (const std::exception& error) {
      if (status.ok()) return {StatusCode::INTERNAL, std::string("audit log: ") + error.what()};
    }
    return status;
  }
  // True once the server shuts down: streaming handlers end.
  bool stopping() const { return stopping_; }
  std::uint32_t open_streams() const { return streams_; }

 private:
  Status authenticate(ServerContext* context) const;
  const DaemonConfig& config_;
  std::atomic<bool>& stopping_;
  Peers& peers_;
  AuditLog& audit_;
  std::atomic<std::uint32_t> streams_{0};
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
// library's map operations (maps/map_operations.hpp), inside one folder of the
// daemon's: the session's, or config.maps_dir without session_id. Inputs are
// relative paths resolved inside it (symbolic links included), outputs a new
// products/<operation>-<time>-<hex> folder (docs/maps.md). Calls run
// synchronously on the gRPC handler thread; the library writes crash-safe.
std::unique_ptr<grpc::Service> make_maps_service(Daemon& daemon, Guard& guard);
std::unique_ptr<grpc::Service> make_plan_service(Daemon& daemon, Guard& guard);
std::unique_ptr<grpc::Service> make_camera_service(Daemon& daemon, Guard& guard);

}  // namespace chromo::daemon::services
