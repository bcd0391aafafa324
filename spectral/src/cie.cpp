#include "chromo/spectral/cie.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <string>

#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::spectral {
namespace {

Table embedded_table(std::string_view name) {
  return parse_table(data::embedded_file(name), "data/" + std::string(name));
}

Spectrum embedded_spectrum(std::string_view file, std::string_view column) {
  return resample_column(embedded_table(file), column);
}

}  // namespace

const Observer& cie1931_observer() {
  static const Observer observer = [] {
    Table t = embedded_table("cie1931_2deg_cmf.csv");
    return Observer{resample_column(t, "x_bar"), resample_column(t, "y_bar"), resample_column(t, "z_bar")};
  }();
  return observer;
}

const Spectrum& illuminant_d65() {
  static const Spectrum s = embedded_spectrum("cie_d65.csv", "S_D65");
  return s;
}
const Spectrum& blue_light_hazard_weighting() {
  static const Spectrum s = embedded_spectrum("blue_light_hazard_iec62471.csv", "B");
  return s;
}
const Spectrum& illuminant_d50() {
  static const Spectrum s = embedded_spectrum("cie_d50.csv", "S_D50");
  return s;
}
const Spectrum& illuminant_a() {
  static const Spectrum s = embedded_spectrum("cie_a.csv", "S_A");
  return s;
}

Spectrum daylight_illuminant(double cct_K) {
  if (!(cct_K >= 4000.0 && cct_K <= 25000.0))
    throw DataError("daylight CCT " + std::to_string(cct_K) + " K is outside the CIE daylight range 4000-25000 K");
  static const Table basis = embedded_table("cie_daylight_components.csv");
  // CIE 15:2004 eq. 3.3/3.4: chromaticity of daylight at the CCT.
  const double t = cct_K, t2 = t * t, t3 = t2 * t;
  const double xd = cct_K <= 7000.0 ? -4.6070e9 / t3 + 2.9678e6 / t2 + 0.09911e3 / t + 0.244063
                                    : -2.0064e9 / t3 + 1.9018e6 / t2 + 0.24748e3 / t + 0.237040;
  const double yd = -3.000 * xd * xd + 2.870 * xd - 0.275;
  const double m = 0.0241 + 0.2562 * xd - 0.7341 * yd;
  const double m1 = (-1.3515 - 1.7703 * xd + 5.9114 * yd) / m;
  const double m2 = (0.0300 - 31.4424 * xd + 30.0717 * yd) / m;
  Spectrum s = resample_column(basis, "S0") + m1 * resample_column(basis, "S1") + m2 * resample_column(basis, "S2");
  const int index_560 = static_cast<int>((560.0 - kGridStartNm) / kGridStepNm);
  return s * (100.0 / s[index_560]);
}

Spectrum illuminant_by_name_or_file(std::string_view name_or_path) {
  std::string lower(name_or_path);
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  if (lower == "d65") return illuminant_d65();
  if (lower == "d50") return illuminant_d50();
  if (lower == "a") return illuminant_a();
  if (lower.size() >= 4 && lower.substr(lower.size() - 4) == ".csv") return read_spectrum_file(std::string(name_or_path));
  throw DataError("unknown illuminant '" + std::string(name_or_path) + "' (expected d65, d50, a or a .csv file)");
}

}  // namespace chromo::spectral
