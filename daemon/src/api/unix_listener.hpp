#pragma once
// The Unix socket, accepted by chromod itself so that each connection's peer
// credentials are known: gRPC (1.51) tells a handler nothing about a Unix
// peer but the socket path. UnixListener binds and listens, takes
// SO_PEERCRED of every accepted connection, reports (fd, uid) and hands the
// connection to the gRPC server (grpc::AddInsecureChannelFromFd), whose peer
// string for it is then "fd:<fd>" (services.hpp, Peers).
//
// Thread rules: one accepting thread between start() and stop(); stop()
// before the gRPC server shuts down.

#include <functional>
#include <string>
#include <thread>

namespace grpc {
class Server;
}

namespace chromo::daemon {

class UnixListener {
 public:
  // Binds `path` (which must not exist) and listens; throws
  // std::runtime_error naming the path and the reason.
  explicit UnixListener(const std::string& path);
  ~UnixListener();
  UnixListener(const UnixListener&) = delete;
  UnixListener& operator=(const UnixListener&) = delete;

  void start(grpc::Server& server, std::function<void(int fd, unsigned uid)> on_accept);
  void stop();

 private:
  void run();
  std::string path_;
  int listen_fd_ = -1;
  int wake_fd_ = -1;
  grpc::Server* server_ = nullptr;
  std::function<void(int, unsigned)> on_accept_;
  std::thread thread_;
};

}  // namespace chromo::daemon
