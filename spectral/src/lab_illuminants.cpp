#include "chromo/spectral/lab_illuminants.hpp"

#include <Eigen/Dense>
#include <array>

#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::spectral {

const Spectrum& led_spectrum(LedType type) {
  static const std::array<Spectrum, kLedTypeCount> spectra = [] {
    constexpr std::array<const char*, kLedTypeCount> kFiles{
        "led_spectra_measured/LCFOCUS_LC_10FS504_G24.csv", "led_spectra_measured/LCFOCUS_LC_10FSCOB1917_4000.csv",
        "led_spectra_measured/Nichia_NS6L183AT_H1_sw.csv", "led_spectra_measured/LedEngin_LZ7_N4M100_ch_B_Red.csv",
        "led_spectra_measured/LedEngin_LZ7_N4M100_ch_A_Green.csv",
        "led_spectra_measured/LedEngin_LZ7_N4M100_ch_C_Blue.csv"};
    std::array<Spectrum, kLedTypeCount> out;
    for (int i = 0; i < kLedTypeCount; ++i) {
      const Table table = parse_table(data::embedded_file(kFiles[i]), kFiles[i]);
      out[i] = resample_column(table, table.column_names.at(1), OutsideRange::kZero);
    }
    return out;
  }();
  return spectra[led_type_index(type)];
}

std::vector<NamedIlluminant> relight_illuminants() {
  std::vector<NamedIlluminant> out;
  for (LedType t : kAllLedTypes) out.push_back({std::string(led_type_name(t)), led_spectrum(t)});
  out.push_back({"D65", illuminant_d65()});
  return out;
}

Spectrum led_d65_metamer() {
  const int first = 4, last = 64;  // 400-700 nm
  Eigen::MatrixXd a(last - first + 1, kLedTypeCount);
  Eigen::VectorXd b(last - first + 1);
  for (int i = first; i <= last; ++i) {
    for (int k = 0; k < kLedTypeCount; ++k) a(i - first, k) = led_spectrum(kAllLedTypes[k])[i];
    b(i - first) = illuminant_d65()[i];
  }
  // Projected gradient NNLS (six unknowns; converges in a few thousand cheap steps).
  const Eigen::MatrixXd ata = a.transpose().lazyProduct(a);  // lazy: avoids GCC 12's false AVX-512 GEMM warning
  const Eigen::VectorXd atb = a.transpose().lazyProduct(b);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(kLedTypeCount);
  const double step = 1.0 / ata.operatorNorm();
  for (int it = 0; it < 20000; ++it) x = (x - step * (ata * x - atb)).cwiseMax(0.0);
  Spectrum mix;
  for (int k = 0; k < kLedTypeCount; ++k) mix += x[k] * led_spectrum(kAllLedTypes[k]);
  return mix;
}

}  // namespace chromo::spectral
