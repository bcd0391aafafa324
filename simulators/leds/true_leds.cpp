#include "chromo/simulators/leds/true_leds.hpp"

#include <algorithm>
#include <string>

#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::simulators {

TrueLedSet default_true_leds() {
  // file, flux, nm/K, loss/K, rise K, current shift nm, droop (docs/virtual-lab-leds.md)
  return {{
      {"led_spectra_measured/LCFOCUS_LC_10FS504_G24.csv", 1.00, 0.05, 0.0030, 35, -1.5, 0.10},
      {"led_spectra_measured/LCFOCUS_LC_10FSCOB1917_4000.csv", 0.90, 0.05, 0.0030, 35, -1.5, 0.10},
      {"led_spectra_measured/Nichia_NS6L183AT_H1_sw.csv", 0.80, 0.05, 0.0035, 35, -1.5, 0.10},
      {"led_spectra_measured/LedEngin_LZ7_N4M100_ch_B_Red.csv", 0.70, 0.13, 0.0090, 30, 0.5, 0.05},
      {"led_spectra_measured/LedEngin_LZ7_N4M100_ch_A_Green.csv", 0.50, 0.04, 0.0040, 35, -4.0, 0.20},
      {"led_spectra_measured/LedEngin_LZ7_N4M100_ch_C_Blue.csv", 0.70, 0.03, 0.0015, 35, -2.0, 0.15},
  }};
}

double FineSpectrum::at(double nm) const {
  if (wavelength_nm.empty() || nm < wavelength_nm.front() || nm > wavelength_nm.back()) return 0.0;
  auto upper = std::upper_bound(wavelength_nm.begin(), wavelength_nm.end(), nm);
  if (upper == wavelength_nm.end()) return value.back();
  std::size_t i = static_cast<std::size_t>(upper - wavelength_nm.begin());
  if (i == 0) return value.front();
  double t = (nm - wavelength_nm[i - 1]) / (wavelength_nm[i] - wavelength_nm[i - 1]);
  return value[i - 1] + t * (value[i] - value[i - 1]);
}

FineSpectrum load_reference_spectrum(const TrueLedParameters& parameters) {
  spectral::Table table =
      spectral::parse_table(spectral::data::embedded_file(parameters.spectrum_file), parameters.spectrum_file);
  if (table.columns.size() < 2 || table.rows() < 2)
    throw spectral::DataError(parameters.spectrum_file + ": needs a wavelength and a value column");
  FineSpectrum spectrum{table.columns[0], table.columns[1]};
  double peak = *std::max_element(spectrum.value.begin(), spectrum.value.end());
  if (!(peak > 0)) throw spectral::DataError(parameters.spectrum_file + ": no positive value");
  for (double& v : spectrum.value) v = std::max(0.0, v / peak);
  return spectrum;
}

}  // namespace chromo::simulators
