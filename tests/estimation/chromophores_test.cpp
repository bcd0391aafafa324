#include "chromo/estimation/chromophores.hpp"

#include <gtest/gtest.h>

#include "chromo/estimation/layer_optics.hpp"

using namespace chromo::estimation;

namespace {

// Values worked from MODEL.md's formulas (an independent Python evaluation,
// digits as printed by repr()).
TEST(Chromophores, CoefficientsAtChosenWavelengths) {
  struct Row {
    double nm, eumelanin, pheomelanin, baseline, sigma_s_epi, sigma_s_derm;
  };
  const Row rows[] = {
      {400, 142.7855189861344, 126.65228778807402, 0.23194175656714505, 12.538725273210403, 6.2693626366052015},
      {500, 67.9162692041523, 43.88241065774736, 0.07022173481200876, 7.275987018393602, 3.637993509196801},
      {650, 28.34930771212457, 12.620005780844819, 0.02915357758611653, 4.777778860067528, 2.388889430033764},
  };
  for (const Row& r : rows) {
    EXPECT_NEAR(sigma_a_eumelanin_per_mm(r.nm), r.eumelanin, 1e-12 * r.eumelanin) << r.nm;
    EXPECT_NEAR(sigma_a_pheomelanin_per_mm(r.nm), r.pheomelanin, 1e-12 * r.pheomelanin) << r.nm;
    EXPECT_NEAR(sigma_a_baseline_per_mm(r.nm), r.baseline, 1e-12 * r.baseline) << r.nm;
    EXPECT_NEAR(sigma_s_reduced_epidermis_per_mm(r.nm), r.sigma_s_epi, 1e-12 * r.sigma_s_epi) << r.nm;
    EXPECT_NEAR(sigma_s_reduced_dermis_per_mm(r.nm), r.sigma_s_derm, 1e-12 * r.sigma_s_derm) << r.nm;
  }
  // The unit trap: Jacques' cm^-1 constants are ten times these.
  EXPECT_NEAR(sigma_a_eumelanin_per_mm(500) * 10, 6.6e11 * std::pow(500.0, -3.33), 1e-9);
}

TEST(Chromophores, BloodFromPrahlsTableBinAveraged) {
  // ε at 2 nm; each 5 nm bin averages 3 (or 2) samples. 500 nm bin: 498, 500,
  // 502 nm → HbO2 mean 20930.67 cm^-1/M → 2.303·ε·150/64500/10 mm^-1.
  const ChromophoreSpectra& s = chromophore_spectra();
  const int i420 = (420 - 380) / 5, i500 = (500 - 380) / 5, i560 = (560 - 380) / 5;
  EXPECT_NEAR(s.sigma_a_oxy_blood[i420], 254.8938976744186, 1e-9);
  EXPECT_NEAR(s.sigma_a_deoxy_blood[i420], 218.3601054263566, 1e-9);
  EXPECT_NEAR(s.sigma_a_blood[i420], 245.76044961240308, 1e-9);
  EXPECT_NEAR(s.sigma_a_oxy_blood[i500], 11.209575782945738, 1e-9);
  EXPECT_NEAR(s.sigma_a_deoxy_blood[i560], 28.605045271317827, 1e-9);
  EXPECT_NEAR(s.sigma_a_blood[i560], 20.365286178294575, 1e-9);
  EXPECT_NEAR(blood_sigma_a_per_mm(64500.0), 2.303 * 150.0 / 10.0, 1e-12);
}

TEST(Chromophores, BoundaryCoefficients) {
  EXPECT_NEAR(diffuse_fresnel_reflectance(1.4), 0.5294889795918367, 1e-15);
  EXPECT_NEAR(boundary_coefficient(1.4), 3.250697461379377, 1e-12);
  EXPECT_EQ(kIndexMatchedA, 1.0);
  // Why MODEL.md pins A = 1 rather than evaluating the fit at η = 1:
  EXPECT_NEAR(boundary_coefficient(1.0), 1.0032, 1e-4);
}

}  // namespace
