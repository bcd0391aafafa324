#pragma once
// Shared by the operator commands that talk to chromod over the socket API.
//
// Where: --daemon ADDRESS (or $CHROMO_DAEMON), default unix:<runtime dir>/chromod.sock (files/runtime_dir.hpp);
// a TCP address needs --token (or $CHROMO_TOKEN), sent as a bearer token, and
// uses TLS when --tls-ca PEM is given.

#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <grpcpp/grpcpp.h>

#include "chromosphere/v1/operations.pb.h"

namespace chromo::cli {

struct DaemonAddress {
  std::string target;
  std::string token;
  std::string tls_ca_file;
};

// Adds --daemon, --token, --tls-ca to a subcommand.
void add_daemon_options(CLI::App& command, DaemonAddress& address);

class DaemonConnection {
 public:
  explicit DaemonConnection(const DaemonAddress& address);
  std::shared_ptr<grpc::Channel> channel() const { return channel_; }
  // A context carrying the token, with a deadline unless streaming.
  std::unique_ptr<grpc::ClientContext> context(bool streaming = false) const;

 private:
  std::shared_ptr<grpc::Channel> channel_;
  std::string token_;
};

// Prints "chromo: <what>: <status message>" and returns the exit status:
// 2 for a request the daemon refused as invalid or unknown, 1 otherwise.
int report_failure(const std::string& what, const grpc::Status& status);

std::string state_text(chromosphere::v1::OperationState state);
// "[#########.........]  45%  eta 12 s  stored 31/70  lost 0  step white_w57"
std::string progress_line(const chromosphere::v1::Operation& operation);
// Streams an operation (session or calibration) to its end with a live
// progress line, then its outcome. Exit status 0 only on success.
int watch_operation(const DaemonConnection& daemon, const std::string& id);

}  // namespace chromo::cli
