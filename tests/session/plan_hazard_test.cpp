// The blue-light hazard dose of a plan (session/plan_hazard.hpp) from the
// nominal LED library: the IEC 62471 weighting, the absolute scale, the
// lit time per subject step, and bad options refused naming the field.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <numbers>
#include <unistd.h>

#include "chromo/calibration/led_library.hpp"
#include "chromo/session/journal.hpp"
#include "chromo/session/plan_hazard.hpp"
#include "chromo/spectral/cie.hpp"

namespace chromo::session {
namespace {

drivers::DriveLevels only(spectral::LedType type, double level) {
  drivers::DriveLevels drive{};
  drive[static_cast<std::size_t>(spectral::led_type_index(type))] = level;
  return drive;
}

TEST(PlanHazard, WeightingIsIec62471TableAndDoseIsRadianceTimesLitTime) {
  const auto& b = spectral::blue_light_hazard_weighting();
  auto at = [&](double nm) { return b[static_cast<int>((nm - spectral::kGridStartNm) / spectral::kGridStepNm)]; };
  EXPECT_DOUBLE_EQ(at(380), 0.01);
  EXPECT_DOUBLE_EQ(at(440), 1.0);
  EXPECT_DOUBLE_EQ(at(470), 0.62);
  EXPECT_NEAR(at(550), 0.01, 1e-9);  // 10^((450 − 550)/50)
  EXPECT_DOUBLE_EQ(at(650), 0.001);
  EXPECT_DOUBLE_EQ(at(750), 0.0);

  const calibration::LedLibrary library = calibration::nominal_led_library();
  SessionPlan plan = standard_plan({.exposure_us = 10000, .frames_per_camera = 2, .settle_ms = 50});
  // W57 alone at full drive on every lit step: E_B is then the scale times W57's weighted share.
  auto levels = [](const Step& step) {
    return step.illumination.kind == Illumination::Kind::kDark ? drivers::DriveLevels{} : only(spectral::LedType::kW57, 1.0);
  };
  BlueLightHazardOptions options;
  options.w57_full_drive_irradiance_W_per_m2 = 40;
  options.frame_allowance_ms = 100;
  const PlanHazard hazard = plan_blue_light_hazard(plan, levels, library, options);
  const spectral::Spectrum w57 = library.led(spectral::LedType::kW57).spectrum_per_unit_drive();
  const double weighted_share = (w57.values() * b.values()).sum() / w57.values().sum();
  ASSERT_EQ(hazard.steps.size(), 3u);
  for (const auto& step : hazard.steps) {
    EXPECT_NEAR(step.weighted_irradiance_W_per_m2, 40 * weighted_share, 1e-9);
    EXPECT_NEAR(step.weighted_radiance_W_per_m2_sr, 40 * weighted_share / std::numbers::pi, 1e-9);
    EXPECT_NEAR(step.lit_s, 0.050 + 2 * (0.010 + 0.100), 1e-12);
  }
  EXPECT_NEAR(hazard.dose_J_per_m2_sr, 3 * 0.27 * 40 * weighted_share / std::numbers::pi, 1e-9);
  EXPECT_GT(weighted_share, 0.05);  // a 5700 K white LED has real blue
  EXPECT_LT(weighted_share, 0.5);
  EXPECT_TRUE(hazard.within_limit());

  // The blue LED weighs more per watt than the white; a metered exposure replaces the plan's.
  auto blue = [](const Step& step) {
    return step.illumination.kind == Illumination::Kind::kDark ? drivers::DriveLevels{} : only(spectral::LedType::kBlue, 1.0);
  };
  const PlanHazard blue_hazard = plan_blue_light_hazard(plan, blue, library, options, {{"subject_d65", 1e6}});
  EXPECT_NEAR(blue_hazard.steps[0].lit_s, 0.050 + 2 * (1.0 + 0.100), 1e-12);
  EXPECT_GT(blue_hazard.steps[1].weighted_irradiance_W_per_m2 /
                (library.led(spectral::LedType::kBlue).spectrum_per_unit_drive().values().sum()),
            hazard.steps[1].weighted_irradiance_W_per_m2 / w57.values().sum());
  options.limit_J_per_m2_sr = blue_hazard.dose_J_per_m2_sr / 2;
  const PlanHazard refused = plan_blue_light_hazard(plan, blue, library, options, {{"subject_d65", 1e6}});
  EXPECT_FALSE(refused.within_limit());
  EXPECT_NE(refused.describe().find("plan \"standard\""), std::string::npos) << refused.describe();

  options.w57_full_drive_irradiance_W_per_m2 = -1;
  std::string error;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_EQ(error.rfind("w57_full_drive_irradiance_W_per_m2:", 0), 0u) << error;
  EXPECT_THROW(plan_blue_light_hazard(plan, levels, library, options), std::invalid_argument);
}

// summary.json's "blue_light_hazard": the journal's last record of the dose
// (the metered one follows the planned one), whatever else the journal holds.
TEST(PlanHazard, TheRecordedDoseIsTheJournalsLastHazardRecord) {
  const auto folder = std::filesystem::temp_directory_path() / ("chromo_hazard_record_" + std::to_string(::getpid()));
  std::filesystem::create_directories(folder);
  const auto path = folder / "journal.jsonl";
  EXPECT_TRUE(recorded_blue_light_hazard(path).is_null());  // no journal yet
  {
    Journal journal(path, nullptr);
    journal.append({{"type", "session_started"}, {"expected_frames", 7}});
    EXPECT_TRUE(recorded_blue_light_hazard(path).is_null());  // none recorded
    journal.append({{"type", "blue_light_hazard"}, {"exposures", "planned"}, {"dose_J_per_m2_sr", 1.5}});
    journal.append({{"type", 3}, {"note", "a type that is not a string is skipped"}});
    journal.append({{"type", "blue_light_hazard"}, {"exposures", "metered"}, {"dose_J_per_m2_sr", 2.5}});
    journal.append({{"type", "frame"}, {"step", "subject_d65"}});
  }
  std::ofstream(path, std::ios::app) << R"({"type": "blue_light_hazard", "dose_J_per_m2_sr": 9)";  // torn tail
  const nlohmann::ordered_json recorded = recorded_blue_light_hazard(path);
  EXPECT_EQ(recorded.value("exposures", ""), "metered");
  EXPECT_DOUBLE_EQ(recorded.value("dose_J_per_m2_sr", 0.0), 2.5);
  EXPECT_FALSE(recorded.contains("type"));
  EXPECT_FALSE(recorded.contains("t"));
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace chromo::session
