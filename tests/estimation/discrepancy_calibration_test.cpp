// The discrepancy's scale by nested cross-validation inside its own training
// subjects (estimation/discrepancy_calibration.hpp, issue 37): on the shipped
// NIST residuals the held-out subjects' distances are heavy-tailed (subject
// 006 the farthest) while their bulk is within the learned covariance, and
// bad options are refused naming what was wrong.
#include "chromo/estimation/discrepancy_calibration.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include "chromo/estimation/measurement.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::estimation {
namespace {

Eigen::MatrixXd method_weights() {
  const spectral::CameraSensitivity camera = spectral::builtin_camera("nikon_d5100");
  return method_measurement_set(camera, spectral::led_d65_metamer(), spectral::led_spectrum(spectral::LedType::kBlue))
      .weights();
}

TEST(DiscrepancyCalibration, HeldOutDistancesAreHeavyTailedWithSubject006Farthest) {
  const auto d = ModelDiscrepancy::standard();
  const DiscrepancyCalibration median = calibrate_discrepancy_scale(*d, method_weights(), {5, 0.5});
  ASSERT_EQ(median.held_out_d2.size(), 50u);
  const auto farthest = std::max_element(median.held_out_d2.begin(), median.held_out_d2.end());
  EXPECT_EQ(farthest - median.held_out_d2.begin(), 5);  // subject_006
  // The bulk lies within the learned covariance: the median D² is below χ²(4)'s.
  EXPECT_LT(median.held_out_quantile, median.expected_quantile);
  EXPECT_EQ(median.scale, 1.0);
  // The tail does not: the 0.99 quantile (006) lies far beyond χ²(4)'s.
  const DiscrepancyCalibration tail = calibrate_discrepancy_scale(*d, method_weights(), {5, 0.99});
  EXPECT_GT(tail.scale, 2.0);
  EXPECT_EQ(tail.held_out_d2, median.held_out_d2);
}

TEST(DiscrepancyCalibration, ScaleDoesNotDependOnTheResidualsUnits) {
  std::vector<SpectrumResidual> doubled = nist_forearm_residuals();
  for (auto& r : doubled) r.residual *= 2.0;
  const auto a = calibrate_discrepancy_scale(*ModelDiscrepancy::standard(), method_weights());
  const auto b = calibrate_discrepancy_scale(ModelDiscrepancy::learn(doubled), method_weights());
  EXPECT_NEAR(a.scale, b.scale, 1e-9);
  EXPECT_NEAR(a.held_out_quantile, b.held_out_quantile, 1e-6 * a.held_out_quantile);
}

TEST(DiscrepancyCalibration, RefusesBadOptionsNamingThem) {
  const auto d = ModelDiscrepancy::standard();
  const Eigen::MatrixXd w = method_weights();
  EXPECT_THROW(calibrate_discrepancy_scale(*d, w, {1, 0.9}), std::invalid_argument);
  EXPECT_THROW(calibrate_discrepancy_scale(*d, w, {30, 0.9}), std::invalid_argument);
  EXPECT_THROW(calibrate_discrepancy_scale(*d, w, {5, 1.0}), std::invalid_argument);
  EXPECT_THROW(calibrate_discrepancy_scale(*d, Eigen::MatrixXd::Ones(4, 10), {5, 0.9}), std::invalid_argument);
  try {
    calibrate_discrepancy_scale(*d, w, {5, 0.0});
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("quantile"), std::string::npos);
  }
}

}  // namespace
}  // namespace chromo::estimation
