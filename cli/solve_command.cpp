// chromo solve TARGET and chromo calibrate: the daemon's mix solver and
// calibration runs (the offline versions are `chromo leds ...`).
#include <iostream>

#include <fmt/format.h>

#include "chromosphere/v1/calibration.grpc.pb.h"
#include "commands.hpp"
#include "daemon_client.hpp"

namespace chromo::cli {

namespace pb = chromosphere::v1;

void add_solve_command(CLI::App& app, int& exit_status) {
  struct Options {
    DaemonAddress address;
    std::string target;
    std::string controller, spectrometer;
    std::vector<double> levels;
    unsigned warmup_ms = 0;
    std::string objective = "camera";
    bool hold_chromaticity = false, detach = false;
    std::string adopt_id, adopt_reason;
  };
  auto options = std::make_shared<Options>();
  auto* solve = app.add_subcommand("solve", "the LED weights chromod uses for a mix (d65, w57, w57+blue[:R])");
  add_daemon_options(*solve, options->address);
  solve->add_option("target", options->target, "mix: d65, w57, w57+blue[:R] or cct:K")->required();
  solve->add_option("--objective", options->objective, "spectral, xyz or camera")->capture_default_str();
  solve->add_flag("--hold-chromaticity", options->hold_chromaticity, "camera objective: hold the target's chromaticity");
  solve->callback([&exit_status, options] {
    DaemonConnection daemon(options->address);
    pb::SolveMixRequest request;
    request.set_target(options->target);
    if (options->objective == "spectral") request.set_objective(pb::MIX_OBJECTIVE_SPECTRAL);
    else if (options->objective == "xyz") request.set_objective(pb::MIX_OBJECTIVE_XYZ);
    else if (options->objective == "camera") request.set_objective(pb::MIX_OBJECTIVE_CAMERA);
    else {
      std::cerr << "solve: --objective: \"" << options->objective << "\" is not spectral, xyz or camera\n";
      exit_status = kExitBadInput;
      return;
    }
    request.set_hold_chromaticity(options->hold_chromaticity);
    pb::SolveMixResponse response;
    auto status = pb::CalibrationService::NewStub(daemon.channel())->SolveMix(daemon.context().get(), request, &response);
    if (!status.ok()) {
      exit_status = report_failure("solve", status);
      return;
    }
    const auto& w = response.weights();
    std::cout << fmt::format("{}: W57 {:.4f}  W40 {:.4f}  W27 {:.4f}  R {:.4f}  G {:.4f}  B {:.4f}\n{}\n", options->target,
                             w.w57(), w.w40(), w.w27(), w.red(), w.green(), w.blue(), response.summary());
    std::cout << "library: " << response.library() << "\n";
    for (const auto& [name, value] : response.figures()) std::cout << fmt::format("  {} = {:.4g}\n", name, value);
  });

  auto* calibrate = app.add_subcommand("calibrate", "measure the LED library on chromod's spectrometer");
  add_daemon_options(*calibrate, options->address);
  calibrate->add_option("--controller", options->controller, "LED controller (default: the only one)");
  calibrate->add_option("--spectrometer", options->spectrometer, "spectrometer (default: the only one)");
  calibrate->add_option("--levels", options->levels, "drive-level ladder, increasing, each in (0, 1]");
  calibrate->add_option("--warmup-ms", options->warmup_ms, "warm-up per LED type, ms (0: the daemon's default)");
  calibrate->add_flag("--detach", options->detach, "print the id and return instead of following the run");
  // chromo calibrate adopt ID --reason TEXT: a run the daemon did not adopt (worse than its library then).
  auto* adopt = calibrate->add_subcommand("adopt", "adopt a calibration's library that the daemon kept out "
                                                   "(it measured worse than the library in use); audited");
  adopt->add_option("id", options->adopt_id, "the calibration's id")->required();
  adopt->add_option("--reason", options->adopt_reason, "why (written to the audit log)")->required();
  adopt->callback([&exit_status, options] {
    DaemonConnection daemon(options->address);
    pb::AdoptCalibrationRequest request;
    request.set_id(options->adopt_id);
    request.set_reason(options->adopt_reason);
    pb::AdoptCalibrationResponse response;
    auto status =
        pb::CalibrationService::NewStub(daemon.channel())->AdoptCalibration(daemon.context().get(), request, &response);
    if (!status.ok()) {
      exit_status = report_failure("calibrate adopt", status);
      return;
    }
    std::cout << "calibration " << options->adopt_id << " adopted: the daemon's LED library is now " << response.library()
              << "\n";
  });
  calibrate->callback([&exit_status, options, adopt] {
    if (adopt->parsed()) return;  // the subcommand did the work
    DaemonConnection daemon(options->address);
    pb::StartCalibrationRequest request;
    request.set_controller(options->controller);
    request.set_spectrometer(options->spectrometer);
    for (double level : options->levels) request.add_drive_levels(level);
    request.set_warmup_ms(options->warmup_ms);
    pb::Operation operation;
    auto status =
        pb::CalibrationService::NewStub(daemon.channel())->StartCalibration(daemon.context().get(), request, &operation);
    if (!status.ok()) {
      exit_status = report_failure("calibrate", status);
      return;
    }
    std::cout << "calibration " << operation.id() << " started\n";
    if (options->detach) {
      std::cout << "follow it with: chromo session watch " << operation.id() << "\n";
      return;
    }
    exit_status = watch_operation(daemon, operation.id());
  });
}

}  // namespace chromo::cli
