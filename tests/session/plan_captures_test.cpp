// Plans beyond the method's (issue 20, part 3): the built-in multispectral
// plans, plan files an operator writes (validated, the bad field named), the
// capture builder pairing any plan's whites and subjects, and the plan
// measurement (R, G, B albedo per capture against its own white).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "chromo/session/method_measurement.hpp"
#include "chromo/session/session_captures.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::session {
namespace {

namespace fs = std::filesystem;

TEST(Plans, MultispectralPlanLightsEachLedTypeAloneWithItsWhite) {
  const SessionPlan plan = multispectral_plan();
  std::string error;
  ASSERT_TRUE(plan.IsValid(&error)) << error;
  ASSERT_EQ(plan.steps.size(), 13u);  // dark, 6 whites, 6 subjects
  EXPECT_EQ(plan.steps[0].role, StepRole::kDark);
  for (int k = 0; k < 6; ++k) {
    const Step& white = plan.steps[1 + k];
    const Step& subject = plan.steps[7 + k];
    EXPECT_EQ(white.role, StepRole::kWhite);
    EXPECT_EQ(subject.role, StepRole::kSubject);
    ASSERT_EQ(subject.illumination.kind, Illumination::Kind::kWeights);
    for (int led = 0; led < 6; ++led) {
      EXPECT_EQ(subject.illumination.weights[led], led == k ? 1.0 : 0.0);
      EXPECT_EQ(white.illumination.weights[led], subject.illumination.weights[led]);
    }
  }
  const PlanTiming t = plan_timing(plan);
  EXPECT_EQ(t.captures, 6);
  EXPECT_EQ(t.channels, 18);
  // 6 subject steps of 50 ms settle + 20 ms exposure; 7 reference steps apart.
  EXPECT_NEAR(t.subject_time_s, 6 * 0.07, 1e-9);
  EXPECT_NEAR(t.reference_time_s, 7 * 0.07, 1e-9);

  const SessionPlan both = multispectral_plan({}, true);
  EXPECT_EQ(plan_timing(both).captures, 9);
  EXPECT_EQ(plan_timing(both).channels, 27);
  EXPECT_EQ(plan_timing(standard_plan()).channels, 4);  // the method's: D65' R, G, B and the blue-only B
  EXPECT_EQ(builtin_plan_names().size(), 3u);
  for (const std::string& name : builtin_plan_names()) EXPECT_EQ(builtin_plan(name)->name, name);
  EXPECT_FALSE(builtin_plan("nonesuch").has_value());
}

class PlanFile : public ::testing::Test {
 protected:
  fs::path dir = fs::temp_directory_path() / ("chromo_plan_file_test_" + std::to_string(::getpid()));
  void SetUp() override { fs::create_directories(dir); }
  void TearDown() override { fs::remove_all(dir); }
  std::string write(const std::string& name, const std::string& text) {
    const fs::path path = dir / name;
    std::ofstream(path) << text;
    return path.string();
  }
  std::string error_of(const std::string& text) {
    try {
      read_plan_file(write("plan.json", text));
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  }
};

TEST_F(PlanFile, AValidFileReadsBackAsWritten) {
  const std::string path = write("ms.json", to_json(multispectral_plan()).dump());
  const SessionPlan plan = read_plan_file(path);
  EXPECT_EQ(to_json(plan), to_json(multispectral_plan()));
  // The "plan" member of a session.json is accepted too.
  const std::string wrapped = write("session.json", nlohmann::json{{"plan", to_json(standard_plan())}}.dump());
  EXPECT_EQ(read_plan_file(wrapped).steps.size(), 7u);
}

TEST_F(PlanFile, BadFieldsAreRefusedByName) {
  nlohmann::json plan = to_json(multispectral_plan());
  plan["steps"][3]["illumination"]["weights"]["Blue"] = 1.0;  // not an LED type name (B)
  EXPECT_NE(error_of(plan.dump()).find("steps[3].illumination.weights.Blue"), std::string::npos) << error_of(plan.dump());

  plan = to_json(multispectral_plan());
  plan["steps"][2]["exposure_us"] = 0;
  EXPECT_NE(error_of(plan.dump()).find("steps[2].exposure_us"), std::string::npos) << error_of(plan.dump());

  plan = to_json(multispectral_plan());
  plan["steps"][5]["illumination"]["weights"]["R"] = 1.5;
  EXPECT_NE(error_of(plan.dump()).find("steps[5].weights.R"), std::string::npos) << error_of(plan.dump());

  plan = to_json(multispectral_plan());
  plan["steps"][1]["role"] = "reference";
  EXPECT_NE(error_of(plan.dump()).find("steps[1].role"), std::string::npos);

  plan = to_json(multispectral_plan());
  plan["steps"][4].erase("illumination");
  EXPECT_NE(error_of(plan.dump()).find("steps[4].illumination"), std::string::npos);

  EXPECT_NE(error_of("{not json").find("not valid JSON"), std::string::npos);
  EXPECT_NE(error_of("[]").find("plan: not a JSON object"), std::string::npos);
  try {
    read_plan_file((dir / "missing.json").string());
    ADD_FAILURE() << "a missing file was read";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("missing.json"), std::string::npos);
  }
}

TEST(PlanCaptureBuilder, PairsWhitesAndSubjectsByIllumination) {
  CaptureSources sources;
  sources.camera = spectral::builtin_camera("nikon_d5100");
  const SessionCaptureBuilder multispectral(multispectral_plan(), sources);
  EXPECT_FALSE(multispectral.is_method_plan());
  EXPECT_TRUE(SessionCaptureBuilder(standard_plan(), sources).is_method_plan());
  EXPECT_FALSE(SessionCaptureBuilder(multispectral_plan({}, true), sources).is_method_plan());
  // A subject without its white, a white without its subject, an unlit subject: refused, named.
  SessionPlan plan = multispectral_plan();
  plan.steps.erase(plan.steps.begin() + 2);  // white_W40
  try {
    SessionCaptureBuilder builder(plan, sources);
    ADD_FAILURE() << "a subject without its white was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("subject_W40"), std::string::npos) << e.what();
  }
  plan = multispectral_plan();
  plan.steps[8].illumination.weights = {};
  try {
    SessionCaptureBuilder builder(plan, sources);
    ADD_FAILURE() << "an unlit subject was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(plan.steps[8].name), std::string::npos) << e.what();
  }
  EXPECT_THROW(multispectral.captures(), std::invalid_argument);  // not the method's session
}

RgbImage flat(int width, int height, std::array<float, 3> value) {
  RgbImage image;
  image.width = width, image.height = height;
  for (int c = 0; c < 3; ++c) image.planes[c].assign(image.pixels(), value[c]);
  return image;
}

// Albedo per capture and camera channel is ρ·(subject − dark)/(white − dark),
// each capture against its own white; the set's channels carry each capture's
// illuminant, in plan order.
TEST(PlanMeasurement, EveryCaptureIsNormalisedByItsOwnWhite) {
  PlanCaptures captures;
  captures.camera = spectral::builtin_camera("nikon_d5100");
  captures.white_reflectance = 0.9;
  const int w = 24, h = 16;
  captures.dark = flat(w, h, {0.02f, 0.02f, 0.02f});
  // The subject carries a texture (the registration needs structure); the whites are flat.
  auto texture = [](int x, int y) { return 1.0f + 0.3f * std::sin(x / 2.0f) * std::cos(y / 1.5f); };
  for (int k = 0; k < 6; ++k) {
    const auto type = spectral::kAllLedTypes[k];
    IlluminatedCapture c;
    c.name = std::string(spectral::led_type_name(type));
    c.illuminant = spectral::led_spectrum(type);
    const float scale = 0.3f + 0.1f * k;
    c.white = flat(w, h, {0.02f + 0.6f * scale, 0.02f + 0.5f * scale, 0.02f + 0.4f * scale});
    c.subject = flat(w, h, {0, 0, 0});
    const float ratio[3] = {0.5f, 0.2f, 0.5f};
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int ch = 0; ch < 3; ++ch)
          c.subject.planes[ch][y * w + x] = 0.02f + (c.white.planes[ch][0] - 0.02f) * ratio[ch] * texture(x, y);
    captures.captures.push_back(c);
  }
  RegistrationOptions registration;
  const MethodMeasurement m = build_plan_measurement(captures, registration);
  ASSERT_EQ(m.set.size(), 18);
  EXPECT_EQ(m.set.channels[0].name, "W57.R");
  EXPECT_EQ(m.set.channels[17].name, "B.B");
  EXPECT_EQ(m.photographs.size(), 6u);
  ASSERT_EQ(m.measured.size(), static_cast<std::size_t>(w * h * 18));
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(m.set.channels[3 * k].illuminant.values().maxCoeff(), captures.captures[k].illuminant.values().maxCoeff());
    EXPECT_FALSE(k > 0 && m.registration[k - 1].warped);  // nothing moved
    // Subject/white signal ratios 0.5, 0.2, 0.5 (times the texture) of any scale, times ρ.
    for (int pixel : {0, 5 * w + 7, w * h - 1}) {
      const double t = texture(pixel % w, pixel / w);
      EXPECT_NEAR(m.measured[pixel * 18 + 3 * k + 0], 0.9 * 0.5 * t, 1e-5);
      EXPECT_NEAR(m.measured[pixel * 18 + 3 * k + 1], 0.9 * 0.2 * t, 1e-5);
      EXPECT_NEAR(m.measured[pixel * 18 + 3 * k + 2], 0.9 * 0.5 * t, 1e-5);
    }
  }
  EXPECT_EQ(plan_set_from_references(captures).size(), 18);
  // No capture: refused.
  captures.captures.clear();
  EXPECT_THROW(build_plan_measurement(captures), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::session
