// OperationService: operations: get, list, watch, cancel, pause, resume (operations.proto).
#include <string>

#include "chromosphere/v1/operations.grpc.pb.h"
#include "services.hpp"

namespace chromo::daemon::services {
namespace {

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
    return guard_.stream(context, [&] {
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
    return control(context, "cancel", request->id(), response, [](OperationControl& c) { c.request_cancel(); });
  }
  Status PauseOperation(ServerContext* context, const pb::PauseOperationRequest* request, pb::Operation* response) override {
    return control(context, "pause", request->id(), response, [](OperationControl& c) { c.request_pause(); });
  }
  Status ResumeOperation(ServerContext* context, const pb::ResumeOperationRequest* request, pb::Operation* response) override {
    return control(context, "resume", request->id(), response, [](OperationControl& c) { c.request_resume(); });
  }

 private:
  template <typename Action>
  Status control(ServerContext* context, const char* verb, const std::string& id, pb::Operation* response, Action action) {
    return guard_.audited(context, verb, [&](nlohmann::json& details) {
      if (Status s = check_id("id", id); !s.ok()) return s;
      details["operation"] = id;
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

}  // namespace

std::unique_ptr<grpc::Service> make_operation_service(Daemon& daemon, Guard& guard) {
  return std::make_unique<OperationServiceImpl>(daemon, guard);
}

}  // namespace chromo::daemon::services
