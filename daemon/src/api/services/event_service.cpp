// EventService: the event stream: operations, logs, frames (events.proto).
#include <string>

#include "chromosphere/v1/events.grpc.pb.h"
#include "services.hpp"

namespace chromo::daemon::services {
namespace {

class EventServiceImpl final : public pb::EventService::Service {
 public:
  EventServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}
  Status Subscribe(ServerContext* context, const pb::SubscribeRequest* request, grpc::ServerWriter<pb::Event>* writer) override {
    return guard_.stream(context, [&] {
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

}  // namespace

std::unique_ptr<grpc::Service> make_event_service(Daemon& daemon, Guard& guard) {
  return std::make_unique<EventServiceImpl>(daemon, guard);
}

}  // namespace chromo::daemon::services
