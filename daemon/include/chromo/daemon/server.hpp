#pragma once
// The gRPC server of chromod: the services of proto/chromosphere/v1 over a
// Daemon, plus the standard health service and server reflection.
//
// Listening: the Unix socket (config.unix_socket, accepted by chromod itself
// for each peer's uid: unix_listener.hpp; its file mode is set to
// config.unix_socket_mode so that file permissions decide who may connect;
// a file already at that path is refused unless it is a socket nobody
// listens on, which is replaced; the socket is removed at shutdown)
// and, when config.tcp_address is set, TCP with TLS, or plaintext from
// loopback peers with config.tcp_insecure, accepted by chromod itself under
// config.max_tcp_connections and relayed to gRPC's own loopback port
// (tcp_gate.hpp). Every call over TCP must carry
// "authorization: Bearer <config.token>": an auth metadata processor on the
// credentials checks it before the message is parsed (UNAUTHENTICATED), and
// the services' Guard again. Streaming calls are capped at config.max_streams.
//
// Lifetime: the Server must not outlive the Daemon. shutdown() ends streams
// (Watch/Subscribe notice within 200 ms) and waits for the handlers.

#include <memory>
#include <string>

#include "chromo/daemon/daemon.hpp"

namespace grpc {
class Channel;
class Server;
}

namespace chromo::daemon {

class Server {
 public:
  // Throws std::runtime_error when a port cannot be opened or TLS files read.
  explicit Server(Daemon& daemon);
  ~Server();
  void shutdown();
  void wait();
  // The TCP port actually bound (useful with tcp_address "127.0.0.1:0"); 0 without TCP.
  int tcp_port() const { return tcp_port_; }
  // The TCP gate's counters (all 0 without TCP).
  struct TcpCounters {
    std::uint64_t accepted = 0, refused_over_cap = 0, refused_not_loopback = 0, accept_failures = 0, open = 0;
  };
  TcpCounters tcp_counters() const;
  // A channel to this server inside the process (the web view's bridge to the
  // API); calls over it are TCP-like peers: they need the bearer token.
  std::shared_ptr<grpc::Channel> in_process_channel();
  // One line in the audit log (<sessions_dir>/audit.jsonl); error empty = ok.
  void audit(const std::string& who, const std::string& action, const std::string& error);

  struct Services;

 private:
  Daemon& daemon_;
  std::unique_ptr<Services> services_;
  std::unique_ptr<grpc::Server> server_;
  int tcp_port_ = 0;       // the TCP gate's (the configured address)
  int grpc_tcp_port_ = 0;  // gRPC's own, on 127.0.0.1, where the gate relays to
  std::string created_socket_;  // removed again at shutdown
};

}  // namespace chromo::daemon
