// Polarisers and skin's surface layer in the virtual lab
// (docs/polarisation.md, "Virtual lab physics"): exact Fresnel at η = 1.4,
// the films' spectral extinction and transmission, and what cross and
// parallel captures keep of a surface reflection.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "chromo/simulators/polarisation/polariser_optics.hpp"
#include "chromo/simulators/polarisation/skin_surface.hpp"

namespace chromo::simulators {
namespace {

using drivers::Polarisation;

int grid_index_nm(double wavelength_nm) {
  return static_cast<int>(std::lround((wavelength_nm - spectral::kGridStartNm) / spectral::kGridStepNm));
}

TEST(SkinSurface, ExactFresnelAtTheSkinsIndex) {
  // Normal incidence: ((η − 1)/(η + 1))².
  EXPECT_NEAR(fresnel_reflectance_unpolarised(kSkinRefractiveIndex, 0), std::pow(0.4 / 2.4, 2), 1e-15);
  EXPECT_NEAR(fresnel_reflectance_unpolarised(kSkinRefractiveIndex, 0), 0.027778, 1e-6);
  // Brewster's angle: r_p = 0, r_s = (1 − η²)/(1 + η²).
  const double brewster = std::atan(kSkinRefractiveIndex);
  EXPECT_NEAR(fresnel_reflectance_unpolarised(kSkinRefractiveIndex, brewster), 0.5 * std::pow(0.96 / 2.96, 2), 1e-12);
  // The lab's second camera (20 degrees) sees almost the normal sheen; grazing views see much more.
  EXPECT_NEAR(fresnel_reflectance_unpolarised(kSkinRefractiveIndex, 20 * std::numbers::pi / 180), 0.0279, 2e-4);
  EXPECT_GT(fresnel_reflectance_unpolarised(kSkinRefractiveIndex, 80 * std::numbers::pi / 180), 0.3);
  EXPECT_THROW(fresnel_reflectance_unpolarised(kSkinRefractiveIndex, std::numbers::pi / 2), std::invalid_argument);
  EXPECT_THROW(fresnel_reflectance_unpolarised(0, 0), std::invalid_argument);
}

TEST(PolariserFilm, WeakerInTheBlueAndBelowUnitTransmission) {
  const PolariserFilm film;  // defaults: 1:200 at 550 nm, 1:20 at 400 nm, 0.42 / 0.30
  EXPECT_NEAR(film.extinction_ratio_at(550), 200, 1e-9);
  EXPECT_NEAR(film.extinction_ratio_at(700), 200, 1e-9);
  EXPECT_NEAR(film.extinction_ratio_at(400), 20, 1e-9);
  EXPECT_NEAR(film.extinction_ratio_at(475), std::sqrt(200.0 * 20.0), 1e-9);  // log-linear
  const spectral::Spectrum k1 = film.axis_transmittance(), k2 = film.cross_transmittance();
  for (double nm : {400.0, 475.0, 550.0, 700.0}) {
    const int i = grid_index_nm(nm);
    EXPECT_NEAR(0.5 * (k1[i] + k2[i]), film.transmission_at(nm), 1e-12) << nm;
    EXPECT_NEAR(k1[i] / k2[i], film.extinction_ratio_at(nm), 1e-9) << nm;
    EXPECT_LT(k1[i], 1.0);
  }
  EXPECT_NEAR(film.transmission_at(550), 0.42, 1e-12);
  EXPECT_NEAR(film.transmission_at(400), 0.30, 1e-12);
  PolariserFilm bad;
  bad.extinction_ratio_550nm = 0.5;
  std::string error;
  EXPECT_FALSE(bad.IsValid(&error));
  EXPECT_NE(error.find("extinction"), std::string::npos);
  EXPECT_THROW(surface_factor_in_albedo(Polarisation::kCross, bad, PolariserFilm{}, 0), std::invalid_argument);
  EXPECT_THROW(surface_factor_in_albedo(Polarisation::kCross, film, film, 1.5), std::invalid_argument);
}

// A highlight pixel: diffuse albedo 0.4 (after the white reference of its
// state) under a surface layer of sheen 0.0278 plus an oily highlight 0.05.
TEST(PolarisedCapture, CrossIsDiffuseOnlyWithinTheExtinctionLeakAndParallelMinusCrossIsTheSurface) {
  const PolariserFilm film;
  const double diffuse = 0.4, surface = fresnel_reflectance_unpolarised(kSkinRefractiveIndex, 0) + 0.05;
  const spectral::Spectrum cross = surface_factor_in_albedo(Polarisation::kCross, film, film, 0);
  const spectral::Spectrum parallel = surface_factor_in_albedo(Polarisation::kParallel, film, film, 0);
  const spectral::Spectrum unpolarised = surface_factor_in_albedo(Polarisation::kUnpolarised, film, film, 0);
  for (int i = 0; i < spectral::kGridSize; ++i) {
    const double er = film.extinction_ratio_at(spectral::grid_wavelength_nm(i));
    // Identical films, crossed exactly: c_cross = 4·ER/(1 + ER)², c_parallel = 2·(1 + ER²)/(1 + ER)².
    EXPECT_NEAR(cross[i], 4 * er / std::pow(1 + er, 2), 1e-12) << i;
    EXPECT_NEAR(parallel[i], 2 * (1 + er * er) / std::pow(1 + er, 2), 1e-12) << i;
    EXPECT_NEAR(unpolarised[i], 0.5 * (cross[i] + parallel[i]), 1e-12);
    const double cross_capture = diffuse + cross[i] * surface;
    EXPECT_LE(cross_capture - diffuse, 4.0 / er * surface) << i;  // within the extinction leak
  }
  const int at_550 = grid_index_nm(550), at_400 = grid_index_nm(400);
  // At 550 nm (1:200) the cross capture keeps 1.98% of the surface layer ...
  EXPECT_NEAR(cross[at_550], 0.0198, 1e-4);
  EXPECT_NEAR(diffuse + cross[at_550] * surface, diffuse, 0.0016);
  // ... and (parallel − cross)/2 is the surface layer within 2% (1.96/2).
  EXPECT_NEAR((parallel[at_550] - cross[at_550]) * surface / 2, surface, 0.02 * surface);
  // In the blue (1:20) the cross capture keeps 0.181 of the surface layer and (parallel − cross)/2 is 18% short.
  EXPECT_NEAR(cross[at_400], 80.0 / 441.0, 1e-9);
  EXPECT_NEAR((parallel[at_400] - cross[at_400]) / 2, 361.0 / 441.0, 1e-9);
}

TEST(PolarisedCapture, AViewThatIsNotTheDesignViewKeepsItsGeometricLeakOfTheDifference) {
  const PolariserFilm film;
  const int at_550 = grid_index_nm(550);
  const double crossed = surface_factor_in_albedo(Polarisation::kCross, film, film, 0)[at_550];
  const double aligned = surface_factor_in_albedo(Polarisation::kParallel, film, film, 0)[at_550];
  for (double leak : {0.01, 0.05, 0.2}) {
    const double cross = surface_factor_in_albedo(Polarisation::kCross, film, film, leak)[at_550];
    const double parallel = surface_factor_in_albedo(Polarisation::kParallel, film, film, leak)[at_550];
    // A leak f moves f of the difference from the parallel to the cross capture ...
    EXPECT_NEAR(cross, crossed + leak * (aligned - crossed), 1e-12) << leak;
    EXPECT_NEAR(parallel, aligned - leak * (aligned - crossed), 1e-12) << leak;
    // ... so the cross capture of camera 1 keeps about 2f of the surface layer in albedo units.
    EXPECT_NEAR(cross - crossed, 2 * leak, 0.03 * 2 * leak) << leak;
  }
}

}  // namespace
}  // namespace chromo::simulators
