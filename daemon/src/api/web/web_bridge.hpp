#pragma once
// The web view's bridge to the API (web_server.hpp): JSON in, a unary call of
// chromosphere.v1 over the in-process channel with the bearer token, JSON
// out; and the server-sent event streams over the streaming methods.
// Private to the daemon library.

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>

namespace chromo::daemon::web {

struct BridgeReply {
  int http_status = 200;
  std::string json;  // the response message, or {"error": ..., "code": ...}
};

class ApiBridge {
 public:
  ApiBridge(std::shared_ptr<grpc::Channel> channel, std::string token)
      : channel_(std::move(channel)), token_(std::move(token)) {}
  // POST /api/<service>/<method>: only unary methods of chromosphere.v1.
  BridgeReply call(const std::string& service, const std::string& method, const std::string& request_json) const;
  // A server-streaming method: each message as JSON to `send` (false: the
  // client left) until the stream or the client ends. While no message comes,
  // `idle` is called every `idle_interval` (false: the client left, and the
  // call is cancelled, freeing its max_streams slot). Returns the final status
  // as a reply (its json is empty on OK).
  BridgeReply stream(const std::string& service, const std::string& method, const std::string& request_json,
                     const std::function<bool(const std::string& json)>& send,
                     std::chrono::milliseconds idle_interval, const std::function<bool()>& idle) const;

 private:
  std::shared_ptr<grpc::Channel> channel_;
  std::string token_;
};

// A gRPC status as the bridge's HTTP status (INVALID_ARGUMENT 400, NOT_FOUND
// 404, FAILED_PRECONDITION 409, RESOURCE_EXHAUSTED 429, UNAVAILABLE 503, ...).
int http_status_of(grpc::StatusCode code);
std::string error_json(const std::string& message, const std::string& code);
// Exactly `count` finite numbers separated by commas ("0.1,0.2,0.5,0.5"), or
// std::nullopt (a query parameter's list).
std::optional<std::vector<double>> parse_numbers(const std::string& text, std::size_t count);

}  // namespace chromo::daemon::web
