// ResultsService: a session's estimation results (estimation.proto).
#include <string>

#include "chromosphere/v1/estimation.grpc.pb.h"
#include "services.hpp"

namespace chromo::daemon::services {
namespace {

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

}  // namespace

std::unique_ptr<grpc::Service> make_results_service(Daemon& daemon, Guard& guard) {
  return std::make_unique<ResultsServiceImpl>(daemon, guard);
}

}  // namespace chromo::daemon::services
