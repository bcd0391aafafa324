#pragma once
// WebServer: the operator's web view (docs/web.md), served by chromod on
// config.web_address when set (chromod --web HOST:PORT).
//
// - Static files of the built front end, only from config.web_dir (no path
//   outside it, no hidden or odd names: a clear 404).
// - Log-in: POST /login {"token": ...} compared in constant time with
//   config.token; success sets the cookie "chromo_session" (64 random hex
//   digits; HttpOnly, SameSite=Strict, Path=/, Secure under TLS). Failed
//   attempts are limited per source (kMaxFailedLogins a minute, then 429;
//   every loopback address is one source, IPv6 counts by /64). Log-ins and
//   wrong tokens are appended to the audit log ("web_login"); a lock-out's
//   refusals are at most two lines.
// - Every request's Host must name this server (loopback names, the
//   web_address host, the address it arrived on, config.web_host_names):
//   else 421 (DNS rebinding). Methods other than GET, HEAD, POST: 405.
// - Bodies: at most config.web_max_body_bytes, counted as they arrive
//   (chunked and compressed ones too): else 413.
// - Streams: at most config.web_max_streams; an idle one writes an SSE
//   comment every config.web_stream_keepalive_ms and ends when its client
//   has gone.
// - The API: POST /api/<Service>/<Method> with the request as JSON calls that
//   unary method of chromosphere.v1 over the gRPC server's in-process channel
//   with the bearer token, so the services' guard, limits and audit apply as
//   for lab automation (the web layer goes over the API, not around it).
//   GET /api/stream/preview and /api/stream/events are server-sent events
//   over CameraService.StreamPreview and EventService.Subscribe.
// - GET /api/files/<session id>/<path>: a file of that session's folder
//   (config.sessions_dir/<id>; results/maps.exr, previews, summary.json),
//   never one outside it (the same rules as the static files).
// - Every POST must carry an Origin equal to this server's (cross-origin:
//   403); every response carries a Content-Security-Policy without inline
//   script, Referrer-Policy same-origin, X-Content-Type-Options nosniff.
//
// TLS (config.tls_certificate_file/tls_private_key_file) when configured;
// config.IsValid() refuses a non-loopback web_address without it.
// Thread rules: the server runs its own threads; stop() is thread-safe.
// Lifetime: must not outlive the gRPC server whose channel it holds.

#include <functional>
#include <memory>
#include <string>

#include "chromo/daemon/config.hpp"

namespace grpc {
class Channel;
}

namespace chromo::daemon {

inline constexpr int kMaxFailedLogins = 5;  // per source (loopback is one), per minute

// Appends one line to the audit log: who, action, outcome, error (empty = ok).
using WebAuditor = std::function<void(const std::string& who, const std::string& action, const std::string& error)>;

class WebServer {
 public:
  // Listens on config.web_address serving config.web_dir (must be set).
  // Throws std::runtime_error when it cannot listen or read the TLS files.
  WebServer(const DaemonConfig& config, std::shared_ptr<grpc::Channel> api_channel, WebAuditor audit);
  ~WebServer();
  int port() const;
  void stop();

  struct State;

 private:
  std::unique_ptr<State> state_;
};

}  // namespace chromo::daemon
