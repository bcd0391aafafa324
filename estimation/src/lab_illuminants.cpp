#include "chromo/estimation/lab_illuminants.hpp"

#include <Eigen/Dense>
#include <array>

#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::estimation {

const spectral::Spectrum& led_spectrum(spectral::LedType type) {
  static const std::array<spectral::Spectrum, spectral::kLedTypeCount> spectra = [] {
    constexpr std::array<const char*, spectral::kLedTypeCount> kFiles{
        "led_spectra_measured/LCFOCUS_LC_10FS504_G24.csv", "led_spectra_measured/LCFOCUS_LC_10FSCOB1917_4000.csv",
        "led_spectra_measured/Nichia_NS6L183AT_H1_sw.csv", "led_spectra_measured/LedEngin_LZ7_N4M100_ch_B_Red.csv",
        "led_spectra_measured/LedEngin_LZ7_N4M100_ch_A_Green.csv",
        "led_spectra_measured/LedEngin_LZ7_N4M100_ch_C_Blue.csv"};
    std::array<spectral::Spectrum, spectral::kLedTypeCount> out;
    for (int i = 0; i < spectral::kLedTypeCount; ++i) {
      const spectral::Table table = spectral::parse_table(spectral::data::embedded_file(kFiles[i]), kFiles[i]);
      out[i] = spectral::resample_column(table, table.column_names.at(1), spectral::OutsideRange::kZero);
    }
    return out;
  }();
  return spectra[spectral::led_type_index(type)];
}

std::vector<NamedIlluminant> relight_illuminants() {
  std::vector<NamedIlluminant> out;
  for (spectral::LedType t : spectral::kAllLedTypes) out.push_back({std::string(spectral::led_type_name(t)), led_spectrum(t)});
  out.push_back({"D65", spectral::illuminant_d65()});
  return out;
}

spectral::Spectrum led_d65_metamer() {
  const int first = 4, last = 64;  // 400-700 nm
  Eigen::MatrixXd a(last - first + 1, spectral::kLedTypeCount);
  Eigen::VectorXd b(last - first + 1);
  for (int i = first; i <= last; ++i) {
    for (int k = 0; k < spectral::kLedTypeCount; ++k) a(i - first, k) = led_spectrum(spectral::kAllLedTypes[k])[i];
    b(i - first) = spectral::illuminant_d65()[i];
  }
  // Projected gradient NNLS (six unknowns; converges in a few thousand cheap steps).
  const Eigen::MatrixXd ata = a.transpose().lazyProduct(a);  // lazy: avoids GCC 12's false AVX-512 GEMM warning
  const Eigen::VectorXd atb = a.transpose().lazyProduct(b);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(spectral::kLedTypeCount);
  const double step = 1.0 / ata.operatorNorm();
  for (int it = 0; it < 20000; ++it) x = (x - step * (ata * x - atb)).cwiseMax(0.0);
  spectral::Spectrum mix;
  for (int k = 0; k < spectral::kLedTypeCount; ++k) mix += x[k] * led_spectrum(spectral::kAllLedTypes[k]);
  return mix;
}

}  // namespace chromo::estimation
