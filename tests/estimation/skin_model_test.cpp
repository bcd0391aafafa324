#include "chromo/estimation/skin_model.hpp"

#include "chromo/estimation/layer_optics.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

using namespace chromo::estimation;
using chromo::spectral::kGridSize;
using chromo::spectral::Spectrum;
using ::testing::HasSubstr;

namespace {

int index_of(double nm) { return static_cast<int>((nm - 380.0) / 5.0); }

TEST(SkinModel, MatchesAnIndependentTermByTermEvaluation) {
  // Python evaluation of MODEL.md with the explicit multipole sum (i = -200..200),
  // Cm = 0.05, Ch = 0.03, βm = 0.7, Che = 0.01: (R1, T1, R2, albedo).
  struct Row {
    double nm, r1, t1, r2, albedo;
  };
  const Row rows[] = {
      {450, 0.11749607639925971, 0.02977078030394738, 0.22806627046062566, 0.11770377712262457},
      {550, 0.1387616293181559, 0.1613466607943944, 0.24636914383749464, 0.14540231682306431},
      {650, 0.15842692719425058, 0.36355364520299266, 0.6629794991173049, 0.25633769918296734},
  };
  const SkinModel model;
  const LayerSpectra layers = model.layers({0.05, 0.03, 0.7, 0.01});
  for (const Row& r : rows) {
    const int i = index_of(r.nm);
    EXPECT_NEAR(layers.epidermis_reflectance[i], r.r1, 1e-10) << r.nm;
    EXPECT_NEAR(layers.epidermis_transmittance[i], r.t1, 1e-10) << r.nm;
    EXPECT_NEAR(layers.dermis_reflectance[i], r.r2, 1e-10) << r.nm;
    EXPECT_NEAR(layers.albedo[i], r.albedo, 1e-10) << r.nm;
  }
}

TEST(SkinModel, VectorisedModelEqualsTheScalarLayerOpticsAtEveryWavelength) {
  // The grid-wide Eigen evaluation against layer_optics.hpp's scalar slab,
  // dipole and combination (which find each pole family's sign change with a
  // general ceil), over the corners and middle of the parameter box.
  const SkinModel model;
  const ChromophoreSpectra& k = chromophore_spectra();
  const double a_skin = boundary_coefficient(kSkinRefractiveIndex);
  for (const SkinParameters p : {SkinParameters{0.001, 0.001, 0.0, 0.0}, SkinParameters{0.5, 0.32, 1.0, 0.1},
                                 SkinParameters{0.12, 0.05, 0.4, 0.06}, SkinParameters{0.5, 0.001, 0.0, 0.1}}) {
    const Spectrum albedo = model.albedo(p);
    for (int i = 0; i < kGridSize; ++i) {
      const double sa_epi = p.cm * (p.bm * k.sigma_a_eumelanin[i] + (1 - p.bm) * k.sigma_a_pheomelanin[i]) +
                            p.che * k.sigma_a_blood[i] + (1 - p.cm - p.che) * k.sigma_a_baseline[i];
      const double sa_derm = p.ch * k.sigma_a_blood[i] + (1 - p.ch) * k.sigma_a_baseline[i];
      const SlabReflectance epi =
          multipole_slab(sa_epi, k.sigma_s_reduced_epidermis[i], kEpidermisThicknessMm, a_skin, kIndexMatchedA);
      const double r2 = dipole_semi_infinite(sa_derm, k.sigma_s_reduced_dermis[i]);
      EXPECT_NEAR(albedo[i], combine_two_layers(epi.reflectance, epi.transmittance, r2), 1e-13) << i;
    }
  }
}

TEST(SkinModel, AlbedoIsInsideZeroOneAcrossTheWholeParameterBox) {
  const SkinModel model;
  for (double cm : {kCmRange.min, 0.05, 0.2, kCmRange.max})
    for (double ch : {kChRange.min, 0.05, kChRange.max})
      for (double bm : {0.0, 0.7, 1.0})
        for (double che : {0.0, 0.05, kCheRange.max}) {
          const Spectrum a = model.albedo({cm, ch, bm, che});
          EXPECT_GT(a.min(), 0.0) << cm << " " << ch << " " << bm << " " << che;
          EXPECT_LT(a.max(), 1.0) << cm << " " << ch << " " << bm << " " << che;
        }
}

TEST(SkinModel, AlbedoAt550FallsAsMelaninOrBloodRises) {
  const SkinModel model;
  const int i550 = index_of(550);
  double previous = 1.0;
  for (double cm = 0.001; cm <= 0.5; cm += 0.05) {
    const double a = model.albedo({cm, 0.03, 0.7, 0.0})[i550];
    EXPECT_LT(a, previous) << "Cm " << cm;
    previous = a;
  }
  previous = 1.0;
  for (double ch = 0.001; ch <= 0.32; ch += 0.03) {
    const double a = model.albedo({0.05, ch, 0.7, 0.0})[i550];
    EXPECT_LT(a, previous) << "Ch " << ch;
    previous = a;
  }
}

TEST(SkinModel, BatchEqualsSingleEvaluationBitForBit) {
  const SkinModel model;
  std::vector<SkinParameters> parameters;
  for (int i = 0; i < 500; ++i) parameters.push_back({0.001 + 0.001 * i, 0.001 + 0.0006 * i, (i % 11) / 10.0, (i % 7) / 70.0});
  std::vector<Spectrum> batch(parameters.size());
  model.albedo_batch(parameters, batch, 2);
  for (std::size_t i = 0; i < parameters.size(); i += 37) {
    const Spectrum single = model.albedo(parameters[i]);
    for (int k = 0; k < kGridSize; ++k) ASSERT_EQ(batch[i][k], single[k]) << i << " " << k;
  }
  std::vector<Spectrum> too_small(3);
  EXPECT_THROW(model.albedo_batch(parameters, too_small), std::invalid_argument);
}

TEST(SkinModel, NonFiniteParametersGiveNonFiniteAlbedoNotACrash) {
  const SkinModel model;
  const Spectrum a = model.albedo({std::numeric_limits<double>::quiet_NaN(), 0.03, 0.7, 0.0});
  EXPECT_TRUE(std::isnan(a[40]));
}

TEST(SkinParameters, RangeViolationNamesParameterAndRange) {
  EXPECT_FALSE(range_violation({0.05, 0.03, 0.7, 0.0}).has_value());
  EXPECT_FALSE(range_violation({0.5, 0.32, 1.0, 0.1}).has_value());
  EXPECT_THAT(*range_violation({0.6, 0.03, 0.7, 0.0}), HasSubstr("Cm = 0.6 is outside its range 0.001-0.5"));
  EXPECT_THAT(*range_violation({0.05, 0.0, 0.7, 0.0}), HasSubstr("Ch = 0 is outside its range 0.001-0.32"));
  EXPECT_THAT(*range_violation({0.05, 0.03, 1.5, 0.0}), HasSubstr("βm = 1.5 is outside its range 0-1"));
  EXPECT_THAT(*range_violation({0.05, 0.03, 0.7, -0.01}), HasSubstr("Che = -0.01 is outside its range 0-0.1"));
  EXPECT_TRUE(range_violation({0.05, std::nan(""), 0.7, 0.0}).has_value());
}

}  // namespace
