// chromo relight: parameter maps relit under any illuminant, optionally
// compared with a photograph (docs/maps.md).
#include <fmt/format.h>

#include <iostream>

#include "chromo/maps/map_operations.hpp"
#include "commands.hpp"

namespace chromo::cli {

int run_map_operation(const char* command, const std::function<void()>& operation) {
  try {
    operation();
    return kExitOk;
  } catch (const std::invalid_argument& e) {
    std::cerr << "chromo " << command << ": " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "chromo " << command << ": " << e.what() << "\n";
    return kExitFailure;
  }
}

void add_relight_command(CLI::App& app, int& exit_status) {
  auto options = std::make_shared<maps::RelightOptions>();
  CLI::App* cmd = app.add_subcommand("relight", "Relight parameter maps under any illuminant (+ panel against a photograph)");
  cmd->add_option("maps", options->maps, "maps.exr from chromo estimate")->required();
  cmd->add_option("--illuminant", options->illuminant,
                  "W57, W40, W27, R, G, B, D65, D50, A, a CCT like 4000K, or a CSV file (wavelength_nm,value)")
      ->capture_default_str();
  cmd->add_option("--out", options->out, "output directory")->required();
  cmd->add_option("--photo", options->photograph, "photograph: OpenEXR camera RGB albedo under the illuminant");
  cmd->add_option("--camera", options->camera, "the photograph's camera: builtin:<name> or a CSV")->capture_default_str();
  cmd->add_option("--heat-max", options->heat_map_max, "ΔE94 at the top of the colour bar (0 = the p95 clamped to 1-5)");
  cmd->add_option("--threads", options->threads, "threads (0 = all cores)");
  auto layer = std::make_shared<std::string>("on");
  cmd->add_option("--discrepancy-layer", *layer,
                  "on: add the maps' posterior discrepancy where they carry one (chromo estimate --discrepancy-layer "
                  "on); off: the model alone")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  cmd->callback([options, layer, &exit_status] {
    options->discrepancy_layer = *layer == "on";
    exit_status = run_map_operation("relight", [&] {
      const auto s = maps::relight_to_files(*options);
      fmt::print("{}x{} maps relit under {} ({}): {} pixels → {}\n", s.width, s.height, s.illuminant,
                 s.discrepancy_layer ? "model + discrepancy" : "model", s.relit_pixels, options->out.string());
      if (s.compared)
        fmt::print("ΔE94 photograph vs reconstruction: mean {:.3f} median {:.3f} p95 {:.3f} ({} pixels)\n",
                   s.photo_delta_e94.mean, s.photo_delta_e94.median, s.photo_delta_e94.p95, s.photo_delta_e94.pixels);
    });
  });
}

}  // namespace chromo::cli
