#include "chromo/calibration/colour_rendering.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "chromo/calibration/planck.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/resample.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::calibration {
namespace {

TEST(Planck, MatchesWienDisplacementAndAKnownRadiance) {
  // Peak of the 3000 K black body at b/T, b = 2.897771955e-3 m·K.
  double best_nm = 0, best = 0;
  for (double nm = 900; nm < 1000; nm += 0.01)
    if (const double v = planck_radiance_W_per_m2_sr_nm(nm, 3000.0); v > best) best = v, best_nm = nm;
  EXPECT_NEAR(best_nm, 2.897771955e6 / 3000.0, 0.05);
  // 2hc²/λ⁵/(exp(hc/λkT)−1) at 560 nm, 5000 K, computed independently: 1.3395e4 W/m²/sr/µm... per nm:
  const double lambda = 560e-9, t = 5000;
  const double expected = 2 * 6.62607015e-34 * 299792458.0 * 299792458.0 / std::pow(lambda, 5) /
                          std::expm1(6.62607015e-34 * 299792458.0 / (lambda * 1.380649e-23 * t)) * 1e-9;
  EXPECT_NEAR(planck_radiance_W_per_m2_sr_nm(560, 5000) / expected, 1.0, 2e-4);
  EXPECT_THROW(planck_radiance_W_per_m2_sr_nm(560, 0), std::invalid_argument);
}

TEST(CorrelatedColourTemperature, RecoversPlanckianAndStandardIlluminants) {
  for (double t : {1500.0, 2856.0, 4000.0, 6500.0, 15000.0}) {
    const auto cct = correlated_colour_temperature(planckian_spectrum(t));
    EXPECT_NEAR(cct.cct_K, t, 1e-3 * t) << t;
    EXPECT_NEAR(cct.duv, 0.0, 1e-6);
  }
  EXPECT_NEAR(correlated_colour_temperature(spectral::illuminant_a()).cct_K, 2856, 2);
  const auto d65 = correlated_colour_temperature(spectral::illuminant_d65());
  EXPECT_NEAR(d65.cct_K, 6504, 4);
  EXPECT_NEAR(d65.duv, 0.0032, 0.0002);  // D65 sits above the Planckian locus
}

TEST(ColourRenderingIndex, ReferenceIlluminantsRenderPerfectly) {
  const ColourRendering a = colour_rendering_index(spectral::illuminant_a());
  EXPECT_NEAR(a.ra, 100.0, 0.1);
  for (double r : a.r) EXPECT_NEAR(r, 100.0, 0.1);
  EXPECT_NEAR(colour_rendering_index(spectral::illuminant_d65()).ra, 100.0, 0.1);
  EXPECT_TRUE(colour_rendering_index(spectral::illuminant_d65()).near_planckian_locus);
}

TEST(ColourRenderingIndex, CieLedIlluminantsMatchAnIndependentImplementation) {
  // Ra of CIE 015:2018 LED-B1..B5 from the issue (an independent implementation, 1 nm data).
  const spectral::Table table =
      spectral::parse_table(spectral::data::embedded_file("led_spectra.csv"), "data/led_spectra.csv");
  const std::pair<const char*, double> expected[] = {
      {"LED_B1", 81.8}, {"LED_B2", 82.8}, {"LED_B3", 84.8}, {"LED_B4", 76.8}, {"LED_B5", 80.2}};
  for (const auto& [column, ra] : expected)
    EXPECT_NEAR(colour_rendering_index(spectral::resample_column(table, column)).ra, ra, 0.05) << column;
}

TEST(ColourRenderingIndex, NarrowBandLightRendersBadlyAndIsFlaggedOffLocus) {
  spectral::Spectrum green;
  for (int i = 0; i < spectral::kGridSize; ++i)
    green[i] = std::exp(-0.5 * std::pow((spectral::grid_wavelength_nm(i) - 530.0) / 15.0, 2));
  const ColourRendering r = colour_rendering_index(green);
  EXPECT_LT(r.ra, 0.0);
  EXPECT_FALSE(r.near_planckian_locus);
  EXPECT_THROW(colour_rendering_index(spectral::Spectrum()), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::calibration
