#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

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

// Reference frames: every dark and white step of each built-in plan takes
// reference_frames, every subject step frames_per_camera; the subject's time
// (plan_timing) does not change, the references' does.
TEST(SessionPlan, ReferenceFramesApplyToDarkAndWhiteStepsOnly) {
  session::StandardPlanOptions options;
  options.frames_per_camera = 2;
  for (bool polarised : {false, true})
    for (const std::string name : {"standard", "multispectral", "multispectral+method"}) {
      options.polarised = polarised && name == "standard";
      options.reference_frames = 0;
      const session::SessionPlan same = *session::builtin_plan(name, options);
      options.reference_frames = 7;
      const session::SessionPlan plan = *session::builtin_plan(name, options);
      ASSERT_EQ(plan.steps.size(), same.steps.size()) << name;
      int references = 0;
      for (const session::Step& step : plan.steps) {
        const bool reference = step.role != session::StepRole::kSubject;
        references += reference;
        EXPECT_EQ(step.frames_per_camera, reference ? 7u : 2u) << name << " " << step.name;
      }
      for (const session::Step& step : same.steps) EXPECT_EQ(step.frames_per_camera, 2u) << name << " " << step.name;
      EXPECT_GE(references, 4) << name;
      const session::PlanTiming t = session::plan_timing(plan), t_same = session::plan_timing(same);
      EXPECT_DOUBLE_EQ(t.subject_time_s, t_same.subject_time_s) << name;
      EXPECT_GT(t.reference_time_s, t_same.reference_time_s) << name;
    }
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

namespace chromo::session {
namespace {

TEST(SessionPlan, MeteredStandardPlanMetersD65AndW57PlusBlueAndSharesTheirExposures) {
  const auto plan = standard_plan({.meter_white_share = 0.8, .blue_ratio = 4});
  std::map<std::string, const Step*> by_name;
  for (const auto& step : plan.steps) by_name[step.name] = &step;
  EXPECT_DOUBLE_EQ(by_name.at("white_d65")->meter_white_share, 0.8);
  EXPECT_DOUBLE_EQ(by_name.at("white_w57+blue")->meter_white_share, 0.8);
  EXPECT_EQ(by_name.at("white_w57")->exposure_from, "white_w57+blue");
  EXPECT_EQ(by_name.at("subject_d65")->exposure_from, "white_d65");
  EXPECT_EQ(by_name.at("subject_w57")->exposure_from, "white_w57+blue");
  EXPECT_EQ(by_name.at("subject_w57+blue")->exposure_from, "white_w57+blue");
  EXPECT_FALSE(by_name.at("dark")->metered());
  EXPECT_EQ(by_name.at("subject_w57")->illumination.mix, "w57:4");
  EXPECT_EQ(by_name.at("subject_w57+blue")->illumination.mix, "w57+blue:4");
  std::string error;
  EXPECT_TRUE(plan.IsValid(&error)) << error;
  EXPECT_EQ(to_json(plan_from_json(to_json(plan))), to_json(plan));
  EXPECT_TRUE(is_valid_mix("w57:2.5"));
  EXPECT_FALSE(is_valid_mix("w57:0"));
}

// Subject metering (docs/daemon.md "Subject exposure"): D65' and W57+blue
// meter their subjects, W57+blue's subject comes before W57's, which takes
// its ratio; without metered whites the option does nothing.
TEST(SessionPlan, SubjectMeteredStandardPlanMetersD65AndW57PlusBlueAndW57TakesItsRatio) {
  const auto plan = standard_plan({.meter_white_share = 0.8, .blue_ratio = 4, .subject_fill = 0.85,
                                   .subject_percentile = 0.98, .max_subject_exposure_ratio = 6});
  std::vector<std::string> subjects;
  std::map<std::string, const Step*> by_name;
  for (const auto& step : plan.steps) {
    by_name[step.name] = &step;
    if (step.role == StepRole::kSubject) subjects.push_back(step.name);
  }
  EXPECT_EQ(subjects, (std::vector<std::string>{"subject_d65", "subject_w57+blue", "subject_w57"}));
  for (const char* metered : {"subject_d65", "subject_w57+blue"}) {
    EXPECT_DOUBLE_EQ(by_name.at(metered)->subject_fill, 0.85) << metered;
    EXPECT_DOUBLE_EQ(by_name.at(metered)->subject_percentile, 0.98) << metered;
    EXPECT_DOUBLE_EQ(by_name.at(metered)->max_subject_exposure_ratio, 6) << metered;
  }
  EXPECT_DOUBLE_EQ(by_name.at("subject_w57")->subject_fill, 0);
  EXPECT_EQ(by_name.at("subject_w57")->subject_ratio_from, "subject_w57+blue");
  // After the subjects, each subject's white for the linearity check.
  std::vector<std::string> last;
  for (std::size_t i = plan.steps.size() - 3; i < plan.steps.size(); ++i) last.push_back(plan.steps[i].name);
  EXPECT_EQ(last, (std::vector<std::string>{"white_d65_linearity", "white_w57+blue_linearity", "white_w57_linearity"}));
  EXPECT_EQ(by_name.at("white_w57_linearity")->linearity_of, "subject_w57");
  EXPECT_EQ(by_name.at("white_w57_linearity")->illumination.mix, "w57:4");
  EXPECT_EQ(by_name.at("white_w57_linearity")->role, StepRole::kWhite);
  std::string error;
  EXPECT_TRUE(plan.IsValid(&error)) << error;
  EXPECT_EQ(to_json(plan_from_json(to_json(plan))), to_json(plan));
  for (const auto& step : standard_plan({.subject_fill = 0.85}).steps) EXPECT_FALSE(step.subject_metered()) << step.name;
  // Polarised: the linearity whites cross like every lit step of the plan, after the parallel pair.
  const auto polarised =
      standard_plan({.meter_white_share = 0.8, .subject_fill = 0.85, .polarised = true});
  EXPECT_TRUE(polarised.IsValid(&error)) << error;
  EXPECT_EQ(polarised.steps.back().name, "white_w57_linearity");
  EXPECT_EQ(polarised.steps.back().polarisation, drivers::Polarisation::kCross);
}

TEST(SessionPlan, BadSubjectMeteringIsRefusedNamingTheField) {
  const auto metered = standard_plan({.meter_white_share = 0.8, .subject_fill = 0.85});
  std::size_t d65 = 0, w57 = 0;
  for (std::size_t i = 0; i < metered.steps.size(); ++i) {
    if (metered.steps[i].name == "subject_d65") d65 = i;
    if (metered.steps[i].name == "subject_w57") w57 = i;
  }
  const std::string at = "steps[" + std::to_string(d65) + "].";
  std::string error;
  auto refused = [&](auto change, const std::string& field) {
    auto plan = metered;
    change(plan);
    EXPECT_FALSE(plan.IsValid(&error)) << field;
    EXPECT_EQ(error.rfind(field + ":", 0), 0u) << error;
  };
  refused([&](SessionPlan& p) { p.steps[d65].subject_fill = 1.0; }, at + "subject_fill");
  refused([&](SessionPlan& p) { p.steps[d65].subject_fill = std::nan(""); }, at + "subject_fill");
  refused([&](SessionPlan& p) { p.steps[d65].subject_percentile = 0; }, at + "subject_percentile");
  refused([&](SessionPlan& p) { p.steps[d65].subject_percentile = 1.01; }, at + "subject_percentile");
  refused([&](SessionPlan& p) { p.steps[d65].max_subject_exposure_ratio = 0.9; }, at + "max_subject_exposure_ratio");
  refused([&](SessionPlan& p) { p.steps[d65].max_subject_exposure_ratio = 65; }, at + "max_subject_exposure_ratio");
  refused([&](SessionPlan& p) { p.steps[0].subject_fill = 0.5; }, "steps[0].subject_fill");  // the dark step
  refused([&](SessionPlan& p) { p.steps[w57].subject_ratio_from = "subject_d65x"; },
          "steps[" + std::to_string(w57) + "].subject_ratio_from");
  refused([&](SessionPlan& p) { p.steps[d65].subject_ratio_from = "subject_w57+blue"; },
          at + "subject_ratio_from");  // meters its own, and that step is later
  const std::size_t linearity = metered.steps.size() - 1;
  const std::string linearity_at = "steps[" + std::to_string(linearity) + "].linearity_of";
  refused([&](SessionPlan& p) { p.steps[linearity].linearity_of = "white_d65"; }, linearity_at);  // not subject-metered
  refused([&](SessionPlan& p) { p.steps[linearity].role = StepRole::kSubject; }, linearity_at);
  refused([&](SessionPlan& p) { p.steps[1].linearity_of = "subject_d65"; }, "steps[1].linearity_of");  // metered white
  EXPECT_THROW(plan_from_json(nlohmann::json::parse(
                   R"({"name": "p", "steps": [{"name": "s", "role": "subject", "exposure_us": 1, "subject_fill": "x",
                       "illumination": {"mix": "d65"}}]})")),
               std::invalid_argument);
}

TEST(SessionPlan, BadMeteringIsRefusedNamingTheField) {
  std::string error;
  auto plan = standard_plan({.meter_white_share = 0.8});
  plan.steps[1].meter_white_share = 1.5;
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_EQ(error.rfind("steps[1].meter_white_share:", 0), 0u) << error;

  plan = standard_plan({.meter_white_share = 0.8});
  plan.steps[0].meter_white_share = 0.5;  // the dark step
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_EQ(error.rfind("steps[0].meter_white_share:", 0), 0u) << error;

  plan = standard_plan({.meter_white_share = 0.8});
  plan.steps[4].exposure_from = "subject_w57";  // not an earlier metered white
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_EQ(error.rfind("steps[4].exposure_from:", 0), 0u) << error;

  plan = standard_plan({.timing = Timing::kHardware, .meter_white_share = 0.8});
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_NE(error.find("software timing"), std::string::npos) << error;

  EXPECT_THROW(plan_from_json(nlohmann::json::parse(
                   R"({"name": "p", "steps": [{"name": "w", "role": "white", "exposure_us": 1, "meter_white_share": "x",
                       "illumination": {"mix": "d65"}}]})")),
               std::invalid_argument);
}

}  // namespace
}  // namespace chromo::session
