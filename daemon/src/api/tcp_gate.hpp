#pragma once
// The TCP port, accepted by chromod itself under a cap (issue 40, row 3).
//
// Debian's gRPC 1.51 cannot cap its incoming connections, and after one
// accept4() that fails with EMFILE it stops accepting on that port for good.
// Its from-descriptor API takes insecure credentials only, so a TLS
// connection cannot be handed to it as UnixListener hands it a Unix one.
// TcpGate therefore listens on the configured address itself, holds at most
// `max_connections` connections at once and relays each one's bytes, unread,
// to the gRPC server's own port on 127.0.0.1: TLS stays end to end and gRPC
// checks the token as before. Beyond the cap a connection is closed as soon
// as it is accepted; an accept that fails for want of descriptors pauses the
// gate for 100 ms and leaves its listening socket as it is, so the port
// accepts again once the connections that used them up are gone.
//
// Each relayed connection holds three descriptors: the client's and the
// gate's to gRPC in chromod, and gRPC's accepted end.
//
// Thread rules: one relaying thread between start() and stop(); counters()
// from any thread.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>
#include <thread>

namespace chromo::daemon {

struct TcpGateOptions {
  std::string address;              // "host:port" as config.tcp_address (port 0: any free port)
  std::size_t max_connections = 128;  // relayed at once; more are closed when accepted
  bool loopback_peers_only = false;   // tcp_insecure: only 127.0.0.0/8 and ::1 are relayed
};

struct TcpGateCounters {
  std::uint64_t accepted = 0;               // relayed, since start
  std::uint64_t refused_over_cap = 0;       // closed at once: max_connections were open
  std::uint64_t refused_not_loopback = 0;   // closed at once: loopback_peers_only
  std::uint64_t accept_failures = 0;        // accept4 failed for want of descriptors (EMFILE, ENFILE, ENOBUFS, ENOMEM)
  std::uint64_t open = 0;                   // relayed now
};

class TcpGate {
 public:
  // Binds options.address and listens; throws std::runtime_error naming the
  // address and the reason.
  explicit TcpGate(TcpGateOptions options);
  ~TcpGate();
  TcpGate(const TcpGate&) = delete;
  TcpGate& operator=(const TcpGate&) = delete;

  // The port bound (the configured one, or the one picked for port 0).
  int port() const { return port_; }
  // Relays every accepted connection to 127.0.0.1:backend_port from the gate's thread.
  void start(int backend_port);
  // Stops accepting and closes every relayed connection; idempotent.
  void stop();
  TcpGateCounters counters() const;

 private:
  class Loop;
  void run();
  TcpGateOptions options_;
  int listen_fd_ = -1;
  int wake_fd_ = -1;
  int port_ = 0;
  int backend_port_ = 0;
  std::thread thread_;
  std::atomic<std::uint64_t> accepted_{0}, refused_over_cap_{0}, refused_not_loopback_{0}, accept_failures_{0}, open_{0};
};

}  // namespace chromo::daemon
