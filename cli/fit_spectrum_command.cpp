// chromo fit-spectrum: fit the skin model to reflectance spectra measured with
// a contact spectrophotometer (estimation/spectrum_fit.hpp) and report the
// parameters and ΔE94 under D65, A and the six LED types.
#include <fmt/format.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "chromo/spectral/lab_illuminants.hpp"
#include "chromo/estimation/spectrum_fit.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"
#include "commands.hpp"

namespace chromo::cli {
namespace {

struct FitSpectrumOptions {
  std::string file;
  std::string model = "4d";
  bool specular_included = false;
  bool json = false;
};

int run_fit_spectrum(const FitSpectrumOptions& options) {
  estimation::SpectrumFitOptions fit;
  fit.order = options.model == "2d" ? 2 : 4;
  fit.specular_included = options.specular_included;
  std::vector<std::pair<std::string, spectral::Spectrum>> samples;
  try {
    const spectral::Table table = spectral::read_table(options.file);
    if (table.column_names.size() < 2 || table.column_names.front() != "wavelength_nm")
      throw spectral::DataError(options.file + ": expected columns wavelength_nm and one column per sample");
    for (std::size_t c = 1; c < table.column_names.size(); ++c)
      samples.emplace_back(table.column_names[c], spectral::resample_column(table, table.column_names[c]));
  } catch (const spectral::DataError& e) {
    std::cerr << "chromo fit-spectrum: " << e.what() << "\n";
    return kExitBadInput;
  }
  // Every sample is fitted before anything is printed: bad input prints nothing.
  std::vector<estimation::SpectrumFitResult> results;
  for (const auto& [name, spectrum] : samples) {
    try {
      results.push_back(estimation::fit_spectrum(spectrum, fit));
    } catch (const std::invalid_argument& e) {
      std::cerr << "chromo fit-spectrum: " << options.file << ": column '" << name << "': " << e.what() << "\n";
      return kExitBadInput;
    }
  }
  nlohmann::ordered_json array = nlohmann::ordered_json::array();
  double sum_d65 = 0, sum_a = 0, sum_led = 0;
  if (!options.json)
    fmt::print("# model {}{}; ΔE94 of the fit against the measured spectrum\n{:<14} {:>7} {:>7} {:>5} {:>6} {:>7} {:>6} "
               "{:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>7}\n",
               options.model, options.specular_included ? " + surface reflection" : "", "sample", "Cm", "Ch", "βm",
               "Che", "rms", "D65", "A", "W57", "W40", "W27", "R", "G", "B", "LEDmean");
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const std::string& name = samples[k].first;
    const estimation::SpectrumFitResult& r = results[k];
    sum_d65 += r.de94_d65, sum_a += r.de94_a, sum_led += r.de94_led_mean;
    const auto& p = r.parameters;
    if (options.json) {
      nlohmann::ordered_json o{{"sample", name},      {"cm", p.cm},         {"ch", p.ch},
                               {"bm", p.bm},          {"che", p.che},       {"specular", r.specular},
                               {"de94_d65", r.de94_d65}, {"de94_a", r.de94_a}, {"rms", r.rms}};
      nlohmann::ordered_json leds;
      for (int i = 0; i < spectral::kLedTypeCount; ++i)
        leds[std::string(spectral::led_type_name(spectral::kAllLedTypes[i]))] = r.de94_led[i];
      o["de94_led"] = leds;
      o["de94_led_mean"] = r.de94_led_mean;
      array.push_back(o);
    } else {
      fmt::print("{:<14} {:7.4f} {:7.4f} {:5.3f} {:6.4f} {:7.5f} {:6.3f} {:6.3f}", name, p.cm, p.ch, p.bm, p.che, r.rms,
                 r.de94_d65, r.de94_a);
      for (double d : r.de94_led) fmt::print(" {:6.3f}", d);
      fmt::print(" {:7.3f}\n", r.de94_led_mean);
    }
  }
  const double n = static_cast<double>(samples.size());
  if (options.json)
    std::cout << array.dump(2) << "\n";
  else
    fmt::print("mean over {} samples: ΔE94 D65 {:.3f}  A {:.3f}  six LEDs {:.3f}\n", samples.size(), sum_d65 / n,
               sum_a / n, sum_led / n);
  return kExitOk;
}

}  // namespace

void add_fit_spectrum_command(CLI::App& app, int& exit_status) {
  auto options = std::make_shared<FitSpectrumOptions>();
  CLI::App* cmd = app.add_subcommand(
      "fit-spectrum", "Fit the skin model to measured reflectance spectra (CSV: wavelength_nm, one column per sample)");
  cmd->add_option("file", options->file, "CSV file ('#' comments, header wavelength_nm,<sample>...)")->required();
  cmd->add_option("--model", options->model, "2d (Cm, Ch) or 4d (Cm, Ch, βm, Che)")
      ->check(CLI::IsMember({"2d", "4d"}))
      ->capture_default_str();
  cmd->add_flag("--specular-included", options->specular_included,
                "the instrument includes the specular component (8°/hemispherical SCI, e.g. NIST): add the surface "
                "reflection 0.0278 to the model");
  cmd->add_flag("--json", options->json, "print one JSON array, one object per sample");
  cmd->callback([options, &exit_status] { exit_status = run_fit_spectrum(*options); });
}

}  // namespace chromo::cli
