// Runs the real chromo binary: chromo leds solve / compare / plot.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "chromo/calibration/led_library.hpp"
#include "chromo/calibration/led_library_io.hpp"
#include "run_chromo.hpp"

using ::testing::HasSubstr;

namespace {

class ChromoLeds : public ::testing::Test {
 protected:
  void SetUp() override {
    home_ = std::filesystem::path(::testing::TempDir()) /
            ("chromo_leds_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    std::filesystem::remove_all(home_);
    std::filesystem::create_directories(home_);
  }
  void TearDown() override { std::filesystem::remove_all(home_); }
  // Every run gets its own CHROMO_HOME so a library on this machine never leaks in.
  Result run(const std::string& arguments) const {
    return run_chromo(arguments, "CHROMO_HOME='" + home_.string() + "'");
  }
  std::filesystem::path home_;
};

TEST_F(ChromoLeds, SolveJsonHasTheDocumentedKeysAndMeetsTheD65Targets) {
  const Result r = run("leds solve --library nominal --target d65 --objective camera --hold-chromaticity --json");
  ASSERT_EQ(r.exit_status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  ASSERT_EQ(j["weights"].size(), 6u);
  for (const char* led : {"W57", "W40", "W27", "R", "G", "B"}) {
    EXPECT_GE(j["weights"][led].get<double>(), 0.0) << led;
    EXPECT_LE(j["weights"][led].get<double>(), 1.0) << led;
    EXPECT_TRUE(j["weight_std"].contains(led)) << led;
  }
  ASSERT_EQ(j["wavelength_nm"].size(), 81u);
  ASSERT_EQ(j["mix"].size(), 81u);
  EXPECT_EQ(j["r1_r14"].size(), 14u);
  EXPECT_EQ(j["termination"], "optimal");
  EXPECT_EQ(j["library_source"], "nominal");
  EXPECT_THAT(j["library"].get<std::string>(), HasSubstr("nominal"));
  EXPECT_LE(j["camera_de00_mean"].get<double>(), 0.2);
  EXPECT_GE(j["camera_de00_max"].get<double>(), j["camera_de00_mean"].get<double>());
  EXPECT_GE(j["ra"].get<double>(), 98.5);
  EXPECT_LT(j["delta_uv_prime"].get<double>(), 1e-9);
  EXPECT_GT(j["rmse"].get<double>(), 0.0);
  EXPECT_EQ(j["unreachable"][0]["start_nm"], 380.0);
  // mix = Σ weight · spectrum: its value at 455 nm must be positive where the blue LED is on.
  EXPECT_GT(j["mix"][15].get<double>(), 0.0);
}

TEST_F(ChromoLeds, SolveTextNamesTheLibraryAndTheUnreachableBand) {
  const Result r = run("leds solve --library nominal --target cct:5000 --objective xyz --stability-trials 0");
  ASSERT_EQ(r.exit_status, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("library: nominal (built-in, --library nominal)"));
  EXPECT_THAT(r.output, HasSubstr("UNREACHABLE 380-"));
  EXPECT_THAT(r.output, HasSubstr("camera ColorChecker dE00 mean"));
}

TEST_F(ChromoLeds, WithoutLibraryTheLatestMeasuredOneIsUsed) {
  chromo::calibration::LedLibrary lib = chromo::calibration::nominal_led_library();
  lib.source = "measured";
  lib.created_utc = "2026-11-22T10:00:00Z";
  lib.led(chromo::spectral::LedType::kW57).max_drive_level = 0.4;
  std::filesystem::create_directories(home_ / "leds");
  chromo::calibration::save_led_library(lib, home_ / "leds" / chromo::calibration::led_library_file_name(lib));
  const Result r = run("leds solve --target d65 --objective spectral --json --stability-trials 0");
  ASSERT_EQ(r.exit_status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["library_source"], "measured");
  EXPECT_THAT(j["library"].get<std::string>(), HasSubstr("led-library-20261122T100000Z.json (latest measured)"));
  EXPECT_LE(j["weights"]["W57"].get<double>(), 0.4 + 1e-12);
}

TEST_F(ChromoLeds, WithoutAnyLibraryOneIsMeasuredOnTheVirtualLabAndKept) {
  Result r = run("leds solve --target d65 --objective camera --hold-chromaticity --stability-trials 0");
  ASSERT_EQ(r.exit_status, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("no measured library in " + (home_ / "leds").string() + "; measuring one now on the virtual lab"));
  EXPECT_THAT(r.output, HasSubstr("(measured now on the virtual lab)"));
  EXPECT_THAT(r.output, HasSubstr("] 100% done"));  // the progress bar
  int libraries = 0;
  for (const auto& entry : std::filesystem::directory_iterator(home_ / "leds")) {
    ++libraries;
    const auto lib = chromo::calibration::load_led_library(entry.path());
    EXPECT_EQ(lib.source, "measured");
    EXPECT_TRUE(lib.instrument.response_calibration.has_value());
    EXPECT_EQ(lib.leds[0].ladder.size(), 4u);
  }
  EXPECT_EQ(libraries, 1);
  // The next solve uses it.
  r = run("leds solve --target d65 --objective spectral --stability-trials 0");
  ASSERT_EQ(r.exit_status, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("(latest measured)"));
}

TEST_F(ChromoLeds, MeasureWritesTheLibraryWhereAsked) {
  const auto out = home_ / "measured.json";
  const Result r = run("leds measure --json --out " + out.string());
  ASSERT_EQ(r.exit_status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output.substr(r.output.find("{\n")));
  EXPECT_EQ(j["termination"], "completed");
  EXPECT_EQ(j["library"], out.string());
  EXPECT_EQ(j["spectra_measured"], 31);  // lamp; per LED its cold spectrum and four rungs
  EXPECT_TRUE(j["linearity_ok"].get<bool>());
  const auto lib = chromo::calibration::load_led_library(out);
  EXPECT_EQ(lib.instrument.spectrometer_model.empty(), false);
  EXPECT_NE(lib.conditions.notes.find("virtual lab"), std::string::npos);
}

TEST_F(ChromoLeds, BadInputExitsWith2NamingTheField) {
  Result r = run("leds solve --objective fastest");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("--objective: unknown objective 'fastest'"));
  r = run("leds solve --library nominal --target w57+blue:abc");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("--target: target 'w57+blue:abc': blue ratio R 'abc' is not a positive number"));
  r = run("leds solve --objective spectral --hold-chromaticity");
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("--hold-chromaticity"));
  const std::filesystem::path bad = home_ / "bad.json";
  auto j = nlohmann::json::parse(chromo::calibration::led_library_to_json(chromo::calibration::nominal_led_library()));
  j["leds"][3]["ladder"][0].erase("drive_level");
  std::ofstream(bad) << j.dump();
  r = run("leds solve --library " + bad.string());
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("--library: " + bad.string() + ": leds[3].ladder[0].drive_level: missing"));
  r = run("leds compare " + bad.string() + " " + bad.string());
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_THAT(r.output, HasSubstr("leds[3].ladder[0].drive_level: missing"));
  EXPECT_EQ(run("leds").exit_status, 2);
  EXPECT_EQ(run("leds solve --stability-trials x").exit_status, 2);
}

TEST_F(ChromoLeds, CompareReportsPerLedDrift) {
  chromo::calibration::LedLibrary old_lib = chromo::calibration::nominal_led_library(), new_lib = old_lib;
  new_lib.led(chromo::spectral::LedType::kRed).ladder[0].spectrum *= 0.9;
  chromo::calibration::save_led_library(old_lib, home_ / "old.json");
  chromo::calibration::save_led_library(new_lib, home_ / "new.json");
  Result r = run("leds compare " + (home_ / "old.json").string() + " " + (home_ / "new.json").string() + " --json");
  ASSERT_EQ(r.exit_status, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_NEAR(j["leds"]["R"]["flux_change_percent"].get<double>(), -10.0, 1e-6);
  EXPECT_NEAR(j["leds"]["G"]["flux_change_percent"].get<double>(), 0.0, 1e-9);
  EXPECT_TRUE(j["leds"]["R"]["linearity_max_deviation_percent"].is_null());  // one rung: not assessable
  r = run("leds compare " + (home_ / "old.json").string() + " " + (home_ / "new.json").string());
  ASSERT_EQ(r.exit_status, 0) << r.output;
  EXPECT_THAT(r.output, HasSubstr("-10.00"));
}

TEST_F(ChromoLeds, PlotWritesAPng) {
  const std::filesystem::path png = home_ / "mix.png";
  const Result r = run("leds plot --library nominal --target d65 --objective camera --hold-chromaticity --stability-trials 0 --out " + png.string());
  ASSERT_EQ(r.exit_status, 0) << r.output;
  std::ifstream file(png, std::ios::binary);
  std::array<char, 8> magic{};
  file.read(magic.data(), magic.size());
  EXPECT_EQ(std::string(magic.data() + 1, 3), "PNG");
  EXPECT_GT(std::filesystem::file_size(png), 10000u);
}

}  // namespace
