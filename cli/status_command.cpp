// chromo status: the daemon's devices and its operations in flight.
#include <iostream>

#include <fmt/format.h>

#include "chromosphere/v1/devices.grpc.pb.h"
#include "chromosphere/v1/operations.grpc.pb.h"
#include "commands.hpp"
#include "daemon_client.hpp"

namespace chromo::cli {

namespace pb = chromosphere::v1;

void add_status_command(CLI::App& app, int& exit_status) {
  auto* command = app.add_subcommand("status", "chromod's devices (probed now) and running operations");
  auto address = std::make_shared<DaemonAddress>();
  add_daemon_options(*command, *address);
  command->callback([&exit_status, address] {
    DaemonConnection daemon(*address);
    pb::ListDevicesResponse devices;
    auto status = pb::DeviceService::NewStub(daemon.channel())->ListDevices(daemon.context().get(), {}, &devices);
    if (!status.ok()) {
      exit_status = report_failure("status", status);
      return;
    }
    for (const auto& device : devices.devices()) {
      std::string health = pb::DeviceHealth_Name(device.health()).substr(std::string("DEVICE_HEALTH_").size());
      std::cout << fmt::format("{:<12} {:<15} {:<10} {:<20} {}", device.name(),
                               pb::DeviceKind_Name(device.kind()).substr(std::string("DEVICE_KIND_").size()),
                               device.backend(), device.address(), health);
      if (!device.detail().empty()) std::cout << "  " << device.detail();
      std::cout << "\n";
    }
    pb::ListOperationsResponse operations;
    status = pb::OperationService::NewStub(daemon.channel())->ListOperations(daemon.context().get(), {}, &operations);
    if (!status.ok()) {
      exit_status = report_failure("status", status);
      return;
    }
    int active = 0;
    for (const auto& operation : operations.operations()) {
      if (operation.state() != pb::OPERATION_STATE_RUNNING && operation.state() != pb::OPERATION_STATE_PAUSED &&
          operation.state() != pb::OPERATION_STATE_PENDING)
        continue;
      ++active;
      std::cout << operation.id() << "  " << progress_line(operation) << "\n";
    }
    if (active == 0) std::cout << "no operation running\n";
  });
}

}  // namespace chromo::cli
