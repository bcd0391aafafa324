#include "daemon_client.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>

#include <fmt/format.h>

#include "chromo/files/runtime_dir.hpp"
#include "chromo/files/bounded_read.hpp"
#include "commands.hpp"

namespace chromo::cli {

void add_daemon_options(CLI::App& command, DaemonAddress& address) {
  const char* env_target = std::getenv("CHROMO_DAEMON");
  const char* env_token = std::getenv("CHROMO_TOKEN");
  // chromod's default socket (files/runtime_dir.hpp: the same rule as the daemon's).
  address.target = env_target ? env_target : "unix:" + files::default_unix_socket().string();
  address.token = env_token ? env_token : "";
  command.add_option("--daemon", address.target, "chromod address: unix:PATH or HOST:PORT ($CHROMO_DAEMON)");
  command.add_option("--token", address.token, "bearer token for TCP ($CHROMO_TOKEN)");
  command.add_option("--tls-ca", address.tls_ca_file, "PEM of the CA that signed the daemon's certificate (TLS)");
}

DaemonConnection::DaemonConnection(const DaemonAddress& address) : token_(address.token) {
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (!address.tls_ca_file.empty()) {
    grpc::SslCredentialsOptions options;
    try {
      options.pem_root_certs = files::read_bounded(address.tls_ca_file, files::kMaxTextFileBytes, "PEM");
    } catch (const files::InputFileError& e) {
      throw std::invalid_argument(std::string("--tls-ca: ") + e.what());
    }
    credentials = grpc::SslCredentials(options);
  }
  channel_ = grpc::CreateChannel(address.target, credentials);
}

std::unique_ptr<grpc::ClientContext> DaemonConnection::context(bool streaming) const {
  auto context = std::make_unique<grpc::ClientContext>();
  if (!token_.empty()) context->AddMetadata("authorization", "Bearer " + token_);
  if (!streaming) context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  return context;
}

int report_failure(const std::string& what, const grpc::Status& status) {
  std::cerr << "chromo: " << what << ": " << status.error_message();
  if (status.error_code() == grpc::StatusCode::UNAVAILABLE) std::cerr << " (is chromod running? see --daemon)";
  std::cerr << "\n";
  switch (status.error_code()) {
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::NOT_FOUND:
    case grpc::StatusCode::FAILED_PRECONDITION:
    case grpc::StatusCode::UNAUTHENTICATED:
      return kExitBadInput;
    default:
      return kExitFailure;
  }
}

std::string state_text(chromosphere::v1::OperationState state) {
  std::string name = chromosphere::v1::OperationState_Name(state);
  name = name.substr(std::string("OPERATION_STATE_").size());
  for (auto& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

std::string progress_line(const chromosphere::v1::Operation& operation) {
  constexpr int kWidth = 24;
  // Every frame stored, still running: the maps are being made; the message
  // carries the estimator's own step and share, and the capture's eta is over.
  if (operation.state() == chromosphere::v1::OPERATION_STATE_RUNNING && operation.progress() >= 1 &&
      operation.counters().expected() > 0 && operation.counters().stored() >= operation.counters().expected())
    return fmt::format("[{}] capture done, {} frames stored; making the maps: {}", std::string(kWidth, '#'),
                       operation.counters().stored(), operation.message().empty() ? "starting" : operation.message());
  const int filled = static_cast<int>(std::lround(std::clamp(operation.progress(), 0.0, 1.0) * kWidth));
  const auto& counters = operation.counters();
  std::string eta = operation.eta_seconds() < 0 ? "  ?" : fmt::format("{:3.0f}", operation.eta_seconds());
  return fmt::format("[{}{}] {:3.0f}%  eta {} s  stored {}/{}  lost {}  {:<9} {}", std::string(filled, '#'),
                     std::string(kWidth - filled, '.'), operation.progress() * 100, eta, counters.stored(),
                     counters.expected(), counters.lost(), state_text(operation.state()), operation.message());
}

}  // namespace chromo::cli
