// chromo model: evaluate the skin model (MODEL.md) for one parameter set and
// print the albedo spectrum with its colour under an illuminant.
#include <fmt/format.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "chromo/estimation/skin_model.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/colorimetry.hpp"
#include "chromo/spectral/srgb.hpp"
#include "chromo/spectral/table.hpp"
#include "commands.hpp"

namespace chromo::cli {
namespace {

struct ModelOptions {
  estimation::SkinParameters parameters;
  std::string illuminant = "d65";
  bool json = false;
};

int run_model(const ModelOptions& options) {
  if (auto violation = estimation::range_violation(options.parameters)) {
    std::cerr << "chromo model: " << *violation << "\n";
    return kExitBadInput;
  }
  spectral::Spectrum illuminant;
  try {
    illuminant = spectral::illuminant_by_name_or_file(options.illuminant);
  } catch (const spectral::DataError& e) {
    std::cerr << "chromo model: --illuminant: " << e.what() << "\n";
    return kExitBadInput;
  }
  const estimation::SkinModel model;
  const spectral::Spectrum albedo = model.albedo(options.parameters);
  const spectral::Xyz white = spectral::white_point(illuminant);
  const spectral::Xyz xyz = spectral::xyz_of_reflectance(albedo, illuminant);
  const spectral::Lab lab = spectral::lab_from_xyz(xyz, white);
  const spectral::Rgb srgb = spectral::srgb_from_xyz(xyz, white);
  const auto& p = options.parameters;

  if (options.json) {
    nlohmann::ordered_json out;
    std::vector<double> wavelengths;
    for (int i = 0; i < spectral::kGridSize; ++i) wavelengths.push_back(spectral::grid_wavelength_nm(i));
    out["parameters"] = {{"cm", p.cm}, {"ch", p.ch}, {"bm", p.bm}, {"che", p.che}};
    out["illuminant"] = options.illuminant;
    out["wavelength_nm"] = wavelengths;
    out["albedo"] = albedo.to_vector();
    out["xyz"] = {{"X", xyz.X}, {"Y", xyz.Y}, {"Z", xyz.Z}};
    out["lab"] = {{"L", lab.L}, {"a", lab.a}, {"b", lab.b}};
    out["srgb"] = {{"r", srgb.r}, {"g", srgb.g}, {"b", srgb.b}};
    std::cout << out.dump(2) << "\n";
    return kExitOk;
  }
  fmt::print("# skin albedo (MODEL.md): Cm={} Ch={} βm={} Che={}\n", p.cm, p.ch, p.bm, p.che);
  fmt::print("# wavelength_nm albedo\n");
  for (int i = 0; i < spectral::kGridSize; ++i) fmt::print("{:.0f} {:.6f}\n", spectral::grid_wavelength_nm(i), albedo[i]);
  fmt::print("illuminant {} (white X={:.3f} Y=100 Z={:.3f})\n", options.illuminant, white.X, white.Z);
  fmt::print("XYZ    {:.4f} {:.4f} {:.4f}\n", xyz.X, xyz.Y, xyz.Z);
  fmt::print("CIELAB {:.4f} {:.4f} {:.4f}\n", lab.L, lab.a, lab.b);
  auto byte = [](double v) { return static_cast<int>(v * 255.0 + 0.5); };
  fmt::print("sRGB   {:.4f} {:.4f} {:.4f} (#{:02x}{:02x}{:02x})\n", srgb.r, srgb.g, srgb.b, byte(srgb.r), byte(srgb.g),
             byte(srgb.b));
  return kExitOk;
}

}  // namespace

void add_model_command(CLI::App& app, int& exit_status) {
  auto options = std::make_shared<ModelOptions>();
  CLI::App* cmd = app.add_subcommand("model", "Evaluate the skin model: albedo spectrum, XYZ, CIELAB and sRGB");
  auto range_text = [](const estimation::ParameterRange& r) { return fmt::format(" ({}-{})", r.min, r.max); };
  cmd->add_option("--cm", options->parameters.cm, "melanin volume fraction Cm" + range_text(estimation::kCmRange))
      ->required();
  cmd->add_option("--ch", options->parameters.ch, "dermal hemoglobin fraction Ch" + range_text(estimation::kChRange))
      ->required();
  cmd->add_option("--bm", options->parameters.bm, "eumelanin share βm" + range_text(estimation::kBmRange))
      ->capture_default_str();
  cmd->add_option("--che", options->parameters.che,
                  "epidermal hemoglobin fraction Che" + range_text(estimation::kCheRange))
      ->capture_default_str();
  cmd->add_option("--illuminant", options->illuminant, "d65, d50, a, or a CSV file (wavelength_nm,value)")
      ->capture_default_str();
  cmd->add_flag("--json", options->json, "print one JSON object");
  cmd->callback([options, &exit_status] { exit_status = run_model(*options); });
}

}  // namespace chromo::cli
