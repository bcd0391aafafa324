// PlanService (proto/chromosphere/v1/planning.proto, docs/plan-advisor.md) over
// a real gRPC Unix socket: built-in and described plans advised, the Monte
// Carlo check when asked, and bad plans refused naming the field.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <grpcpp/grpcpp.h>

#include "chromo/daemon/server.hpp"
#include "chromosphere/v1/planning.grpc.pb.h"
#include "test_lab.hpp"

namespace chromo::daemon {
namespace {

namespace pb = chromosphere::v1;
using ::testing::HasSubstr;

struct PlanApi : ::testing::Test {
  testing::TestLab lab{"plan-api"};
  std::unique_ptr<Daemon> daemon;
  std::unique_ptr<Server> server;
  std::unique_ptr<pb::PlanService::Stub> stub;

  void SetUp() override {
    daemon = lab.daemon();
    server = std::make_unique<Server>(*daemon);
    stub = pb::PlanService::NewStub(grpc::CreateChannel("unix:" + lab.config.unix_socket, grpc::InsecureChannelCredentials()));
  }
  void TearDown() override { server->shutdown(); }

  grpc::Status compare(const pb::ComparePlansRequest& request, pb::ComparePlansResponse* response) {
    grpc::ClientContext context;
    return stub->ComparePlans(&context, request, response);
  }
};

pb::PlanDescription blue_direct() {
  pb::PlanDescription plan;
  plan.set_name("blue-direct");
  auto* white = plan.add_captures();
  white->set_name("W57");
  white->mutable_drive()->set_w57(1.0);
  auto* blue = plan.add_captures();
  blue->set_name("blue");
  blue->mutable_drive()->set_blue(1.0);
  blue->set_frames(4);
  return plan;
}

TEST_F(PlanApi, AdvisesBuiltinAndDescribedPlans) {
  pb::ComparePlansRequest request;
  request.add_plans()->set_builtin("standard");
  *request.add_plans()->mutable_description() = blue_direct();
  request.set_skins(8);
  request.set_monte_carlo_draws(2);
  pb::ComparePlansResponse response;
  const grpc::Status status = compare(request, &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(response.plans_size(), 2);
  const pb::PlanAdvice& method = response.plans(0);
  EXPECT_EQ(method.plan(), "standard");
  EXPECT_EQ(method.channels_size(), 4);
  EXPECT_EQ(method.illuminants_size(), 8);
  EXPECT_EQ(method.predicted_delta_e94_size(), 8);
  EXPECT_GT(method.predicted_delta_e94_mean(), 0);
  EXPECT_GT(method.subject_s(), 0);
  EXPECT_TRUE(method.checked());
  EXPECT_EQ(method.fits(), 16u);
  EXPECT_GT(method.ratio(), 0);
  const pb::PlanAdvice& blue = response.plans(1);
  EXPECT_EQ(blue.channels_size(), 6);  // every capture's R, G, B
  ASSERT_EQ(blue.captures_size(), 2);
  EXPECT_GT(blue.captures(1).subject_s(), 4 * blue.captures(1).exposure_us() / 1e6);
  EXPECT_FALSE(response.library().empty());
}

TEST_F(PlanApi, BadPlansAreRefusedNamingTheField) {
  auto refused = [&](const pb::ComparePlansRequest& request) {
    pb::ComparePlansResponse response;
    const grpc::Status status = compare(request, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
    EXPECT_EQ(response.plans_size(), 0);
    return status.error_message();
  };
  pb::ComparePlansRequest request;
  EXPECT_THAT(refused(request), HasSubstr("plans: must hold 1-16"));
  request.add_plans()->set_builtin("hyperspectral");
  EXPECT_THAT(refused(request), HasSubstr("plans[0].builtin: plan 'hyperspectral': not a built-in plan"));
  request.clear_plans();
  pb::PlanDescription bad = blue_direct();
  bad.mutable_captures(1)->set_white_fill(1.5);
  *request.add_plans()->mutable_description() = bad;
  EXPECT_EQ(refused(request), "plans[0].description.captures[1].white_fill: must be in (0, 1]");
  request.clear_plans();
  bad = blue_direct();
  auto* channel = bad.add_channels();
  channel->set_capture("blue");
  channel->set_minus("W56");
  *request.add_plans()->mutable_description() = bad;
  EXPECT_EQ(refused(request), "plans[0].description.channels[0].minus: no capture named 'W56'");
  request.clear_plans();
  request.add_plans();  // neither builtin nor description
  EXPECT_EQ(refused(request), "plans[0].plan: required (builtin or description)");
  request.clear_plans();
  request.add_plans()->set_builtin("standard");
  request.set_skins(2001);
  EXPECT_EQ(refused(request), "skins: at most 2000");
  request.set_skins(2000);
  request.set_monte_carlo_draws(16);
  EXPECT_THAT(refused(request), HasSubstr("monte_carlo_draws: plans × skins × draws must be at most 20000"));
}

}  // namespace
}  // namespace chromo::daemon
