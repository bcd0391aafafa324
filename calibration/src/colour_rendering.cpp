#include "chromo/calibration/colour_rendering.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "chromo/calibration/planck.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/colorimetry.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::calibration {
namespace {

const std::array<spectral::Spectrum, 14>& test_colour_samples() {
  static const std::array<spectral::Spectrum, 14> samples = [] {
    const spectral::Table table =
        spectral::parse_table(spectral::data::embedded_file("cie_tcs.csv"), "data/cie_tcs.csv");
    std::array<spectral::Spectrum, 14> s;
    for (int i = 0; i < 14; ++i) {
      const std::string name = (i < 9 ? "TCS0" : "TCS") + std::to_string(i + 1);
      s[i] = spectral::resample_column(table, name);
    }
    return s;
  }();
  return samples;
}

struct Cd {
  double c, d;
};
Cd cd_of(const Uv1960& uv) { return {(4.0 - uv.u - 10.0 * uv.v) / uv.v, (1.708 * uv.v + 0.404 - 1.481 * uv.u) / uv.v}; }

struct Uvw {
  double u, v, w;
};
Uvw uvw_1964(double y, const Uv1960& uv, const Uv1960& white) {
  const double w = 25.0 * std::cbrt(y) - 17.0;
  return {13.0 * w * (uv.u - white.u), 13.0 * w * (uv.v - white.v), w};
}

}  // namespace

ColourRendering colour_rendering_index(const spectral::Spectrum& light) {
  if (!(spectral::xyz_of_light(light).Y > 0.0))
    throw std::invalid_argument("colour rendering index: the light has no luminance");
  ColourRendering result;
  const CorrelatedColourTemperature cct = correlated_colour_temperature(light);
  result.cct_K = cct.cct_K;
  result.duv = cct.duv;
  result.near_planckian_locus = std::abs(cct.duv) < 5.4e-3;
  const spectral::Spectrum reference =
      cct.cct_K < 5000.0 ? planckian_spectrum(cct.cct_K)
                         : spectral::daylight_illuminant(std::clamp(cct.cct_K * 1.4380 / 1.4388, 4000.0, 25000.0));

  const Uv1960 test_white = uv_1960(spectral::white_point(light));
  const Uv1960 ref_white = uv_1960(spectral::white_point(reference));
  const Cd cd_k = cd_of(test_white), cd_r = cd_of(ref_white);
  double sum_r1_r8 = 0;
  for (int i = 0; i < 14; ++i) {
    const spectral::Xyz xyz_r = spectral::xyz_of_reflectance(test_colour_samples()[i], reference);
    const spectral::Xyz xyz_k = spectral::xyz_of_reflectance(test_colour_samples()[i], light);
    const Cd cd_ki = cd_of(uv_1960(xyz_k));
    const double cc = cd_r.c / cd_k.c * cd_ki.c, dd = cd_r.d / cd_k.d * cd_ki.d;
    const double denominator = 16.518 + 1.481 * cc - dd;
    const Uv1960 adapted{(10.872 + 0.404 * cc - 4.0 * dd) / denominator, 5.520 / denominator};
    const Uvw ref = uvw_1964(xyz_r.Y, uv_1960(xyz_r), ref_white);
    const Uvw test = uvw_1964(xyz_k.Y, adapted, ref_white);
    const double delta_e = std::sqrt((ref.u - test.u) * (ref.u - test.u) + (ref.v - test.v) * (ref.v - test.v) +
                                     (ref.w - test.w) * (ref.w - test.w));
    result.r[i] = 100.0 - 4.6 * delta_e;
    if (i < 8) sum_r1_r8 += result.r[i];
  }
  result.ra = sum_r1_r8 / 8.0;
  return result;
}

}  // namespace chromo::calibration
