#include "chromo/daemon/server.hpp"
#include "chromo/files/bounded_read.hpp"

#include <sys/stat.h>

#include <atomic>
#include <fstream>
#include <sstream>
#include <vector>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>

#include "services/services.hpp"

namespace chromo::daemon {

namespace {

std::string read_text_file(const std::string& path) {
  return files::read_bounded(path, files::kMaxTextFileBytes, "PEM");
}

}  // namespace

// One of each service (services/services.hpp), all behind one guard.
struct Server::Services {
  std::atomic<bool> stopping{false};
  services::Guard guard;
  std::vector<std::unique_ptr<grpc::Service>> all;
  explicit Services(Daemon& daemon) : guard(daemon.config(), stopping) {
    for (auto make : {services::make_device_service, services::make_led_service, services::make_operation_service,
                      services::make_session_service, services::make_calibration_service, services::make_results_service,
                      services::make_event_service, services::make_maps_service})
      all.push_back(make(daemon, guard));
  }
};

Server::Server(Daemon& daemon) : daemon_(daemon), services_(std::make_unique<Services>(daemon)) {
  const auto& config = daemon.config();
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  builder.SetMaxReceiveMessageSize(1 << 20);
  if (!config.unix_socket.empty()) {
    std::filesystem::remove(config.unix_socket);
    builder.AddListeningPort("unix:" + config.unix_socket, grpc::InsecureServerCredentials());
  }
  if (!config.tcp_address.empty()) {
    std::shared_ptr<grpc::ServerCredentials> credentials = grpc::InsecureServerCredentials();
    if (!config.tls_certificate_file.empty()) {
      grpc::SslServerCredentialsOptions options;
      options.pem_key_cert_pairs.push_back(
          {read_text_file(config.tls_private_key_file), read_text_file(config.tls_certificate_file)});
      credentials = grpc::SslServerCredentials(options);
    }
    builder.AddListeningPort(config.tcp_address, credentials, &tcp_port_);
  }
  for (const auto& service : services_->all) builder.RegisterService(service.get());
  server_ = builder.BuildAndStart();
  if (!server_) throw std::runtime_error("could not listen on the configured addresses (unix:" + config.unix_socket + " " +
                                         config.tcp_address + ")");
  if (!config.tcp_address.empty() && tcp_port_ == 0) throw std::runtime_error("could not listen on " + config.tcp_address);
  if (!config.unix_socket.empty()) ::chmod(config.unix_socket.c_str(), config.unix_socket_mode);
  server_->GetHealthCheckService()->SetServingStatus(true);
}

Server::~Server() { shutdown(); }

void Server::shutdown() {
  if (!server_) return;
  services_->stopping = true;
  server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
  server_->Wait();
  server_.reset();
}

void Server::wait() {
  if (server_) server_->Wait();
}

}  // namespace chromo::daemon
