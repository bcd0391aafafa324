// The API's plan messages carry each step's polarisation (proto/chromosphere/v1/sessions.proto
// Step.polarisation, docs/polarisation.md): a polarised plan survives the
// round trip, an unknown value is refused naming the step.

#include <gtest/gtest.h>

#include "chromo/proto/plan_messages.hpp"

namespace chromo {
namespace {

TEST(PlanPolarisationMessages, APolarisedPlanSurvivesTheApiAndUnknownValuesAreRefused) {
  const session::SessionPlan plan = session::standard_plan({.polarised = true});
  chromosphere::v1::SessionPlan message;
  proto::to_proto(plan, &message);
  EXPECT_EQ(message.steps(1).polarisation(), chromosphere::v1::POLARISATION_CROSS);
  session::SessionPlan back;
  ASSERT_TRUE(proto::from_proto(message, "plan", &back).ok());
  ASSERT_EQ(back.steps.size(), plan.steps.size());
  for (std::size_t i = 0; i < plan.steps.size(); ++i) EXPECT_EQ(back.steps[i].polarisation, plan.steps[i].polarisation);

  message.mutable_steps(2)->set_polarisation(static_cast<chromosphere::v1::Polarisation>(7));
  const grpc::Status status = proto::from_proto(message, "plan", &back);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("plan.steps[2].polarisation: unknown value 7"), std::string::npos)
      << status.error_message();
  chromosphere::v1::SessionPlan unpolarised;
  proto::to_proto(session::standard_plan(), &unpolarised);
  for (const auto& step : unpolarised.steps()) EXPECT_EQ(step.polarisation(), chromosphere::v1::POLARISATION_UNPOLARISED);
}

}  // namespace
}  // namespace chromo
