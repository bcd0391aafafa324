#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "chromo/calibration/led_library.hpp"
#include "chromo/calibration/led_library_analysis.hpp"
#include "chromo/calibration/led_library_io.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::calibration {
namespace {

using ::testing::HasSubstr;

TEST(NominalLedLibrary, HasSixValidLedsWithTheDocumentedFluxAndPeaks) {
  const LedLibrary lib = nominal_led_library();
  EXPECT_EQ(validate(lib), "");
  EXPECT_EQ(lib.source, "nominal");
  for (int i = 0; i < spectral::kLedTypeCount; ++i)
    EXPECT_NEAR(lib.leds[i].spectrum_per_unit_drive().integral(), kNominalRadiantFlux[i], 1e-12);
  // Peaks from data/led_spectra_measured/index.csv (native grid) seen on the 5 nm grid.
  EXPECT_NEAR(peak_wavelength_nm(lib.led(LedType::kRed).spectrum_per_unit_drive()), 628.75, 2.5);
  EXPECT_NEAR(peak_wavelength_nm(lib.led(LedType::kGreen).spectrum_per_unit_drive()), 519.47, 2.5);
  EXPECT_NEAR(peak_wavelength_nm(lib.led(LedType::kBlue).spectrum_per_unit_drive()), 454.26, 2.5);
}

// An LED at another temperature than its ladder's (docs/calibration.md
// "Thermal coefficients"): 20 K cooler than the ladder, flux −0.9 %/K and
// centroid +0.13 nm/K give 18 % more light, its centroid 2.6 nm bluer.
TEST(LedThermalModel, TheSpectrumAtATemperatureIsScaledAndShifted) {
  LedRecord red = nominal_led_library().led(LedType::kRed);
  for (auto& rung : red.ladder) rung.led_temperature_C = 50.0;
  auto same = [](const spectral::Spectrum& a, const spectral::Spectrum& b) { return a.to_vector() == b.to_vector(); };
  EXPECT_TRUE(same(red.spectrum_at(30.0), red.spectrum_per_unit_drive()));  // no thermal record: as measured
  red.thermal = LedThermalRecord{1.0, 25.0, 50.0, -0.009, 0.13};
  ASSERT_EQ(red.ladder_temperature_C(), 50.0);
  EXPECT_DOUBLE_EQ(red.flux_factor_at(30.0), 1.18);
  const spectral::Spectrum cool = red.spectrum_at(30.0), reference = red.spectrum_per_unit_drive();
  EXPECT_NEAR(cool.integral() / reference.integral(), 1.18, 0.002);
  EXPECT_NEAR(centroid_wavelength_nm(cool) - centroid_wavelength_nm(reference), -2.6, 0.05);
  EXPECT_TRUE(same(red.spectrum_at(50.0), reference));
  red.ladder.front().led_temperature_C.reset();  // a rung without its temperature: no reference
  EXPECT_TRUE(same(red.spectrum_at(30.0), reference));
}

TEST(LedLibraryIo, SaveThenLoadGivesTheSameLibrary) {
  LedLibrary lib = nominal_led_library();
  lib.source = "measured";
  lib.created_utc = "2026-11-22T16:00:00Z";
  lib.conditions.ambient_temperature_C = 23.5;
  lib.instrument.response_calibration = ResponseCalibrationRecord{"lamp", 3000.0, "2026-11-22T15:00:00Z",
                                                                  spectral::Spectrum::constant(1.0)};
  lib.leds[0].ladder.insert(lib.leds[0].ladder.begin(),
                            LedSpectrumSample{0.5, 41.25, 12000.0, true, lib.leds[0].ladder[0].spectrum * 0.5});
  const std::filesystem::path path = ::testing::TempDir() + "/" + led_library_file_name(lib);
  save_led_library(lib, path);
  EXPECT_EQ(path.filename().string(), "led-library-20261122T160000Z.json");
  const LedLibrary back = load_led_library(path);
  EXPECT_EQ(led_library_to_json(back), led_library_to_json(lib));  // every field, every digit
  EXPECT_EQ(back.leds[0].ladder[0].led_temperature_C, 41.25);
  EXPECT_FALSE(back.leds[1].ladder[0].led_temperature_C.has_value());
  EXPECT_FALSE(std::filesystem::exists(path.string() + ".tmp"));
  std::filesystem::remove(path);
}

// A valid file as JSON, to break one field at a time.
nlohmann::json valid_json() { return nlohmann::json::parse(led_library_to_json(nominal_led_library())); }

std::string error_of(const nlohmann::json& j) {
  try {
    parse_led_library(j.dump(), "test.json");
  } catch (const spectral::DataError& e) {
    return e.what();
  }
  return "no error";
}

TEST(LedLibraryIo, MalformedFilesAreRefusedNamingTheField) {
  EXPECT_THAT(error_of(valid_json()), "no error");
  auto j = valid_json();
  j.erase("instrument");
  EXPECT_THAT(error_of(j), HasSubstr("test.json: instrument: missing"));
  j = valid_json();
  j["format_version"] = 2;
  EXPECT_THAT(error_of(j), HasSubstr("format_version: unsupported version 2"));
  j = valid_json();
  j["format"] = "something-else";
  EXPECT_THAT(error_of(j), HasSubstr("format: expected \"chromosphere-led-library\""));
  j = valid_json();
  j["wavelength_nm"][3] = 396;
  EXPECT_THAT(error_of(j), HasSubstr("wavelength_nm[3]: expected 395"));
  j = valid_json();
  j["leds"][2]["ladder"][0]["spectrum"].erase(80);
  EXPECT_THAT(error_of(j), HasSubstr("leds[2].ladder[0].spectrum: expected 81 numbers"));
  j = valid_json();
  j["leds"][1]["ladder"][0]["spectrum"][7] = "x";
  EXPECT_THAT(error_of(j), HasSubstr("leds[1].ladder[0].spectrum[7]: expected a number, got \"x\""));
  j = valid_json();
  j["leds"][4]["type"] = "UV";
  EXPECT_THAT(error_of(j), HasSubstr("leds[4].type: unknown LED type 'UV'"));
  j = valid_json();
  j["leds"][4]["type"] = "W57";
  EXPECT_THAT(error_of(j), HasSubstr("leds[4].type: LED type W57 appears twice"));
  j = valid_json();
  j["leds"][0]["ladder"].push_back(j["leds"][0]["ladder"][0]);  // same drive level twice
  EXPECT_THAT(error_of(j), HasSubstr("W57.ladder[1].drive_level = 1.000000 must be in (0, 1]"));
  j = valid_json();
  j["leds"][5]["max_drive_level"] = 1.5;
  EXPECT_THAT(error_of(j), HasSubstr("B.max_drive_level = 1.500000 is outside (0, 1]"));
  j = valid_json();
  j["leds"][5]["ladder"][0]["dark_subtracted"] = "yes";
  EXPECT_THAT(error_of(j), HasSubstr("leds[5].ladder[0].dark_subtracted: expected true or false"));
  j = valid_json();
  j["leds"][3]["ladder"][0]["integration_time_us"] = -5;
  EXPECT_THAT(error_of(j), HasSubstr("R.ladder[0].integration_time_us must be positive"));
  EXPECT_THAT(error_of(nlohmann::json::array()), HasSubstr("test.json: : expected an object"));
  try {
    parse_led_library("{\"format\": ", "broken.json");
    FAIL();
  } catch (const spectral::DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("broken.json: not valid JSON"));
  }
  EXPECT_THROW(load_led_library("/nonexistent/led-library.json"), spectral::DataError);
}

TEST(LedLibraryIo, SavingAnInvalidLibraryIsRefusedAndWritesNothing) {
  LedLibrary lib = nominal_led_library();
  lib.leds[2].ladder.clear();
  const std::filesystem::path path = ::testing::TempDir() + "/invalid-library.json";
  EXPECT_THROW(save_led_library(lib, path), spectral::DataError);
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(LedLibraryStore, LatestLibraryIsTheNewestTimestampUnderChromoHome) {
  const std::filesystem::path home = ::testing::TempDir() + "/chromo_home_store";
  std::filesystem::remove_all(home);
  setenv("CHROMO_HOME", home.c_str(), 1);
  EXPECT_EQ(led_library_directory(), home / "leds");
  EXPECT_TRUE(latest_led_library_path().empty());
  std::filesystem::create_directories(home / "leds");
  for (const char* name : {"led-library-20261101T000000Z.json", "led-library-20261122T160000Z.json", "notes.json"})
    std::ofstream(home / "leds" / name) << "{}";
  EXPECT_EQ(latest_led_library_path().filename(), "led-library-20261122T160000Z.json");
  unsetenv("CHROMO_HOME");
  std::filesystem::remove_all(home);
}

spectral::Spectrum shifted_by_one_step(const spectral::Spectrum& s) {
  spectral::Spectrum out;
  for (int i = 1; i < spectral::kGridSize; ++i) out[i] = s[i - 1];
  return out;
}

TEST(LedLibraryAnalysis, CompareReportsShiftAndFluxChangePerLed) {
  const LedLibrary old_lib = nominal_led_library();
  LedLibrary new_lib = old_lib;
  auto& green = new_lib.led(LedType::kGreen).ladder[0].spectrum;
  green = shifted_by_one_step(green);  // 5 nm to the red
  new_lib.led(LedType::kRed).ladder[0].spectrum *= 0.95;
  const auto drift = compare(old_lib, new_lib);
  const LedDrift& g = drift[spectral::led_type_index(LedType::kGreen)];
  EXPECT_NEAR(g.peak_shift_nm, 5.0, 1e-9);
  EXPECT_NEAR(g.centroid_shift_nm, 5.0, 0.1);
  EXPECT_NEAR(g.flux_change_percent, 0.0, 0.5);
  EXPECT_GT(g.rmse_relative_to_peak, 0.05);
  const LedDrift& r = drift[spectral::led_type_index(LedType::kRed)];
  EXPECT_NEAR(r.flux_change_percent, -5.0, 1e-9);
  EXPECT_NEAR(r.peak_shift_nm, 0.0, 1e-9);
  const spectral::Spectrum red = old_lib.led(LedType::kRed).ladder[0].spectrum;
  EXPECT_NEAR(r.rmse_relative_to_peak, 0.05 * std::sqrt(red.values().square().mean()) / red.max(), 1e-12);
  const LedDrift& w = drift[spectral::led_type_index(LedType::kW57)];
  EXPECT_EQ(w.peak_shift_nm, 0.0);
  EXPECT_EQ(w.flux_change_percent, 0.0);
  EXPECT_EQ(w.rmse_relative_to_peak, 0.0);
}

TEST(LedLibraryAnalysis, LinearityFindsTheDroopingRung) {
  const spectral::Spectrum unit = nominal_led_library().led(LedType::kBlue).ladder[0].spectrum;
  LedRecord led;
  led.type = LedType::kBlue;
  for (double d : {0.25, 0.5, 0.75, 1.0}) led.ladder.push_back({d, 40.0, 1000.0, true, unit * d});
  LinearityReport linear = check_linearity(led);
  ASSERT_TRUE(linear.assessable);
  EXPECT_NEAR(linear.max_deviation_percent, 0.0, 1e-9);
  EXPECT_NEAR(linear.intercept_percent, 0.0, 1e-9);
  EXPECT_NEAR(linear.slope_flux_per_drive, unit.integral(), 1e-12);
  led.ladder.back().spectrum = unit * 0.9;  // droop at full drive: 10% short
  const LinearityReport droop = check_linearity(led);
  // Line through (.25,.25)(.5,.5)(.75,.75)(1,.9): slope 0.88, intercept 0.05; worst residual 0.04 at d=.75.
  EXPECT_NEAR(droop.max_deviation_percent, 100.0 * 0.04 / 0.93, 1e-9);
  EXPECT_NEAR(droop.intercept_percent, 100.0 * 0.05 / 0.93, 1e-9);
  led.ladder.resize(2);
  EXPECT_FALSE(check_linearity(led).assessable);
}

}  // namespace
}  // namespace chromo::calibration
