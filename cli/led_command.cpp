// chromo led get|set: the LED state through chromod.
#include <iostream>
#include <optional>

#include <fmt/format.h>

#include "chromosphere/v1/leds.grpc.pb.h"
#include "commands.hpp"
#include "daemon_client.hpp"

namespace chromo::cli {

namespace pb = chromosphere::v1;

namespace {
void print_status(const pb::LedStatus& status) {
  const auto& d = status.applied().drive();
  std::cout << fmt::format("{}: W57 {:.4f}  W40 {:.4f}  W27 {:.4f}  R {:.4f}  G {:.4f}  B {:.4f}  output {}\n",
                           status.controller(), d.w57(), d.w40(), d.w27(), d.red(), d.green(), d.blue(),
                           status.output_enabled() ? "on" : "off");
  std::cout << "temperature_C:";
  for (double t : status.temperature_c()) std::cout << fmt::format(" {:.1f}", t);
  std::cout << "\n";
}
}  // namespace

void add_led_command(CLI::App& app, int& exit_status) {
  auto* led = app.add_subcommand("led", "read or set the LED state through chromod");
  led->require_subcommand(1);
  struct Options {
    DaemonAddress address;
    std::string controller;
    double levels[6] = {0, 0, 0, 0, 0, 0};
    std::optional<bool> output;
  };
  auto options = std::make_shared<Options>();

  auto* get = led->add_subcommand("get", "the applied state and temperatures");
  add_daemon_options(*get, options->address);
  get->add_option("--controller", options->controller, "LED controller name (default: the only one)");
  get->callback([&exit_status, options] {
    DaemonConnection daemon(options->address);
    pb::GetLedStateRequest request;
    request.set_controller(options->controller);
    pb::LedStatus status;
    auto result = pb::LedService::NewStub(daemon.channel())->GetLedState(daemon.context().get(), request, &status);
    if (!result.ok()) {
      exit_status = report_failure("led get", result);
      return;
    }
    print_status(status);
  });

  auto* set = led->add_subcommand("set", "apply drive levels (0-1); unnamed types are set to 0");
  add_daemon_options(*set, options->address);
  set->add_option("--controller", options->controller, "LED controller name (default: the only one)");
  const char* names[] = {"--w57", "--w40", "--w27", "--red", "--green", "--blue"};
  for (int i = 0; i < 6; ++i) set->add_option(names[i], options->levels[i], "drive level 0-1");
  set->add_option("--output", options->output, "switch the output on (true) or off (false)");
  set->callback([&exit_status, options] {
    DaemonConnection daemon(options->address);
    pb::SetLedStateRequest request;
    request.set_controller(options->controller);
    auto* drive = request.mutable_state()->mutable_drive();
    drive->set_w57(options->levels[0]);
    drive->set_w40(options->levels[1]);
    drive->set_w27(options->levels[2]);
    drive->set_red(options->levels[3]);
    drive->set_green(options->levels[4]);
    drive->set_blue(options->levels[5]);
    if (options->output) request.set_output_enabled(*options->output);
    pb::LedStatus status;
    auto result = pb::LedService::NewStub(daemon.channel())->SetLedState(daemon.context().get(), request, &status);
    if (!result.ok()) {
      exit_status = report_failure("led set", result);
      return;
    }
    print_status(status);
  });
}

}  // namespace chromo::cli
