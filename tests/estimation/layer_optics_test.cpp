#include "chromo/estimation/layer_optics.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "chromo/estimation/chromophores.hpp"

using namespace chromo::estimation;

namespace {

TEST(Multipole, ClosedFormEqualsTheConvergedExplicitSum) {
  const double a_skin = boundary_coefficient(1.4);
  int worst_pairs = 0;
  double worst_difference = 0;
  // σa from nearly transparent to strongly absorbing, σs' across the skin range.
  for (double sigma_a : {0.01, 0.05, 0.2, 1.0, 5.0, 20.0, 80.0}) {
    for (double sigma_s : {2.0, 4.0, 8.0, 15.0}) {
      for (double d : {0.05, 0.25, 1.0}) {
        int pairs = 0;
        const SlabReflectance explicit_sum = multipole_slab_explicit(sigma_a, sigma_s, d, a_skin, 1.0, 1e-9, &pairs);
        const SlabReflectance closed = multipole_slab(sigma_a, sigma_s, d, a_skin, 1.0);
        worst_difference = std::max({worst_difference, std::abs(explicit_sum.reflectance - closed.reflectance),
                                     std::abs(explicit_sum.transmittance - closed.transmittance)});
        worst_pairs = std::max(worst_pairs, pairs);
        // Physical only where the source depth l = 1/σt' lies inside the
        // slab; outside that the pinned formulas give T < 0 (MODEL.md: near
        // 780 nm the epidermis is barely one transport length thick).
        if (1.0 / (sigma_a + sigma_s) < d) {
          EXPECT_GT(closed.reflectance, 0.0);
          EXPECT_GT(closed.transmittance, 0.0);
          EXPECT_LT(closed.reflectance + closed.transmittance, 1.0);
        }
      }
    }
  }
  // The explicit sum stops when a pair adds < 1e-9; the tail left over is of
  // the same order.
  EXPECT_LT(worst_difference, 1e-8);
  // "A few tens of pairs at most" (MODEL.md) for the skin's thin epidermis;
  // only the nearly transparent 0.05 mm slab needs more.
  EXPECT_LE(worst_pairs, 2000);
  int skin_pairs = 0;
  multipole_slab_explicit(0.2, 8.0, 0.25, a_skin, 1.0, 1e-9, &skin_pairs);
  EXPECT_LE(skin_pairs, 40);
}

TEST(Multipole, ThickSlabTendsToTheSemiInfiniteDipole) {
  // d → ∞: R tends to the classical dipole with the same boundary (A = 3.25)
  // and T vanishes.
  const double a_skin = boundary_coefficient(1.4);
  const double sigma_a = 0.5, sigma_s = 5.0;
  const SlabReflectance thick = multipole_slab(sigma_a, sigma_s, 50.0, a_skin, 1.0);
  const double sigma_t = sigma_a + sigma_s, alpha = sigma_s / sigma_t;
  const double sigma_tr = std::sqrt(3 * sigma_a * sigma_t), l = 1 / sigma_t, zb = 2 * a_skin / (3 * sigma_t);
  const double dipole = 0.5 * alpha * (std::exp(-sigma_tr * l) + std::exp(-sigma_tr * (l + 2 * zb)));
  EXPECT_NEAR(thick.reflectance, dipole, 1e-12);
  EXPECT_LT(thick.transmittance, 1e-12);
  // And the plane-integrated dipole matches MODEL.md's closed form with A.
  const double root = std::sqrt(3 * (1 - alpha));
  EXPECT_NEAR(dipole, 0.5 * alpha * (1 + std::exp(-(4.0 / 3.0) * a_skin * root)) * std::exp(-root), 1e-12);
  EXPECT_NEAR(dipole_semi_infinite(sigma_a, sigma_s, a_skin), dipole, 1e-12);
}

TEST(Multipole, ThinSlabTransmitsMoreThanThickAndLessAbsorptionReflectsMore) {
  const double a = boundary_coefficient(1.4);
  EXPECT_GT(multipole_slab(1.0, 8.0, 0.2, a, 1.0).transmittance, multipole_slab(1.0, 8.0, 0.4, a, 1.0).transmittance);
  EXPECT_GT(multipole_slab(0.5, 8.0, 0.25, a, 1.0).reflectance, multipole_slab(2.0, 8.0, 0.25, a, 1.0).reflectance);
}

TEST(TwoLayers, CombinationFormula) {
  EXPECT_DOUBLE_EQ(combine_two_layers(0.1, 0.5, 0.4), 0.1 + 0.5 * 0.4 * 0.5 / (1 - 0.04));
  EXPECT_DOUBLE_EQ(combine_two_layers(0.2, 0.0, 0.9), 0.2);
}

}  // namespace
