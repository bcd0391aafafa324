// `chromo session plans` on the real binary (no daemon): the built-in plans
// with their captures, channels and capture time; plan files listed beside
// them; a plan file with a bad field refused naming it (exit 2).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "chromo/session/session_plan.hpp"
#include "run_chromo.hpp"

namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

class SessionPlans : public ::testing::Test {
 protected:
  fs::path dir = fs::temp_directory_path() / ("chromo_session_plans_test_" + std::to_string(::getpid()));
  void SetUp() override { fs::create_directories(dir / "plans"); }
  void TearDown() override { fs::remove_all(dir); }
};

TEST_F(SessionPlans, ListsTheBuiltInPlansAndPlanFiles) {
  chromo::session::StandardPlanOptions slow;
  slow.exposure_us = 100000;  // 0.1 s
  slow.frames_per_camera = 4;
  chromo::session::SessionPlan mine = chromo::session::multispectral_plan(slow);
  mine.name = "my_multispectral";
  std::ofstream(dir / "plans" / "mine.json") << chromo::session::to_json(mine).dump(1);
  const Result r = run_chromo("session plans --plan-dir " + (dir / "plans").string());
  ASSERT_EQ(r.exit_status, 0) << r.output;
  // name, captures, channels, subject s, references s, frames, predicted relit ΔE94 (the plan advisor)
  EXPECT_THAT(r.output, HasSubstr("standard"));
  EXPECT_THAT(r.output, ::testing::ContainsRegex("standard +3 +4 +0\\.21 +0\\.28 +7 +[0-9.]+ "));
  EXPECT_THAT(r.output, ::testing::ContainsRegex("multispectral +6 +18 +0\\.42 +0\\.49 +13 +[0-9.]+ "));
  EXPECT_THAT(r.output, ::testing::ContainsRegex("multispectral\\+method +9 +27 "));
  // 6 subject steps × (50 ms settle + 4 × 0.1 s); 7 reference steps alike.
  EXPECT_THAT(r.output, ::testing::ContainsRegex("my_multispectral +6 +18 +2\\.70 +3\\.15 +52 +[0-9.]+ +.*mine\\.json"));
  // The advisor's ordering (docs/plan-advisor.md): the six LED types one at
  // a time beat the method's four channels, and 4 frames beat 1.
  auto predicted = [&](const std::string& plan) {
    std::smatch m;
    const std::regex row("(^|\\n)" + plan + " +[0-9]+ +[0-9]+ +[0-9.]+ +[0-9.]+ +[0-9]+ +([0-9.]+) ");
    if (!std::regex_search(r.output, m, row)) return -1.0;
    return std::stod(m[2].str());
  };
  const double standard = predicted("standard"), multispectral = predicted("multispectral"),
               four_frames = predicted("my_multispectral");
  EXPECT_GT(standard, 0.2);
  EXPECT_LT(standard, 3.0);
  EXPECT_LT(multispectral, standard);
  EXPECT_GT(multispectral, 0.0);
  EXPECT_LT(four_frames, multispectral);
  EXPECT_GT(four_frames, 0.0);

  // The blue-light dose column (IEC 62471 L_B·t, session/plan_hazard.hpp): the
  // same six mixes lit longer give a dose in proportion to the lit time,
  // settle + frames × (exposure + 100 ms allowance) per subject step.
  auto dose = [&](const std::string& plan) {
    std::smatch m;
    const std::regex row("(^|\\n)" + plan + " +[0-9]+ +[0-9]+ +[0-9.]+ +[0-9.]+ +[0-9]+ +[0-9.]+ +([0-9.e+-]+) ");
    if (!std::regex_search(r.output, m, row)) return -1.0;
    return std::stod(m[2].str());
  };
  const chromo::session::StandardPlanOptions defaults;
  const double lit_default = defaults.settle_ms / 1e3 + defaults.frames_per_camera * (defaults.exposure_us / 1e6 + 0.1);
  const double lit_slow = slow.settle_ms / 1e3 + slow.frames_per_camera * (slow.exposure_us / 1e6 + 0.1);
  ASSERT_GT(dose("multispectral"), 0.0) << r.output;
  EXPECT_NEAR(dose("my_multispectral") / dose("multispectral"), lit_slow / lit_default, 1e-3 * lit_slow / lit_default)
      << r.output;
  EXPECT_GT(dose("standard"), 0.0);
  EXPECT_LT(dose("standard"), 1e6);  // within IEC 62471's exempt-group limit
  EXPECT_THAT(r.output, HasSubstr("blue_dose: IEC 62471"));
}

TEST_F(SessionPlans, APlanFileWithABadFieldIsRefusedByName) {
  nlohmann::json plan = chromo::session::to_json(chromo::session::multispectral_plan());
  plan["steps"][4]["illumination"]["weights"]["UV"] = 1.0;
  std::ofstream(dir / "bad.json") << plan.dump();
  const Result r = run_chromo("session plans " + (dir / "bad.json").string());
  EXPECT_EQ(r.exit_status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("steps[4].illumination.weights.UV: not an LED type"));
  EXPECT_THAT(r.output, Not(HasSubstr("multispectral ")));  // nothing listed
}

}  // namespace
