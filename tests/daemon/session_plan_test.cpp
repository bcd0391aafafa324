#include <gtest/gtest.h>

#include "chromo/daemon/config.hpp"
#include "chromo/daemon/session_plan.hpp"

namespace chromo::daemon {
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

TEST(DaemonConfig, ParsesDevicesAndRefusesBadFieldsByName) {
  auto config = parse_config(nlohmann::json::parse(R"({
    "unix_socket": "/tmp/x.sock", "tcp_address": "127.0.0.1:7443", "token": "0123456789abcdef",
    "devices": [{"name": "sphere", "kind": "led_controller", "backend": "modbus-tcp", "address": "127.0.0.1:1502"},
                {"name": "cam0", "kind": "camera", "backend": "aravis", "address": "SN123", "settings": {"gain_db": 3}}],
    "mixes": {"d65": {"W57": 0.5, "B": 0.2}}})"));
  ASSERT_EQ(config.devices.size(), 2u);
  EXPECT_EQ(config.devices[1].kind, DeviceKind::kCamera);
  EXPECT_EQ(config.devices[1].settings["gain_db"], 3);
  EXPECT_DOUBLE_EQ(config.mixes.at("d65")[5], 0.2);

  auto refused = [](const char* text) {
    try {
      parse_config(nlohmann::json::parse(text));
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refused(R"({"tcp_address": "0.0.0.0:1", "token": "short"})").find("token"), std::string::npos);
  EXPECT_NE(refused(R"({"frame_attempts": "three"})").find("frame_attempts"), std::string::npos);
  EXPECT_NE(refused(R"({"colour": 1})").find("unknown key \"colour\""), std::string::npos);
  EXPECT_NE(refused(R"({"devices": [{"name": "a", "kind": "toaster", "backend": "x"}]})").find("devices[0].kind"),
            std::string::npos);
  EXPECT_NE(refused(R"({"mixes": {"d65": {"UV": 1}}})").find("mixes.d65.UV"), std::string::npos);
}

}  // namespace
}  // namespace chromo::daemon
