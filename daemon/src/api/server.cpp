#include "chromo/daemon/server.hpp"
#include "chromo/files/bounded_read.hpp"

#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <sstream>
#include <vector>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpc/grpc_security_constants.h>
#include <grpcpp/resource_quota.h>
#include <grpcpp/security/auth_metadata_processor.h>

#include "services/services.hpp"
#include "tcp_gate.hpp"
#include "unix_listener.hpp"

namespace chromo::daemon {

namespace {

std::string read_text_file(const std::string& path) {
  return files::read_bounded(path, files::kMaxTextFileBytes, "PEM");
}

// A socket file at `path` that nobody accepts on is removed (a killed
// chromod's); anything else there is an error, and left as it is.
void remove_stale_socket(const std::string& path) {
  std::error_code error;
  const auto status = std::filesystem::symlink_status(path, error);
  if (error || !std::filesystem::exists(status)) return;
  if (!std::filesystem::is_socket(status))
    throw std::invalid_argument("unix_socket: " + path + ": a file that is not a socket is there (chromod never "
                                "deletes a file it did not create)");
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error("unix_socket: cannot make a socket to probe " + path);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  path.copy(address.sun_path, sizeof address.sun_path - 1);
  const bool listening = ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
  ::close(fd);
  if (listening) throw std::invalid_argument("unix_socket: " + path + ": another process is listening on it");
  std::filesystem::remove(path, error);
}

// Descriptors chromod keeps for everything but relayed TCP connections
// (devices, session files, the web view, the Unix socket's clients).
constexpr std::uint64_t kDescriptorsBesideTcp = 256;

// The TCP gate's cap must fit the descriptor limit (tcp_gate.hpp: three
// descriptors a connection), else gRPC could meet EMFILE after all.
void check_descriptor_limit(std::uint32_t max_tcp_connections) {
  rlimit limit{};
  if (::getrlimit(RLIMIT_NOFILE, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return;
  const std::uint64_t needed = 3ull * max_tcp_connections + kDescriptorsBesideTcp;
  if (needed > limit.rlim_cur)
    throw std::runtime_error("max_tcp_connections: " + std::to_string(max_tcp_connections) + " connections need " +
                             std::to_string(needed) + " open files (3 each + " + std::to_string(kDescriptorsBesideTcp) +
                             "), more than this process's limit of " + std::to_string(limit.rlim_cur) +
                             " (ulimit -n): lower max_tcp_connections or raise the limit");
}

// Threads for unary calls beside max_streams running streams.
constexpr int kUnaryThreads = 32;

// The TCP credentials' metadata processor: the bearer token is checked when a
// call's metadata arrives, before gRPC reads its message or picks a handler.
class TokenProcessor final : public grpc::AuthMetadataProcessor {
 public:
  explicit TokenProcessor(const DaemonConfig& config) : config_(config) {}
  bool IsBlocking() const override { return false; }  // a comparison: runs inline
  grpc::Status Process(const InputMetadata& metadata, grpc::AuthContext*, OutputMetadata*, OutputMetadata*) override {
    return services::check_bearer(config_, metadata);
  }

 private:
  const DaemonConfig& config_;
};

}  // namespace

// One of each service (services/services.hpp), all behind one guard.
struct Server::Services {
  std::atomic<bool> stopping{false};
  services::Peers peers;
  services::AuditLog audit;
  services::Guard guard;
  std::vector<std::unique_ptr<grpc::Service>> all;
  std::unique_ptr<UnixListener> unix_listener;
  std::unique_ptr<TcpGate> tcp_gate;
  explicit Services(Daemon& daemon)
      : audit(daemon.config().sessions_dir / "audit.jsonl"), guard(daemon.config(), stopping, peers, audit) {
    peers.set_token_id(services::token_id(daemon.config().token));
    for (auto make : {services::make_device_service, services::make_led_service, services::make_operation_service,
                      services::make_session_service, services::make_calibration_service, services::make_results_service,
                      services::make_event_service, services::make_maps_service, services::make_plan_service,
                      services::make_camera_service})
      all.push_back(make(daemon, guard));
  }
};

Server::Server(Daemon& daemon) : daemon_(daemon), services_(std::make_unique<Services>(daemon)) {
  const auto& config = daemon.config();
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  builder.SetMaxReceiveMessageSize(1 << 20);
  // A TCP peer that never finishes its handshake is closed (issue 40: held
  // connections that never sent anything used up the descriptors).
  builder.AddChannelArgument(GRPC_ARG_SERVER_HANDSHAKE_TIMEOUT_MS, static_cast<int>(config.tcp_handshake_timeout_ms));
  // One that handshook and then holds the connection without a call (or
  // with calls refused for want of the token) is closed once idle.
  builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_IDLE_MS, static_cast<int>(config.tcp_idle_timeout_ms));
  // A thread per running call (the synchronous API): the streams' slots, room
  // for unary calls beside them, the pollers. Beyond it gRPC itself answers
  // RESOURCE_EXHAUSTED; streams beyond max_streams are refused by the Guard
  // first (measured in docs/daemon.md, "Limits").
  grpc::ResourceQuota quota("chromod");
  quota.SetMaxThreads(static_cast<int>(config.max_streams) + kUnaryThreads + 4);
  builder.SetResourceQuota(quota);
  if (!config.unix_socket.empty()) {
    // Only a socket nobody listens on (left by a killed chromod) is removed;
    // any other file there is refused, never deleted.
    remove_stale_socket(config.unix_socket);
    // Accepted by chromod itself, for each peer's uid (unix_listener.hpp).
    services_->unix_listener = std::make_unique<UnixListener>(config.unix_socket);
  }
  if (!config.tcp_address.empty()) {
    // TLS, or plaintext only with "tcp_insecure": true, where gRPC's local
    // credentials accept loopback peers only. Both carry the token processor.
    std::shared_ptr<grpc::ServerCredentials> credentials;
    if (!config.tls_certificate_file.empty()) {
      grpc::SslServerCredentialsOptions options;
      options.pem_key_cert_pairs.push_back(
          {read_text_file(config.tls_private_key_file), read_text_file(config.tls_certificate_file)});
      credentials = grpc::SslServerCredentials(options);
    } else if (config.tcp_insecure) {
      credentials = grpc::experimental::LocalServerCredentials(LOCAL_TCP);
    } else {
      throw std::runtime_error("tcp_insecure: TCP without TLS needs \"tcp_insecure\": true");
    }
    credentials->SetAuthMetadataProcessor(std::make_shared<TokenProcessor>(config));
    // chromod accepts on the configured address itself, under a cap, and
    // relays to gRPC's own port on loopback (tcp_gate.hpp).
    check_descriptor_limit(config.max_tcp_connections);
    services_->tcp_gate = std::make_unique<TcpGate>(
        TcpGateOptions{config.tcp_address, config.max_tcp_connections, config.tcp_insecure});
    builder.AddListeningPort("127.0.0.1:0", credentials, &grpc_tcp_port_);
  }
  for (const auto& service : services_->all) builder.RegisterService(service.get());
  server_ = builder.BuildAndStart();
  if (!server_) throw std::runtime_error("could not listen on the configured addresses (unix:" + config.unix_socket + " " +
                                         config.tcp_address + ")");
  if (services_->tcp_gate) {
    if (grpc_tcp_port_ == 0) throw std::runtime_error("could not listen on 127.0.0.1 for the TCP gate's connections");
    tcp_port_ = services_->tcp_gate->port();
    services_->tcp_gate->start(grpc_tcp_port_);
  }
  if (!config.unix_socket.empty()) {
    ::chmod(config.unix_socket.c_str(), config.unix_socket_mode);
    created_socket_ = config.unix_socket;
    services_->unix_listener->start(*server_, [this](int fd, unsigned uid) { services_->peers.accepted(fd, uid); });
  }
  server_->GetHealthCheckService()->SetServingStatus(true);
}

Server::~Server() { shutdown(); }

Server::TcpCounters Server::tcp_counters() const {
  if (!services_->tcp_gate) return {};
  const TcpGateCounters c = services_->tcp_gate->counters();
  return {c.accepted, c.refused_over_cap, c.refused_not_loopback, c.accept_failures, c.open};
}

void Server::shutdown() {
  if (!server_) return;
  services_->stopping = true;
  if (services_->unix_listener) services_->unix_listener->stop();
  if (services_->tcp_gate) services_->tcp_gate->stop();
  server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
  server_->Wait();
  server_.reset();
  // The socket this server made (still a socket: nobody replaced it).
  std::error_code error;
  if (!created_socket_.empty() && std::filesystem::is_socket(std::filesystem::symlink_status(created_socket_, error)))
    std::filesystem::remove(created_socket_, error);
  created_socket_.clear();
}

std::shared_ptr<grpc::Channel> Server::in_process_channel() {
  if (!server_) throw std::logic_error("the gRPC server has stopped");
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(64 << 20);  // map data for the web view's results page
  return server_->InProcessChannel(arguments);
}

void Server::audit(const std::string& who, const std::string& action, const std::string& error) {
  const grpc::Status outcome = error.empty() ? grpc::Status::OK : grpc::Status(grpc::StatusCode::UNAUTHENTICATED, error);
  services_->audit.record(who, action, outcome, nlohmann::json::object());
}

void Server::wait() {
  if (server_) server_->Wait();
}

}  // namespace chromo::daemon
