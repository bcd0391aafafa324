// chromo leds measure [--out FILE] [--json]: a calibration run
// (calibration_run.hpp) on the in-process virtual lab: the LED controller
// simulator over Modbus TCP on loopback, a simulated USB2000+ behind the USB
// seam, the reference lamp; the real drivers in between. Progress bar on stderr.

#include <cstdio>
#include <iostream>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "chromo/calibration/led_library_io.hpp"
#include "chromo/drivers/led_controller_factory.hpp"
#include "chromo/drivers/spectrometer_factory.hpp"
#include "chromo/simulators/calibration_lab.hpp"
#include "commands.hpp"
#include "leds_common.hpp"

namespace chromo::cli {
namespace {


void draw_progress_bar(double fraction, const std::string& step) {
  constexpr int kWidth = 30;
  const int filled = static_cast<int>(fraction * kWidth + 0.5);
  std::fprintf(stderr, "\r[%s%s] %3d%% %-40.40s", std::string(filled, '#').c_str(),
               std::string(kWidth - filled, ' ').c_str(), static_cast<int>(fraction * 100 + 0.5), step.c_str());
  if (fraction >= 1.0) std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

}  // namespace

MeasuredOnVirtualLab measure_on_virtual_lab(const std::filesystem::path& out_path, bool progress_bar) {
  simulators::CalibrationLabOptions lab_options;
  lab_options.leds.time_scale = 3000;  // lab seconds per wall-clock second
  simulators::CalibrationLab lab(lab_options);
  auto leds = drivers::make_modbus_tcp_led_controller("127.0.0.1", lab.start_modbus_tcp());
  auto spectrometer = drivers::make_usb_spectrometer(lab.make_spectrometer_transport());

  calibration::CalibrationRunOptions options;
  options.warm_up_s = 0.1;  // 300 s of lab time: 5 thermal time constants
  options.settle_s = 0.01;  // 30 s of lab time
  options.lamp_temperature_K = lab_options.lamp_temperature_K;
  options.lamp_description = fmt::format("virtual-lab tungsten halogen (Planckian, {:.0f} K)", lab_options.lamp_temperature_K);
  options.ambient_temperature_C = lab_options.leds.ambient_C;
  options.notes = fmt::format("virtual lab (chromo leds measure): lab time runs {:.0f}x the wall clock, so the "
                              "{:.1f} s warm-up is {:.0f} s of LED time",
                              lab_options.leds.time_scale, options.warm_up_s, options.warm_up_s * lab_options.leds.time_scale);
  calibration::CalibrationRun run(*leds, *spectrometer, lab.lamp_switch(), options);
  MeasuredOnVirtualLab result;
  result.summary = run.run(progress_bar ? files::Progress{draw_progress_bar, {}} : files::Progress{});
  if (result.summary.IsLibraryUsable()) {
    result.path = out_path.empty() ? calibration::led_library_directory() /
                                         calibration::led_library_file_name(result.summary.library)
                                   : out_path;
    if (result.path.has_parent_path()) std::filesystem::create_directories(result.path.parent_path());
    calibration::save_led_library(result.summary.library, result.path);
  }
  return result;
}

void add_leds_measure_command(CLI::App* leds, int& exit_status) {
  struct Arguments {
    std::string out;
    bool json = false;
  };
  auto a = std::make_shared<Arguments>();
  CLI::App* measure = leds->add_subcommand(
      "measure", "Measure an LED library on the in-process virtual lab (reference lamp, then each LED's drive ladder)");
  measure->add_option("--out", a->out, "library file to write (default: a new file in the library directory)");
  measure->add_flag("--json", a->json, "print one JSON object");
  measure->callback([a, &exit_status] {
    MeasuredOnVirtualLab measured;
    try {
      measured = measure_on_virtual_lab(a->out, true);
    } catch (const std::exception& e) {
      std::cerr << "leds measure: " << e.what() << "\n";
      exit_status = kExitFailure;
      return;
    }
    const auto& s = measured.summary;
    if (a->json) {
      nlohmann::json out;
      out["termination"] = calibration::calibration_termination_name(s.termination);
      out["message"] = s.message;
      out["library"] = measured.path.string();
      out["spectra_measured"] = s.spectra_measured;
      out["elapsed_s"] = s.elapsed_s;
      out["linearity_ok"] = s.linearity_ok;
      for (const auto& lin : s.linearity)
        out["linearity_max_deviation_percent"][std::string(spectral::led_type_name(lin.type))] = lin.max_deviation_percent;
      std::cout << out.dump(2) << "\n";
    } else {
      fmt::print("{}: {}\n", calibration::calibration_termination_name(s.termination), s.message);
      if (s.IsLibraryUsable()) {
        fmt::print("library: {}\n", measured.path.string());
        fmt::print("{:>4} {:>16} {:>12}\n", "LED", "linearity dev %", "T at full °C");
        for (int i = 0; i < spectral::kLedTypeCount; ++i)
          fmt::print("{:>4} {:>16.2f} {:>12.1f}\n", spectral::led_type_name(s.linearity[i].type),
                     s.linearity[i].max_deviation_percent,
                     s.library.leds[i].ladder.back().led_temperature_C.value_or(0.0));
      }
    }
    exit_status = s.IsLibraryUsable() ? kExitOk : kExitFailure;
  });
}

}  // namespace chromo::cli
