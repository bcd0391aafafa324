#include "chromo/daemon/server.hpp"

#include <sys/stat.h>

#include <atomic>
#include <fstream>
#include <sstream>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>

#include "chromo/daemon/api_conversions.hpp"
#include "chromo/daemon/maps_service.hpp"
#include "chromo/drivers/device_error.hpp"
#include "chromosphere/v1/calibration.grpc.pb.h"
#include "chromosphere/v1/devices.grpc.pb.h"
#include "chromosphere/v1/estimation.grpc.pb.h"
#include "chromosphere/v1/events.grpc.pb.h"
#include "chromosphere/v1/leds.grpc.pb.h"
#include "chromosphere/v1/operations.grpc.pb.h"
#include "chromosphere/v1/sessions.grpc.pb.h"

namespace chromo::daemon {

// The plan and drive-level conversions (chromo/proto/plan_messages.hpp) join the daemon's own.
using proto::from_proto;
using proto::to_proto;

namespace pb = chromosphere::v1;
using grpc::ServerContext;
using grpc::Status;
using grpc::StatusCode;

namespace {

Status invalid(const std::string& message) { return {StatusCode::INVALID_ARGUMENT, message}; }

// Common guard of every handler: authentication on TCP, then the handler;
// exceptions become the right status code.
class Guard {
 public:
  Guard(const DaemonConfig& config, std::atomic<bool>& stopping) : config_(config), stopping_(stopping) {}

  template <typename Body>
  Status operator()(ServerContext* context, Body&& body) const {
    if (Status auth = authenticate(context); !auth.ok()) return auth;
    try {
      return body();
    } catch (const std::invalid_argument& error) {
      return invalid(error.what());
    } catch (const std::logic_error& error) {
      return {StatusCode::FAILED_PRECONDITION, error.what()};
    } catch (const drivers::DeviceError& error) {
      bool unanswered = error.kind() == drivers::DeviceError::Kind::kTimeout ||
                        error.kind() == drivers::DeviceError::Kind::kDisconnected;
      if (error.kind() == drivers::DeviceError::Kind::kInvalidRequest) return invalid(error.what());
      return {unanswered ? StatusCode::UNAVAILABLE : StatusCode::FAILED_PRECONDITION, error.what()};
    } catch (const std::exception& error) {
      return {StatusCode::INTERNAL, error.what()};
    }
  }
  bool stopping() const { return stopping_; }

 private:
  Status authenticate(ServerContext* context) const {
    const std::string peer = context->peer();
    if (peer.rfind("unix:", 0) == 0) return Status::OK;
    if (config_.token.empty()) return {StatusCode::UNAUTHENTICATED, "this daemon accepts no TCP calls"};
    const auto& metadata = context->client_metadata();
    auto found = metadata.find("authorization");
    if (found == metadata.end()) return {StatusCode::UNAUTHENTICATED, "authorization: missing bearer token"};
    const std::string value(found->second.data(), found->second.size());
    const std::string expected = "Bearer " + config_.token;
    // Constant-time comparison.
    unsigned char difference = value.size() == expected.size() ? 0 : 1;
    for (std::size_t i = 0; i < value.size() && i < expected.size(); ++i)
      difference |= static_cast<unsigned char>(value[i] ^ expected[i]);
    if (difference != 0) return {StatusCode::UNAUTHENTICATED, "authorization: wrong bearer token"};
    return Status::OK;
  }
  const DaemonConfig& config_;
  std::atomic<bool>& stopping_;
};

Status check_id(const std::string& field, const std::string& id) {
  if (id.empty()) return invalid(field + ": required");
  if (id.size() > 128) return invalid(field + ": longer than 128 bytes");
  if (!session::is_valid_name(id) && id.size() <= session::kMaxNameBytes) return invalid(field + ": not an id ([A-Za-z0-9_+.-])");
  for (char c : id)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '+' || c == '.' || c == '-'))
      return invalid(field + ": not an id ([A-Za-z0-9_+.-])");
  return Status::OK;
}

Status check_device_name(const std::string& field, const std::string& name) {
  if (name.size() > 128) return invalid(field + ": longer than 128 bytes");
  return Status::OK;
}

class DeviceServiceImpl final : public pb::DeviceService::Service {
 public:
  DeviceServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}
  Status ListDevices(ServerContext* context, const pb::ListDevicesRequest*, pb::ListDevicesResponse* response) override {
    return guard_(context, [&] {
      for (const auto& report : daemon_.probe_devices()) to_proto(report, response->add_devices());
      return Status::OK;
    });
  }

 private:
  Daemon& daemon_;
  Guard& guard_;
};

class LedServiceImpl final : public pb::LedService::Service {
 public:
  LedServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}
  Status GetLedState(ServerContext* context, const pb::GetLedStateRequest* request, pb::LedStatus* response) override {
    return guard_(context, [&] {
      if (Status s = check_device_name("controller", request->controller()); !s.ok()) return s;
      auto* led = find(request->controller());
      if (!led) return Status(StatusCode::NOT_FOUND, "controller: " + error_);
      std::lock_guard lock(led->mutex);
      if (!led->device) return Status(StatusCode::UNAVAILABLE, led->config.name + ": " + led->open_error);
      to_proto(led->config.name, led->device->read_status(), response);
      return Status::OK;
    });
  }
  Status SetLedState(ServerContext* context, const pb::SetLedStateRequest* request, pb::LedStatus* response) override {
    return guard_(context, [&] {
      if (Status s = check_device_name("controller", request->controller()); !s.ok()) return s;
      if (!request->has_state()) return invalid("state: required");
      drivers::LedState state;
      if (Status s = from_proto(request->state(), "state", &state); !s.ok()) return s;
      auto* led = find(request->controller());
      if (!led) return Status(StatusCode::NOT_FOUND, "controller: " + error_);
      daemon_.ensure_idle();
      std::lock_guard lock(led->mutex);
      if (!led->device) return Status(StatusCode::UNAVAILABLE, led->config.name + ": " + led->open_error);
      if (request->has_output_enabled()) led->device->set_output_enabled(request->output_enabled());
      led->device->set_state(state);
      to_proto(led->config.name, led->device->read_status(), response);
      return Status::OK;
    });
  }

 private:
  NamedDevice<drivers::LedController>* find(const std::string& name) { return daemon_.devices().led_controller(name, &error_); }
  Daemon& daemon_;
  Guard& guard_;
  thread_local static std::string error_;
};
thread_local std::string LedServiceImpl::error_;

class OperationServiceImpl final : public pb::OperationService::Service {
 public:
  OperationServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}
  Status GetOperation(ServerContext* context, const pb::GetOperationRequest* request, pb::Operation* response) override {
    return guard_(context, [&] {
      if (Status s = check_id("id", request->id()); !s.ok()) return s;
      auto record = daemon_.operations().get(request->id());
      if (!record) return Status(StatusCode::NOT_FOUND, "id: no operation \"" + request->id() + "\"");
      to_proto(*record, response);
      return Status::OK;
    });
  }
  Status ListOperations(ServerContext* context, const pb::ListOperationsRequest* request,
                        pb::ListOperationsResponse* response) override {
    return guard_(context, [&] {
      if (request->limit() > 10000) return invalid("limit: at most 10000");
      if (!pb::OperationKind_IsValid(request->kind())) return invalid("kind: unknown value");
      std::uint32_t count = 0;
      for (const auto& record : daemon_.operations().list()) {
        if (request->kind() == pb::OPERATION_KIND_SESSION && record.kind != session::OperationKind::kSession) continue;
        if (request->kind() == pb::OPERATION_KIND_CALIBRATION && record.kind != session::OperationKind::kCalibration) continue;
        if (request->limit() && count++ >= request->limit()) break;
        to_proto(record, response->add_operations());
      }
      return Status::OK;
    });
  }
  Status WatchOperation(ServerContext* context, const pb::WatchOperationRequest* request,
                        grpc::ServerWriter<pb::Operation>* writer) override {
    return guard_(context, [&] {
      if (Status s = check_id("id", request->id()); !s.ok()) return s;
      if (!daemon_.operations().get(request->id()))
        return Status(StatusCode::NOT_FOUND, "id: no operation \"" + request->id() + "\"");
      std::uint64_t seen = 0;
      while (!context->IsCancelled() && !guard_.stopping()) {
        auto change = daemon_.operations().wait_change(request->id(), seen, std::chrono::milliseconds(200));
        if (!change) return Status(StatusCode::NOT_FOUND, "id: operation vanished");
        if (change->second == seen) continue;
        seen = change->second;
        pb::Operation operation;
        to_proto(change->first, &operation);
        if (!writer->Write(operation)) break;
        if (session::is_final(change->first.state)) break;
      }
      return Status::OK;
    });
  }
  Status CancelOperation(ServerContext* context, const pb::CancelOperationRequest* request, pb::Operation* response) override {
    return control(context, request->id(), response, [](OperationControl& c) { c.request_cancel(); });
  }
  Status PauseOperation(ServerContext* context, const pb::PauseOperationRequest* request, pb::Operation* response) override {
    return control(context, request->id(), response, [](OperationControl& c) { c.request_pause(); });
  }
  Status ResumeOperation(ServerContext* context, const pb::ResumeOperationRequest* request, pb::Operation* response) override {
    return control(context, request->id(), response, [](OperationControl& c) { c.request_resume(); });
  }

 private:
  template <typename Action>
  Status control(ServerContext* context, const std::string& id, pb::Operation* response, Action action) {
    return guard_(context, [&] {
      if (Status s = check_id("id", id); !s.ok()) return s;
      auto record = daemon_.operations().get(id);
      if (!record) return Status(StatusCode::NOT_FOUND, "id: no operation \"" + id + "\"");
      auto control = daemon_.operations().control(id);
      if (!control || session::is_final(record->state))
        return Status(StatusCode::FAILED_PRECONDITION, "id: operation \"" + id + "\" has ended (" + session::state_name(record->state) + ")");
      action(*control);
      to_proto(*daemon_.operations().get(id), response);
      return Status::OK;
    });
  }
  Daemon& daemon_;
  Guard& guard_;
};

class SessionServiceImpl final : public pb::SessionService::Service {
 public:
  SessionServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}
  Status StartSession(ServerContext* context, const pb::StartSessionRequest* request, pb::Operation* response) override {
    return guard_(context, [&] {
      if (request->subject().size() > session::kMaxTextBytes) return invalid("subject: longer than 4096 bytes");
      if (!request->name().empty() && !session::is_valid_name(request->name()))
        return invalid("name: must match [A-Za-z0-9_+.-]{1,64}");
      session::SessionPlan plan;
      if (request->plan_source_case() == pb::StartSessionRequest::kPlan) {
        if (Status s = from_proto(request->plan(), "plan", &plan); !s.ok()) return s;
      } else if (request->plan_source_case() == pb::StartSessionRequest::kStandard && request->standard()) {
        session::StandardPlanOptions options;
        if (Status s = standard_options(request->timing(), request->exposure_us(), request->frames_per_camera(),
                                        request->operator_prompts(), &options);
            !s.ok())
          return s;
        plan = session::standard_plan(options);
      } else {
        return invalid("plan_source: set standard = true or give a plan");
      }
      if (!request->name().empty()) plan.name = request->name();
      to_proto(daemon_.start_session(std::move(plan), request->subject()), response);
      return Status::OK;
    });
  }
  Status GetStandardPlan(ServerContext* context, const pb::GetStandardPlanRequest* request, pb::SessionPlan* response) override {
    return guard_(context, [&] {
      session::StandardPlanOptions options;
      if (Status s = standard_options(request->timing(), request->exposure_us(), request->frames_per_camera(),
                                      request->operator_prompts(), &options);
          !s.ok())
        return s;
      to_proto(session::standard_plan(options), response);
      return Status::OK;
    });
  }
  Status ListSessions(ServerContext* context, const pb::ListSessionsRequest* request, pb::ListSessionsResponse* response) override {
    return guard_(context, [&] {
      if (request->limit() > 10000) return invalid("limit: at most 10000");
      std::uint32_t count = 0;
      for (const auto& record : daemon_.operations().list()) {
        if (record.kind != session::OperationKind::kSession) continue;
        if (request->limit() && count++ >= request->limit()) break;
        auto* summary = response->add_sessions();
        summary->set_id(record.id);
        summary->set_name(record.name);
        summary->set_folder(record.folder);
        to_proto(record, summary->mutable_operation());
      }
      return Status::OK;
    });
  }
  Status GetSession(ServerContext* context, const pb::GetSessionRequest* request, pb::SessionDetail* response) override {
    return guard_(context, [&] {
      if (Status s = check_id("id", request->id()); !s.ok()) return s;
      auto info = daemon_.session(request->id());
      if (!info) return Status(StatusCode::NOT_FOUND, "id: no session \"" + request->id() + "\"");
      to_proto(*info, request->include_frames(), response);
      return Status::OK;
    });
  }

 private:
  static Status standard_options(int timing, double exposure_us, std::uint32_t frames, bool prompts, session::StandardPlanOptions* options) {
    if (!pb::Timing_IsValid(timing)) return invalid("timing: unknown value " + std::to_string(timing));
    options->timing = timing == pb::TIMING_HARDWARE ? session::Timing::kHardware : session::Timing::kSoftware;
    if (exposure_us != 0) {
      if (!(exposure_us > 0 && exposure_us <= session::kMaxExposureUs)) return invalid("exposure_us: must be in (0, 10000000]");
      options->exposure_us = exposure_us;
    }
    if (frames != 0) {
      if (frames > session::kMaxFramesPerCamera) return invalid("frames_per_camera: must be in [1, 1000]");
      options->frames_per_camera = frames;
    }
    options->operator_prompts = prompts;
    return Status::OK;
  }
  Daemon& daemon_;
  Guard& guard_;
};

class CalibrationServiceImpl final : public pb::CalibrationService::Service {
 public:
  CalibrationServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}
  Status SolveMix(ServerContext* context, const pb::SolveMixRequest* request, pb::SolveMixResponse* response) override {
    return guard_(context, [&] {
      if (request->target().size() > 256) return invalid("target: longer than 256 bytes");
      if (!pb::MixObjective_IsValid(request->objective())) return invalid("objective: unknown value");
      std::string objective = "camera";
      if (request->objective() == pb::MIX_OBJECTIVE_SPECTRAL) objective = "spectral";
      if (request->objective() == pb::MIX_OBJECTIVE_XYZ) objective = "xyz";
      const bool w57 = request->target() == "w57";
      if (!w57 && (request->target().ends_with(".csv") || request->target().find('/') != std::string::npos))
        return invalid("target: files are not accepted over the API (d65, w57, w57+blue[:R], cct:K)");
      // The calibration library's mix solver on the daemon's LED library
      // (calibrations.hpp); FAILED_PRECONDITION when there is none yet.
      auto solved = daemon_.calibrations().solve(request->target(), objective, request->hold_chromaticity());
      to_proto(solved.weights, response->mutable_weights());
      for (const auto& [name, value] : solved.figures) (*response->mutable_figures())[name] = value;
      response->set_summary(solved.summary);
      response->set_library(solved.library);
      return Status::OK;
    });
  }
  Status StartCalibration(ServerContext* context, const pb::StartCalibrationRequest* request,
                          pb::Operation* response) override {
    return guard_(context, [&] {
      if (request->drive_levels_size() > 64) return invalid("drive_levels: at most 64 rungs");
      if (request->controller().size() > 64) return invalid("controller: longer than 64 bytes");
      if (request->spectrometer().size() > 64) return invalid("spectrometer: longer than 64 bytes");
      CalibrationRequest calibration;
      calibration.controller = request->controller();
      calibration.spectrometer = request->spectrometer();
      calibration.drive_levels.assign(request->drive_levels().begin(), request->drive_levels().end());
      calibration.warmup_ms = request->warmup_ms();
      // Field-naming std::invalid_argument → INVALID_ARGUMENT; another
      // operation running or no reference lamp → FAILED_PRECONDITION.
      to_proto(daemon_.start_calibration(calibration), response);
      return Status::OK;
    });
  }

 private:
  Daemon& daemon_;
  Guard& guard_;
};

class ResultsServiceImpl final : public pb::ResultsService::Service {
 public:
  ResultsServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}
  Status GetResults(ServerContext* context, const pb::GetResultsRequest* request, pb::Results* response) override {
    return guard_(context, [&] {
      if (Status s = check_id("session_id", request->session_id()); !s.ok()) return s;
      auto info = daemon_.session(request->session_id());
      if (!info) return Status(StatusCode::NOT_FOUND, "session_id: no session \"" + request->session_id() + "\"");
      results_to_proto(*info, response);
      return Status::OK;
    });
  }

 private:
  Daemon& daemon_;
  Guard& guard_;
};

class EventServiceImpl final : public pb::EventService::Service {
 public:
  EventServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}
  Status Subscribe(ServerContext* context, const pb::SubscribeRequest* request, grpc::ServerWriter<pb::Event>* writer) override {
    return guard_(context, [&] {
      auto subscription = daemon_.events().subscribe(request->include_frames());
      while (!context->IsCancelled() && !guard_.stopping()) {
        std::uint64_t dropped = 0;
        auto events = subscription->next(std::chrono::milliseconds(200), &dropped);
        if (dropped) {
          pb::Event event;
          event.set_log(std::to_string(dropped) + " events dropped: the client read too slowly");
          if (!writer->Write(event)) break;
        }
        for (const auto& event : events) {
          pb::Event message;
          to_proto(event, &message);
          if (!writer->Write(message)) return Status::OK;
        }
      }
      return Status::OK;
    });
  }

 private:
  Daemon& daemon_;
  Guard& guard_;
};

std::string read_text_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

}  // namespace

struct Server::Services {
  std::atomic<bool> stopping{false};
  Guard guard;
  DeviceServiceImpl devices;
  LedServiceImpl leds;
  OperationServiceImpl operations;
  SessionServiceImpl sessions;
  CalibrationServiceImpl calibration;
  ResultsServiceImpl results;
  EventServiceImpl events;
  std::unique_ptr<grpc::Service> maps;  // maps_service.cpp
  Services(Daemon& daemon)
      : guard(daemon.config(), stopping),
        devices(daemon, guard),
        leds(daemon, guard),
        operations(daemon, guard),
        sessions(daemon, guard),
        calibration(daemon, guard),
        results(daemon, guard),
        events(daemon, guard),
        maps(make_maps_service(daemon, [this](ServerContext* c, const std::function<Status()>& body) { return guard(c, body); })) {}
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
  for (grpc::Service* service : std::initializer_list<grpc::Service*>{
           &services_->devices, &services_->leds, &services_->operations, &services_->sessions,
           &services_->calibration, &services_->results, &services_->events, services_->maps.get()})
    builder.RegisterService(service);
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
