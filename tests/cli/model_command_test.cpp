// Runs the real chromo binary and checks its output and exit status.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "run_chromo.hpp"

using ::testing::HasSubstr;

namespace {

TEST(ChromoModel, JsonHasTheDocumentedKeysAndConsistentValues) {
  const Result r = run_chromo("model --cm 0.05 --ch 0.03 --bm 0.7 --che 0.01 --json");
  ASSERT_EQ(r.exit_status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  ASSERT_EQ(j["wavelength_nm"].size(), 81u);
  ASSERT_EQ(j["albedo"].size(), 81u);
  EXPECT_EQ(j["wavelength_nm"][0], 380.0);
  EXPECT_EQ(j["wavelength_nm"][80], 780.0);
  // Same numbers as SkinModel's independent check at 550 nm (index 34).
  EXPECT_NEAR(j["albedo"][34].get<double>(), 0.14540231682306431, 1e-9);
  for (const char* key : {"xyz", "lab", "srgb"}) EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_NEAR(j["xyz"]["Y"].get<double>(), 15.94, 0.05);
  EXPECT_NEAR(j["lab"]["L"].get<double>(), 116.0 * std::cbrt(j["xyz"]["Y"].get<double>() / 100.0) - 16.0, 1e-9);
  EXPECT_GT(j["srgb"]["r"].get<double>(), j["srgb"]["b"].get<double>());  // skin is reddish
}

TEST(ChromoModel, TextOutputListsTheSpectrumAndColour) {
  const Result r = run_chromo("model --cm 0.05 --ch 0.03 --illuminant a");
  ASSERT_EQ(r.exit_status, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("\n380 "));
  EXPECT_THAT(r.output, HasSubstr("\n780 "));
  EXPECT_THAT(r.output, HasSubstr("CIELAB"));
  EXPECT_THAT(r.output, HasSubstr("sRGB"));
}

TEST(ChromoModel, OutOfRangeParametersAreRefusedWithExitStatus2) {
  Result r = run_chromo("model --cm 0.7 --ch 0.03");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("Cm = 0.7 is outside its range 0.001-0.5"));
  r = run_chromo("model --cm 0.05 --ch 0.5");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("Ch = 0.5 is outside its range 0.001-0.32"));
  r = run_chromo("model --cm 0.05 --ch 0.03 --bm -0.1");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("βm = -0.1 is outside its range 0-1"));
  r = run_chromo("model --cm 0.05 --ch 0.03 --che 0.2");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("Che = 0.2 is outside its range 0-0.1"));
}

TEST(ChromoModel, MalformedCommandLinesAreRefusedWithExitStatus2) {
  EXPECT_EQ(run_chromo("model --cm abc --ch 0.03").exit_status, 2);
  EXPECT_EQ(run_chromo("model --ch 0.03").exit_status, 2);  // --cm is required
  EXPECT_EQ(run_chromo("model --cm 0.05 --ch 0.03 --frobnicate").exit_status, 2);
  EXPECT_EQ(run_chromo("").exit_status, 2);  // no subcommand
  const Result r = run_chromo("model --cm 0.05 --ch 0.03 --illuminant d75");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("unknown illuminant 'd75'"));
}

TEST(ChromoModel, IlluminantFromCsvFile) {
  const std::string good = ::testing::TempDir() + "/flat.csv";
  std::ofstream(good) << "# equal-energy\nwavelength_nm,value\n300,1\n900,1\n";
  Result r = run_chromo("model --cm 0.05 --ch 0.03 --json --illuminant " + good);
  ASSERT_EQ(r.exit_status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_NEAR(j["xyz"]["Y"].get<double>(), 15.9, 1.0);

  const std::string bad = ::testing::TempDir() + "/bad.csv";
  std::ofstream(bad) << "wavelength_nm,value\n400,1\n700,oops\n";
  r = run_chromo("model --cm 0.05 --ch 0.03 --illuminant " + bad);
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("'oops' is not a finite number"));
  std::remove(good.c_str());
  std::remove(bad.c_str());
}

}  // namespace
