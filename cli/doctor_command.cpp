// chromo doctor: chromod's checks of this lab PC against its configuration
// (DeviceService.CheckLab, docs/doctor.md), one line each with its fix.
#include <iostream>

#include <fmt/format.h>

#include "chromosphere/v1/devices.grpc.pb.h"
#include "commands.hpp"
#include "daemon_client.hpp"

namespace chromo::cli {

namespace pb = chromosphere::v1;

namespace {

std::string status_word(pb::CheckStatus status) {
  switch (status) {
    case pb::CHECK_STATUS_OK: return "ok";
    case pb::CHECK_STATUS_WARNING: return "WARNING";
    case pb::CHECK_STATUS_FAILED: return "FAILED";
    case pb::CHECK_STATUS_SKIPPED: return "skipped";
    default: return "?";
  }
}

}  // namespace

void add_doctor_command(CLI::App& app, int& exit_status) {
  auto* command = app.add_subcommand(
      "doctor", "check this lab PC against chromod's configuration: devices, permissions, receive buffer, MTU, "
                "disk, clock, calibration; one line each with its fix (exit 3 when a check failed)");
  auto address = std::make_shared<DaemonAddress>();
  add_daemon_options(*command, *address);
  auto strict = std::make_shared<bool>(false);
  command->add_flag("--strict", *strict, "exit 3 on warnings too");
  command->callback([&exit_status, address, strict] {
    DaemonConnection daemon(*address);
    pb::CheckLabResponse response;
    auto status = pb::DeviceService::NewStub(daemon.channel())->CheckLab(daemon.context().get(), {}, &response);
    if (!status.ok()) {
      exit_status = report_failure("doctor", status);
      return;
    }
    int failed = 0, warnings = 0;
    for (const auto& check : response.checks()) {
      std::cout << fmt::format("{:<8} {:<26} {}", status_word(check.status()), check.id(), check.finding());
      if (!check.fix().empty()) std::cout << "\n         fix: " << check.fix();
      std::cout << "\n";
      failed += check.status() == pb::CHECK_STATUS_FAILED;
      warnings += check.status() == pb::CHECK_STATUS_WARNING;
    }
    std::cout << fmt::format("{} checks: {} failed, {} warnings\n", response.checks_size(), failed, warnings);
    if (failed > 0 || (*strict && warnings > 0)) exit_status = kExitCheckFailed;
  });
}

}  // namespace chromo::cli
