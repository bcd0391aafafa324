#include "chromo/calibration/response_calibration.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "chromo/calibration/planck.hpp"
#include "chromo/spectral/cie.hpp"

namespace chromo::calibration {
namespace {

// A spectrometer with a bell-shaped response, pixels every 0.47 nm.
struct SimulatedSpectrometer {
  std::vector<double> wavelength_nm;
  double response(double nm) const { return 1000.0 * std::exp(-0.5 * std::pow((nm - 520.0) / 110.0, 2)); }
  SimulatedSpectrometer() {
    for (double nm = 300.0; nm <= 880.0; nm += 0.47) wavelength_nm.push_back(nm);
  }
  template <typename Source>
  std::vector<double> counts(Source source) const {
    std::vector<double> c;
    for (double nm : wavelength_nm) c.push_back(response(nm) * source(nm));
    return c;
  }
};

TEST(SpectralResponseCorrection, RecoversTheLampAndThenAnyOtherSource) {
  const SimulatedSpectrometer spectrometer;
  const auto lamp = [](double nm) { return 7.0 * planck_radiance_W_per_m2_sr_nm(nm, 3100.0); };
  const SpectralResponseCorrection correction =
      spectral_response_correction(spectrometer.wavelength_nm, spectrometer.counts(lamp), 3100.0);
  // Corrected lamp = Planck's shape, 1 at 560 nm... up to the constant the normalisation picks.
  const std::vector<double> corrected = correction.apply(spectrometer.counts(lamp));
  const std::vector<double> source_counts = spectrometer.counts([](double nm) { return 2.0 + std::sin(nm / 40.0); });
  const std::vector<double> source = correction.apply(source_counts);
  std::size_t usable = 0, i560 = 0;
  while (spectrometer.wavelength_nm[i560] < 560.0) ++i560;
  for (std::size_t i = 0; i < corrected.size(); ++i) {
    if (!correction.usable[i]) {
      EXPECT_EQ(correction.correction[i], 0.0);
      continue;
    }
    ++usable;
    const double nm = spectrometer.wavelength_nm[i];
    EXPECT_NEAR(corrected[i] / corrected[i560],
                planck_radiance_W_per_m2_sr_nm(nm, 3100.0) / planck_radiance_W_per_m2_sr_nm(spectrometer.wavelength_nm[i560], 3100.0),
                1e-9);
    EXPECT_NEAR(source[i] / source[i560], (2.0 + std::sin(nm / 40.0)) / (2.0 + std::sin(spectrometer.wavelength_nm[i560] / 40.0)),
                1e-9);
  }
  // The lamp's counts fall below 1% of their peak far out in the wings: those pixels are flagged.
  EXPECT_LT(usable, corrected.size());
  EXPECT_GT(usable, corrected.size() * 9 / 10);
  EXPECT_NEAR(correction_on_grid(correction)[36], 1.0, 1e-3);  // 560 nm on the grid
}

TEST(SpectralResponseCorrection, RefusesBadInputNamingIt) {
  const std::vector<double> nm{500, 550, 600}, counts{1, 2, 3};
  EXPECT_THROW(spectral_response_correction(nm, {1, 2}, 3000), std::invalid_argument);
  EXPECT_THROW(spectral_response_correction({500, 500, 600}, counts, 3000), std::invalid_argument);
  EXPECT_THROW(spectral_response_correction({400, 450, 500}, counts, 3000), std::invalid_argument);  // no 560 nm
  EXPECT_THROW(spectral_response_correction(nm, counts, -1), std::invalid_argument);
  EXPECT_THROW(spectral_response_correction(nm, {1, 0, 3}, 3000, 0.5), std::invalid_argument);  // dark at 560
  try {
    spectral_response_correction(nm, counts, 0);
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "spectral response calibration: lamp temperature must be positive");
  }
  const auto ok = spectral_response_correction(nm, counts, 3000);
  EXPECT_THROW(ok.apply({1, 2}), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::calibration
