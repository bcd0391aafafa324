// LedService: LED controller state: read it, set it while nothing runs (leds.proto).
#include <string>

#include "chromosphere/v1/leds.grpc.pb.h"
#include "services.hpp"

namespace chromo::daemon::services {
namespace {

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
    return guard_.audited(context, "set_led_state", [&](nlohmann::json& details) {
      details["controller"] = request->controller();
      if (Status s = check_device_name("controller", request->controller()); !s.ok()) return s;
      if (!request->has_state()) return invalid("state: required");
      drivers::LedState state;
      if (Status s = from_proto(request->state(), "state", &state); !s.ok()) return s;
      auto* led = find(request->controller());
      if (!led) return Status(StatusCode::NOT_FOUND, "controller: " + error_);
      if (daemon_.operations().any_active())
        return Status(StatusCode::FAILED_PRECONDITION,
                      "a session or calibration is running: its plan drives the LEDs; set them once it has ended (or cancel it)");
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

}  // namespace

std::unique_ptr<grpc::Service> make_led_service(Daemon& daemon, Guard& guard) {
  return std::make_unique<LedServiceImpl>(daemon, guard);
}

}  // namespace chromo::daemon::services
