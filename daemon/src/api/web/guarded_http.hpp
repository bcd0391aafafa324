#pragma once
// The web view's connections, served by chromod rather than by cpp-httplib's
// own loop (web_server.cpp; docs/web.md "Limits"). Debian 12's cpp-httplib
// 0.11.4 reads a request line, a header line or a chunk-size line of any
// length into memory, keeps a connection's thread for as long as the client
// dribbles its request head (slowloris: 100 connections at a byte a second
// held every thread), and after a refused body reads its unread rest as new
// requests. Here each connection is read through a GuardedStream:
//
// - the request head (request line and headers) must arrive whole within
//   head_timeout and max_head_bytes, else the connection is closed;
// - a body may take at most max_body_wire_bytes on the wire (framing
//   included; the decoded body is capped by the route, web_max_body_bytes);
// - after a response that closes (413, 421, ...), nothing more is read;
// - when every HTTP thread is busy and a connection waits, the connection
//   that has waited longest for its request head (or between keep-alive
//   requests), if longer than shed_after, is shut down to free its thread.
//
// The same for TLS: the handshake counts as part of the first request head.
// Private to the daemon library.

#include <chrono>
#include <cstddef>
#include <memory>

#include <httplib.h>

namespace chromo::daemon::web {

struct ConnectionLimits {
  std::size_t max_head_bytes = 64 * 1024;
  std::size_t max_body_wire_bytes = 2 * (1u << 20) + 64 * 1024;
  std::chrono::milliseconds head_timeout{10000};
  std::chrono::milliseconds keep_alive_timeout{5000};
  std::chrono::milliseconds io_timeout{5000};  // a read or write that makes no progress
  std::chrono::milliseconds shed_after{1000};
  std::size_t max_requests_per_connection = 100;
  std::size_t threads = 48;
};

// What the guarded connections saw (for tests and the log).
struct ConnectionCounters {
  std::size_t heads_too_long = 0, heads_too_slow = 0, bodies_too_long = 0, shed = 0;
};

// The response being written closes its connection: nothing more is read
// from it (call from a route handler, on the thread serving the request).
void close_connection_after_response();

class ConnectionGuard;  // the connections in flight, the thread pool's shedding

// httplib::Server / SSLServer serving each connection through a GuardedStream.
std::unique_ptr<httplib::Server> make_guarded_server(const ConnectionLimits& limits, const char* certificate_file,
                                                     const char* private_key_file,
                                                     std::shared_ptr<ConnectionGuard>* guard);
ConnectionCounters counters_of(const ConnectionGuard& guard);

}  // namespace chromo::daemon::web
