// chromo discrepancy: the skin model's learned discrepancy on real skin
// (estimation/model_discrepancy.hpp, docs/estimation.md "Real skin").
//   learn: refit the shipped NIST forearm spectra (or a CSV of spectra) and
//          write the residual table the library ships (data/skin_model_residuals.csv)
//   show:  the statistic learned from the shipped residuals, per wavelength
#include <fmt/format.h>

#include <iostream>

#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/files/durable_file.hpp"
#include "chromo/spectral/grid.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"
#include "commands.hpp"

namespace chromo::cli {
namespace {

struct DiscrepancyOptions {
  std::string spectra;  // empty: the shipped NIST forearms
  std::string out;
  int threads = 0;
};

int run_learn(const DiscrepancyOptions& options) {
  std::vector<estimation::NamedSpectrum> spectra;
  std::string source = "data/skin_reflectance_nist.csv (NIST doi:10.18434/M38597, subjects 001-050)";
  if (options.spectra.empty()) {
    spectra = estimation::nist_forearm_spectra();
  } else {
    try {
      const spectral::Table table = spectral::read_table(options.spectra);
      if (table.column_names.size() < 2 || table.column_names.front() != "wavelength_nm")
        throw spectral::DataError(options.spectra + ": expected columns wavelength_nm and one column per spectrum");
      for (std::size_t c = 1; c < table.column_names.size(); ++c)
        spectra.push_back({table.column_names[c], spectral::resample_column(table, table.column_names[c])});
    } catch (const spectral::DataError& e) {
      std::cerr << "chromo discrepancy learn: " << e.what() << "\n";
      return kExitBadInput;
    }
    source = options.spectra;
  }
  if (spectra.size() < 3) {
    std::cerr << "chromo discrepancy learn: " << source << ": at least 3 spectra are needed, found " << spectra.size() << "\n";
    return kExitBadInput;
  }
  std::vector<estimation::SpectrumResidual> residuals;
  try {
    std::cerr << "fitting " << spectra.size() << " spectra with the 4D model...\n";
    residuals = estimation::fit_residuals(spectra, {}, options.threads);
  } catch (const std::invalid_argument& e) {
    std::cerr << "chromo discrepancy learn: " << source << ": " << e.what() << "\n";
    return kExitBadInput;
  }
  const std::string provenance =
      "The 4D skin model's best full-spectrum fit (fit_spectrum, default options) of each spectrum and its residual\n"
      "(measured - fitted, albedo units) on the 380-780 nm grid: the training material of the model's learned\n"
      "discrepancy (estimation/model_discrepancy.hpp). Made by `chromo discrepancy learn` from " +
      source + ".";
  const std::string csv = estimation::residuals_csv(residuals, provenance);
  files::write_file_durably(options.out, csv, nullptr);
  const estimation::ModelDiscrepancy d = estimation::ModelDiscrepancy::learn(residuals);
  fmt::print("{} residual spectra written to {}; shrinkage λ* {:.3f}\n", residuals.size(), options.out, d.shrinkage());
  return kExitOk;
}

int run_show() {
  const auto d = estimation::ModelDiscrepancy::standard();
  fmt::print("# the model's discrepancy learned from {} NIST forearms (shrinkage λ* {:.3f}), albedo units\n", d->subjects(),
             d->shrinkage());
  fmt::print("{:>6} {:>10} {:>10}\n", "nm", "sigma", "fit_mean");
  const spectral::Spectrum sigma = d->sigma();
  for (int k = 0; k < spectral::kGridSize; k += 4)
    fmt::print("{:6.0f} {:10.4f} {:10.4f}\n", spectral::grid_wavelength_nm(k), sigma[k], d->mean_fitted()[k]);
  return kExitOk;
}

}  // namespace

void add_discrepancy_command(CLI::App& app, int& exit_status) {
  CLI::App* cmd = app.add_subcommand("discrepancy", "The skin model's learned discrepancy on real skin spectra");
  cmd->require_subcommand(1);
  auto options = std::make_shared<DiscrepancyOptions>();
  CLI::App* learn = cmd->add_subcommand("learn", "Refit skin spectra with the 4D model and write the residual table");
  learn->add_option("--spectra", options->spectra,
                    "CSV of albedo spectra (wavelength_nm, one column per spectrum); default: the shipped NIST forearms");
  learn->add_option("--out", options->out, "the residual table to write (CSV)")->required();
  learn->add_option("--threads", options->threads, "fitting threads (0: all cores)")->check(CLI::Range(0, 256));
  learn->callback([options, &exit_status] { exit_status = run_learn(*options); });
  CLI::App* show = cmd->add_subcommand("show", "Print the learned discrepancy (σ per wavelength)");
  show->callback([&exit_status] { exit_status = run_show(); });
}

}  // namespace chromo::cli
