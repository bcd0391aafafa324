// Plans that name a polarisation state per step (docs/polarisation.md,
// "Sessions"): the method cross-polarised plus one parallel D65' capture on a
// sphere with polarisers, white references per state, old plans unchanged.

#include <gtest/gtest.h>

#include <algorithm>

#include "chromo/session/session_plan.hpp"

namespace chromo::session {
namespace {

using drivers::Polarisation;

TEST(PlanPolarisation, PolarisedStandardPlanIsCrossWithOneParallelBroadbandCapture) {
  const SessionPlan plan = standard_plan({.meter_white_share = 0.7, .polarised = true});
  std::string error;
  ASSERT_TRUE(plan.IsValid(&error)) << error;
  std::vector<std::string> names;
  for (const Step& step : plan.steps) names.push_back(step.name);
  EXPECT_EQ(names, (std::vector<std::string>{"dark", "white_d65", "white_w57+blue", "white_w57", "white_d65_parallel",
                                             "subject_d65", "subject_d65_parallel", "subject_w57",
                                             "subject_w57+blue"}));
  for (const Step& step : plan.steps) {
    const Polarisation expected = step.role == StepRole::kDark                ? Polarisation::kUnpolarised
                                  : step.name.ends_with("_parallel")          ? Polarisation::kParallel
                                                                               : Polarisation::kCross;
    EXPECT_EQ(step.polarisation, expected) << step.name;
  }
  // White references per state: the parallel subject pairs with the parallel white only.
  const Step& parallel_subject = plan.steps[6];
  EXPECT_EQ(illumination_state(parallel_subject).key, "d65:parallel");
  EXPECT_EQ(illumination_state(plan.steps[4]).key, "d65:parallel");
  EXPECT_EQ(illumination_state(plan.steps[1]).key, "d65");  // the cross captures are the method's
  EXPECT_EQ(capture_name(illumination_state(parallel_subject)), "D65' parallel");
  EXPECT_EQ(parallel_subject.exposure_from, "white_d65_parallel");
  EXPECT_GT(plan.steps[4].meter_white_share, 0);
}

TEST(PlanPolarisation, UnpolarisedPlansAreWrittenAsBeforeAndPolarisedOnesRoundTrip) {
  const nlohmann::json before = to_json(standard_plan());
  EXPECT_EQ(before.dump().find("polarisation"), std::string::npos);
  EXPECT_EQ(to_json(plan_from_json(before)), before);
  const SessionPlan polarised = standard_plan({.polarised = true});
  const nlohmann::json json = to_json(polarised);
  EXPECT_EQ(json["steps"][1]["polarisation"], "cross");
  const SessionPlan back = plan_from_json(json);
  ASSERT_EQ(back.steps.size(), polarised.steps.size());
  for (std::size_t i = 0; i < back.steps.size(); ++i) EXPECT_EQ(back.steps[i].polarisation, polarised.steps[i].polarisation);
}

TEST(PlanPolarisation, BadOrMixedPolarisationIsRefusedNamingTheStep) {
  nlohmann::json json = to_json(standard_plan());
  json["steps"][2]["polarisation"] = "diagonal";
  try {
    plan_from_json(json);
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("steps[2].polarisation: \"diagonal\""), std::string::npos) << e.what();
  }
  SessionPlan mixed = standard_plan();
  mixed.steps[4].polarisation = Polarisation::kCross;  // subject_d65 cross among unpolarised steps
  std::string error;
  EXPECT_FALSE(mixed.IsValid(&error));
  EXPECT_NE(error.find("steps[4].polarisation: cross, but steps[1] is unpolarised"), std::string::npos) << error;
  SessionPlan with_parallel = standard_plan();
  with_parallel.steps[4].polarisation = Polarisation::kParallel;  // parallel may join an unpolarised plan
  EXPECT_TRUE(with_parallel.IsValid(&error)) << error;
  EXPECT_EQ(parse_polarisation("cross"), Polarisation::kCross);
  EXPECT_FALSE(parse_polarisation("Cross").has_value());
}

}  // namespace
}  // namespace chromo::session
