// chromo profiles: radial reflectance profile tables for renderers, and
// per-pixel index maps into them (docs/formats/profiles.md).
#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <sstream>

#include "chromo/estimation/profile_table.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/table.hpp"
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
  auto bad_input = [](const std::string& message) {
    std::cerr << "chromo profiles: " << message << "\n";
    return kExitBadInput;
  };
  // Everything is checked before anything is written.
  spectral::Spectrum illuminant;
  try {
    illuminant = spectral::illuminant_by_name_or_file(options.illuminant);
  } catch (const spectral::DataError& e) {
    return bad_input(std::string("--illuminant: ") + e.what());
  }
  estimation::ProfileTableAxes axes = estimation::ProfileTableAxes::Default();
  if (!options.cm.empty()) axes.cm = options.cm;
  if (!options.ch.empty()) axes.ch = options.ch;
  if (!options.bm.empty()) axes.bm = options.bm;
  if (!options.che.empty()) axes.che = options.che;
  std::string error;
  if (!axes.IsValid(&error)) return bad_input(error);
  std::optional<estimation::ParameterMaps> maps;
  if (!options.maps.empty()) {
    try {
      maps = estimation::read_parameter_maps(options.maps);
    } catch (const std::runtime_error& e) {
      return bad_input(std::string("--maps: ") + e.what());
    }
  }
  if (std::filesystem::exists(options.out) && !std::filesystem::is_directory(options.out))
    return bad_input("--out: " + options.out.string() + " exists and is not a directory");

  const estimation::SkinModel model;
  const estimation::RadialProfileModel profile_model(model, illuminant);
  const auto table = estimation::build_profile_table(profile_model, axes, options.illuminant, options.threads,
                                                     [](double done) {
                                                       std::cerr << fmt::format("\rprofiles {:5.1f}%", 100 * done);
                                                       return true;
                                                     });
  std::cerr << "\n";
  estimation::write_profile_table(options.out, table);
  fmt::print("{} profiles × {} radii ({:.4g}-{:.4g} mm) under {} → {}/profiles.json, profiles.f32\n",
             axes.entry_count(), table.radius_mm.size(), table.radius_mm.front(), table.radius_mm.back(),
             options.illuminant, options.out.string());
  fmt::print("worst plane-integral error against the forward-model albedo: {:.3f}%\n",
             100 * table.worst_plane_integral_error);
  if (maps) {
    const auto indices = estimation::nearest_entry_indices(table, *maps);
    estimation::write_index_map(options.out, *maps, indices);
    const auto unmapped = std::count(indices.begin(), indices.end(), estimation::kNoProfileEntry);
    fmt::print("index map {}x{} → {}/index.exr ({} flagged or invalid pixels have no entry)\n", maps->width,
               maps->height, options.out.string(), unmapped);
  }
  return kExitOk;
}

}  // namespace

void add_profiles_command(CLI::App& app, int& exit_status) {
  auto options = std::make_shared<ProfilesOptions>();
  CLI::App* cmd = app.add_subcommand("profiles", "Radial reflectance profile tables for renderers (+ index maps)");
  cmd->add_option("--illuminant", options->illuminant, "d65, d50, a, or a CSV file (wavelength_nm,value)")
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
