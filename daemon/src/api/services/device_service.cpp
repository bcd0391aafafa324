// DeviceService: the device list with each device's health (devices.proto).
#include <string>

#include "chromosphere/v1/devices.grpc.pb.h"
#include "services.hpp"

namespace chromo::daemon::services {
namespace {

class DeviceServiceImpl final : public pb::DeviceService::Service {
 public:
  DeviceServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}
  Status ListDevices(ServerContext* context, const pb::ListDevicesRequest*, pb::ListDevicesResponse* response) override {
    return guard_(context, [&] {
      for (const auto& report : daemon_.probe_devices()) to_proto(report, response->add_devices());
      return Status::OK;
    });
  }
  Status CheckLab(ServerContext* context, const pb::CheckLabRequest*, pb::CheckLabResponse* response) override {
    return guard_(context, [&] {
      for (const auto& result : daemon_.check_lab()) {
        auto* check = response->add_checks();
        check->set_id(result.id);
        check->set_status(check_status_message(result.status));
        check->set_finding(result.finding);
        check->set_fix(result.fix);
      }
      return Status::OK;
    });
  }

 private:
  static pb::CheckStatus check_status_message(CheckStatus status) {
    switch (status) {
      case CheckStatus::ok: return pb::CHECK_STATUS_OK;
      case CheckStatus::warning: return pb::CHECK_STATUS_WARNING;
      case CheckStatus::failed: return pb::CHECK_STATUS_FAILED;
      case CheckStatus::skipped: return pb::CHECK_STATUS_SKIPPED;
    }
    return pb::CHECK_STATUS_UNSPECIFIED;
  }

  Daemon& daemon_;
  Guard& guard_;
};

}  // namespace

std::unique_ptr<grpc::Service> make_device_service(Daemon& daemon, Guard& guard) {
  return std::make_unique<DeviceServiceImpl>(daemon, guard);
}

}  // namespace chromo::daemon::services
