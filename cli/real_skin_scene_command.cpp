// chromo make-real-skin-scene: a MEASUREMENT.json scene of measured skin
// spectra (simulators/scene/real_skin_scene.hpp) for `chromo estimate`.
#include <fmt/format.h>

#include "chromo/simulators/scene/real_skin_scene.hpp"
#include "commands.hpp"

namespace chromo::cli {

void add_real_skin_scene_command(CLI::App& app, int& exit_status) {
  auto options = std::make_shared<simulators::RealSkinSceneOptions>();
  auto subjects = std::make_shared<std::string>("041-050");
  auto out = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand("make-real-skin-scene",
                                     "A scene of measured skin spectra (NIST forearms) for chromo estimate (docs/estimation.md 'Real skin')");
  cmd->add_option("--out", *out, "output directory")->required();
  cmd->add_option("--subjects", *subjects, "NIST subjects, a range (041-050) or a list (001,007)")->capture_default_str();
  cmd->add_option("--plan", options->plan, "method (D65' + blue) or six-leds")
      ->check(CLI::IsMember({"method", "six-leds"}))
      ->capture_default_str();
  cmd->add_option("--patch", options->patch_px, "patch side per subject (px)")->capture_default_str();
  cmd->add_option("--columns", options->columns, "patches per row")->capture_default_str();
  cmd->add_option("--texture", options->texture_relative, "relative texture amplitude")->capture_default_str();
  cmd->add_option("--noise-scale", options->noise_scale,
                  "camera noise, × four frames of a 40,000 e- sensor (0 = noise-free)")->capture_default_str();
  cmd->add_flag("--anomalies,!--no-anomalies", options->anomalies, "an ink disc and a marker stroke")->capture_default_str();
  cmd->add_option("--seed", options->seed)->capture_default_str();
  cmd->callback([options, subjects, out, &exit_status] {
    exit_status = run_map_operation("make-real-skin-scene", [&] {
      options->spectra = simulators::nist_subjects(*subjects);
      simulators::write_real_skin_scene(*out, *options);
      fmt::print("real skin scene of {} subjects ({}) → {} (MEASUREMENT.json, truth.exr, skin_mask.png)\n",
                 options->spectra.size(), options->plan, *out);
    });
  });
}

}  // namespace chromo::cli
