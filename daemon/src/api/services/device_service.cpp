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

 private:
  Daemon& daemon_;
  Guard& guard_;
};

}  // namespace

std::unique_ptr<grpc::Service> make_device_service(Daemon& daemon, Guard& guard) {
  return std::make_unique<DeviceServiceImpl>(daemon, guard);
}

}  // namespace chromo::daemon::services
