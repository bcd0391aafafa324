#include <gtest/gtest.h>

#include "chromo/session/session_plan.hpp"

namespace chromo::session {
namespace {

TEST(SessionPlan, StandardPlanIsTheMethodsSequence) {
  auto plan = standard_plan();
  std::vector<std::string> names;
  for (const auto& step : plan.steps) names.push_back(step.name);
  EXPECT_EQ(names, (std::vector<std::string>{"dark", "white_d65", "white_w57", "white_w57+blue", "subject_d65",
                                             "subject_w57", "subject_w57+blue"}));
  EXPECT_EQ(plan.steps[0].illumination.kind, Illumination::Kind::kDark);
  EXPECT_EQ(plan.steps[3].illumination.mix, "w57+blue");
  EXPECT_EQ(plan.steps[4].role, StepRole::kSubject);
  std::string error;
  EXPECT_TRUE(plan.IsValid(&error)) << error;
  EXPECT_TRUE(standard_plan({.operator_prompts = true}).steps[1].prompt.size() > 0);
}

TEST(SessionPlan, InvalidFieldsAreNamed) {
  std::string error;
  auto plan = standard_plan();
  plan.steps[2].exposure_us = -1;
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_EQ(error.rfind("steps[2].exposure_us:", 0), 0u) << error;

  plan = standard_plan();
  plan.steps[1].illumination.mix = "d66";
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_EQ(error.rfind("steps[1].mix:", 0), 0u) << error;

  plan = standard_plan();
  plan.steps[4].name = plan.steps[0].name;
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_NE(error.find("used twice"), std::string::npos);

  plan = standard_plan();
  plan.steps[0].illumination.kind = Illumination::Kind::kWeights;
  plan.steps[0].illumination.weights[5] = 1.5;
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_EQ(error.rfind("steps[0].weights.B:", 0), 0u) << error;

  plan = standard_plan();
  plan.name = "../etc";
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_EQ(error.rfind("name:", 0), 0u);

  plan = standard_plan();
  plan.steps[0].frames_per_camera = 0;
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_EQ(error.rfind("steps[0].frames_per_camera:", 0), 0u);
}

TEST(SessionPlan, JsonRoundTrip) {
  auto plan = standard_plan({.timing = Timing::kHardware, .exposure_us = 1234, .frames_per_camera = 3});
  plan.steps[2].illumination.kind = Illumination::Kind::kWeights;
  plan.steps[2].illumination.weights = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6};
  auto back = plan_from_json(to_json(plan));
  EXPECT_EQ(to_json(back), to_json(plan));
  EXPECT_EQ(back.timing, Timing::kHardware);
  EXPECT_EQ(back.frames_per_camera_total(), 21u);
}

}  // namespace
}  // namespace chromo::session
