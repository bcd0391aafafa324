// chromod's counters as Prometheus text (the web view's /metrics,
// docs/observability.md). Internal to the web view.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include <grpcpp/channel.h>

#include "chromosphere/v1/cameras.pb.h"
#include "chromosphere/v1/operations.pb.h"

namespace chromo::daemon::web {

// The sessions /metrics reports: the newest ones, running or not.
inline constexpr unsigned kMetricsSessions = 20;

// Prometheus text exposition (version 0.0.4) of the cameras' stream counters
// and the sessions' frame counters, estimator queue and throughput (frames
// estimated per second of the session so far, at `now`). Pure formatting.
std::string prometheus_text(const chromosphere::v1::ListCamerasResponse& cameras,
                            const chromosphere::v1::ListOperationsResponse& sessions,
                            std::chrono::system_clock::time_point now);

// Asks the API (CameraService.ListCameras, OperationService.ListOperations of
// the newest kMetricsSessions sessions) over `channel` with the token, and
// formats the answers. Throws std::runtime_error naming the call that failed.
std::string collect_metrics(const std::shared_ptr<grpc::Channel>& channel, const std::string& token);

}  // namespace chromo::daemon::web
