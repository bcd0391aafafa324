#pragma once
// The Maps service of proto/chromosphere/v1/maps.proto: relight, flush,
// import-maps and profile export over the estimation library's map
// operations (maps/map_operations.hpp), on files of a session folder.
//
// Paths: with session_id set, every file field is a relative path inside
// <sessions_dir>/<session_id>/ (no "..", no absolute path); with session_id
// empty, an absolute path. Calls run synchronously on the gRPC handler thread
// (the operation's own threads: all cores); the library writes crash-safe.
//
// The server owns the service and wraps every handler in its guard
// (authentication, exception → status), passed in as `guard`.

#include <functional>
#include <memory>

#include <grpcpp/grpcpp.h>

#include "chromo/daemon/daemon.hpp"

namespace chromo::daemon {

using HandlerGuard = std::function<grpc::Status(grpc::ServerContext*, const std::function<grpc::Status()>&)>;

std::unique_ptr<grpc::Service> make_maps_service(Daemon& daemon, HandlerGuard guard);

}  // namespace chromo::daemon
