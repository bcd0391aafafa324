#include "chromo/spectral/delta_e.hpp"

#include <gtest/gtest.h>

#include "chromo/spectral/table.hpp"

using namespace chromo::spectral;

namespace {

TEST(DeltaE00, SharmaWuDalal34TestPairs) {
  const Table t = read_table(CHROMO_TEST_DATA_DIR "/sharma_ciede2000.csv");
  ASSERT_EQ(t.rows(), 34u);
  for (std::size_t i = 0; i < t.rows(); ++i) {
    const Lab lab1{t.column("L1")[i], t.column("a1")[i], t.column("b1")[i]};
    const Lab lab2{t.column("L2")[i], t.column("a2")[i], t.column("b2")[i]};
    const double expected = t.column("dE00")[i];
    EXPECT_NEAR(delta_e00(lab1, lab2), expected, 1e-4) << "pair " << i + 1;
    EXPECT_NEAR(delta_e00(lab2, lab1), expected, 1e-4) << "pair " << i + 1 << " swapped";
  }
}

TEST(DeltaE94, HandWorkedGraphicArts) {
  // Reference (60, 20, 30), sample (55, 25, 20):
  // C*ref = 36.0555, C*sample = 32.0156, ΔC = 4.0399, ΔL = 5,
  // ΔH² = Δa² + Δb² - ΔC² = 125 - 16.3208 = 108.679,
  // SC = 1 + 0.045·36.0555 = 2.62250, SH = 1 + 0.015·36.0555 = 1.54083,
  // ΔE94 = sqrt(25 + (4.0399/2.6225)² + 108.679/1.54083²) = 8.55271.
  EXPECT_NEAR(delta_e94({60, 20, 30}, {55, 25, 20}), 8.55271, 1e-5);
  // Swapped, the reference's C* is 32.0156: a different number.
  EXPECT_NEAR(delta_e94({55, 25, 20}, {60, 20, 30}), 8.79433, 1e-5);
  // Sharma pair 1 as a ΔE94 pair: 1.39504 one way, 1.36529 the other.
  EXPECT_NEAR(delta_e94({50, 2.6772, -79.7751}, {50, 0, -82.7485}), 1.39504, 1e-5);
  EXPECT_NEAR(delta_e94({50, 0, -82.7485}, {50, 2.6772, -79.7751}), 1.36529, 1e-5);
}

TEST(DeltaE94, IdenticalColoursAndPureLightnessDifference) {
  EXPECT_DOUBLE_EQ(delta_e94({50, 10, 10}, {50, 10, 10}), 0.0);
  EXPECT_DOUBLE_EQ(delta_e94({50, 10, 10}, {47, 10, 10}), 3.0);
  EXPECT_DOUBLE_EQ(delta_e76({50, 0, 0}, {53, 4, 0}), 5.0);
}

}  // namespace
