// chromo profiles: radial reflectance profile tables for renderers, and
// per-pixel index maps into them (docs/formats/profiles.md).
#include <fmt/format.h>

#include <filesystem>
#include <iostream>

#include "chromo/maps/map_operations.hpp"
#include "commands.hpp"

namespace chromo::cli {
namespace {

struct ProfilesOptions {
  std::string illuminant = "d65";
  std::filesystem::path out;
  std::filesystem::path maps;
  std::vector<double> cm, ch, bm, che;
  int threads = 0;
};

int run_profiles(const ProfilesOptions& options) {
  maps::ExportProfilesOptions o;
  o.illuminant = options.illuminant;
  o.out = options.out;
  o.maps = options.maps;
  if (!options.cm.empty()) o.axes.cm = options.cm;
  if (!options.ch.empty()) o.axes.ch = options.ch;
  if (!options.bm.empty()) o.axes.bm = options.bm;
  if (!options.che.empty()) o.axes.che = options.che;
  o.threads = options.threads;
  o.progress.on_progress = [](double done, const std::string&) {
    std::cerr << fmt::format("\rprofiles {:5.1f}%", 100 * done);
  };
  try {
    // Everything is checked before anything is written (map_operations.hpp).
    const maps::ExportProfilesSummary s = maps::export_profiles_to_files(o);
    std::cerr << "\n";
    fmt::print("{} profiles × {} radii under {} → {}/profiles.json, profiles.f32\n", s.entries, s.radii,
               options.illuminant, options.out.string());
    fmt::print("worst plane-integral error against the forward-model albedo: {:.3f}%\n",
               100 * s.worst_plane_integral_error);
    if (!options.maps.empty())
      fmt::print("index map → {}/index.exr ({} flagged or invalid pixels have no entry)\n", options.out.string(),
                 s.unmapped_pixels);
    return kExitOk;
  } catch (const std::invalid_argument& e) {
    // The library names fields ("maps: ..."); the command line names options.
    const std::string message = e.what();
    std::cerr << "chromo profiles: " << (message.rfind("axes: ", 0) == 0 ? message.substr(6) : "--" + message) << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "chromo profiles: " << e.what() << "\n";
    return kExitFailure;
  }
}

}  // namespace

void add_profiles_command(CLI::App& app, int& exit_status) {
  auto options = std::make_shared<ProfilesOptions>();
  CLI::App* cmd = app.add_subcommand("profiles", "Radial reflectance profile tables for renderers (+ index maps)");
  cmd->add_option("--illuminant", options->illuminant,
                  "W57, W40, W27, R, G, B, D65, D50, A, a CCT like 4000K, or a CSV file (wavelength_nm,value)")
      ->capture_default_str();
  cmd->add_option("--out", options->out, "output directory")->required();
  cmd->add_option("--maps", options->maps, "maps.exr from chromo estimate: also write index.exr");
  cmd->add_option("--cm", options->cm, "Cm axis values (default: 8 log-spaced over 0.002-0.5)")->delimiter(',');
  cmd->add_option("--ch", options->ch, "Ch axis values (default: 8 log-spaced over 0.002-0.32)")->delimiter(',');
  cmd->add_option("--bm", options->bm, "βm axis values (default: 0.3,0.7,1)")->delimiter(',');
  cmd->add_option("--che", options->che, "Che axis values (default: 0,0.03,0.08)")->delimiter(',');
  cmd->add_option("--threads", options->threads, "threads (0 = all cores)");
  cmd->callback([options, &exit_status] { exit_status = run_profiles(*options); });
}

}  // namespace chromo::cli
