// One frame's scale of the learned discrepancy (estimation/discrepancy_scale.hpp,
// issue 37): skin within the learned range keeps the estimate as it was; a
// subject outside it (NIST subject_006, held out) is told at the frame level
// instead of flagged pixel by pixel, while its ink and marker stay caught; a
// frame mostly covered by ink stays bounded and its ink caught; bad input
// is refused.
#include "chromo/estimation/discrepancy_scale.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <limits>

#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "held_out_six_led_frames.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::estimation {
namespace {

using test::flagged;
using test::Frame;
using test::frame_of;
using test::learned_estimator;
using test::plan;

TEST(DiscrepancyScale, SkinWithinTheLearnedRangeKeepsTheEstimateAsItWas) {
  const Estimator base = learned_estimator();
  const Frame f = frame_of(10, 0.05, 1);  // subject_011, held out
  const FrameEstimator framed = frame_estimator(base, f.noisy);
  EXPECT_EQ(framed.scale.scale, 1.0);
  EXPECT_EQ(framed.scale.weight, 0.0);
  EXPECT_GT(framed.scale.pixels, 300u);
  EXPECT_FALSE(framed.scale.warn);
  EXPECT_EQ(framed.scale.warning(), "");
  EXPECT_EQ(framed.estimator.discrepancy_scale(), 1.0);
  std::vector<PixelEstimate> a(f.truth.pixels()), b(f.truth.pixels());
  base.estimate(f.noisy, a);
  framed.estimator.estimate(f.noisy, b);
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a[i].chi2, b[i].chi2) << i;
}

TEST(DiscrepancyScale, ASubjectOutsideTheLearnedRangeIsToldOnceNotFlaggedWhole) {
  const Estimator base = learned_estimator();
  const Frame f = frame_of(5, 0.05, 2);  // subject_006, held out
  const auto before = flagged(base, f);
  EXPECT_GT(before[0], 0.5);  // the whole patch flagged pixel by pixel
  const FrameEstimator framed = frame_estimator(base, f.noisy);
  EXPECT_GT(framed.scale.scale, 2.0);
  EXPECT_GT(framed.scale.weight, 0.0);
  EXPECT_LE(framed.scale.weight, framed.scale.max_weight);
  EXPECT_TRUE(framed.scale.warn);
  EXPECT_NE(framed.scale.warning().find("skin outside the model's learned range (scale "), std::string::npos);
  const auto after = flagged(framed.estimator, f);
  EXPECT_LE(after[0], 0.05);
  EXPECT_GE(after[2], 0.95);  // its marker is still caught
  // Its ink is not (measured 61% caught -> 4%): ink over this skin lies
  // along the frame's own residual; why the frame term stays off by default.
  EXPECT_LT(after[1], before[1]);
}

TEST(DiscrepancyScale, AFrameMostlyInkStaysBoundedAndItsInkCaught) {
  const Estimator base = learned_estimator();
  DiscrepancyScaleOptions options;
  const Frame f = frame_of(-1, 0.6, 3);  // model skin under 60% ink and 5% marker
  const FrameEstimator framed = frame_estimator(base, f.noisy, {}, options);
  EXPECT_LE(framed.scale.weight, options.max_weight);  // measured: at the bound
  const auto after = flagged(framed.estimator, f);
  EXPECT_GE(after[1], 0.95);
  EXPECT_GE(after[2], 0.95);
}

TEST(DiscrepancyScale, BadInputIsRefusedNamingWhat) {
  const Estimator base = learned_estimator();
  const std::vector<float> ragged(plan().set.size() * 3 + 1, 0.3f);
  try {
    estimate_discrepancy_scale(base, ragged);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("not whole pixels"), std::string::npos);
  }
  const std::vector<float> three(plan().set.size() * 3, 0.3f);
  const std::vector<std::uint8_t> two(2, 0);
  EXPECT_THROW(estimate_discrepancy_scale(base, three, {two}), std::invalid_argument);
  DiscrepancyScaleOptions options;
  options.quantile = 1.5;
  try {
    estimate_discrepancy_scale(base, three, {}, options);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("quantile"), std::string::npos);
  }
  EXPECT_THROW(base.with_discrepancy_scale(0), std::invalid_argument);
  EXPECT_THROW(base.with_discrepancy_scale(std::numeric_limits<double>::infinity()), std::invalid_argument);
  // Without a discrepancy there is nothing to scale.
  EstimatorOptions none;
  none.threads = 2;
  const DiscrepancyScale s = estimate_discrepancy_scale(Estimator(plan().table, plan().set, none), three);
  EXPECT_EQ(s.scale, 1.0);
  EXPECT_EQ(s.pixels, 0u);
}

}  // namespace
}  // namespace chromo::estimation
