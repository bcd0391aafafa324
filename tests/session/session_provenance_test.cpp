// A session's provenance (session_provenance.hpp): written into session.json
// at creation, read back by the store with the list's subject, study and
// operator; a session without one reads as not recorded; a wrong type is
// refused naming its key.
#include <fstream>

#include <gtest/gtest.h>

#include "chromo/session/session_provenance.hpp"
#include "chromo/session/session_store.hpp"
#include "../support/fresh_directory.hpp"
#include "../support/one_step_plan.hpp"

namespace chromo::session {
namespace {

SessionProvenance example() {
  SessionProvenance p;
  p.recorded = true;
  p.led_library = {"measured", "/lab/calibrations/x/led-library.json", "2026-12-06T10:00:00Z", 7200};
  p.mixes["d65"] = {{0.6, 0, 0.12, 0.05, 0.2, 0.3}, "solved from the calibrated LED library"};
  p.camera_sensitivity = "builtin:nikon_d5100";
  p.camera_sensitivity_of["side"] = "builtin:sony_ilce_7m3";
  p.camera_field_width_mm["cam0"] = 80;
  p.white_reflectance = 0.99;
  p.plan = "standard";
  p.operator_name = "Ana";
  p.study = "pilot-41";
  p.estimator_version = "chromosphere 0.1.0; model+tables 0123456789abcdef";
  p.estimator_options = {{"method", "fast"}, {"model", "auto"}};
  return p;
}

TEST(SessionProvenance, StoredInSessionJsonAndReadBackWithTheListFields) {
  const auto root = testing::fresh_directory("provenance-store");
  SessionStore store(root, nullptr);
  const SessionProvenance written = example();
  const auto id = store.create(testing::one_dark_step_plan(), "forearm", nlohmann::json::array(), &written).id;
  const SessionInfo info = store.read_session(root / id);
  const SessionProvenance& read = info.provenance;
  ASSERT_TRUE(read.recorded);
  EXPECT_EQ(read.led_library.kind, "measured");
  EXPECT_EQ(read.led_library.file, written.led_library.file);
  EXPECT_EQ(read.led_library.created_utc, "2026-12-06T10:00:00Z");
  EXPECT_DOUBLE_EQ(read.led_library.age_at_start_s, 7200);
  ASSERT_EQ(read.mixes.count("d65"), 1u);
  EXPECT_EQ(read.mixes.at("d65").drive, written.mixes.at("d65").drive);
  EXPECT_EQ(read.mixes.at("d65").origin, "solved from the calibrated LED library");
  EXPECT_EQ(read.camera_sensitivity_of.at("side"), "builtin:sony_ilce_7m3");
  EXPECT_DOUBLE_EQ(read.camera_field_width_mm.at("cam0"), 80);
  EXPECT_EQ(read.camera_field_width_mm.count("side"), 0u);  // no known geometry: no scale
  EXPECT_DOUBLE_EQ(read.white_reflectance, 0.99);
  EXPECT_EQ(read.estimator_version, written.estimator_version);
  EXPECT_EQ(read.estimator_options.at("model"), "auto");
  EXPECT_EQ(info.record.subject, "forearm");
  EXPECT_EQ(info.record.study, "pilot-41");
  EXPECT_EQ(info.record.operator_name, "Ana");
}

TEST(SessionProvenance, AnOlderSessionHasNoneRecorded) {
  const auto root = testing::fresh_directory("provenance-none");
  SessionStore store(root, nullptr);
  const auto id = store.create(testing::one_dark_step_plan(), "", nlohmann::json::array()).id;
  const SessionInfo info = store.read_session(root / id);
  EXPECT_FALSE(info.provenance.recorded);
  EXPECT_EQ(info.record.operator_name, "");
}

TEST(SessionProvenance, AWrongTypeIsRefusedNamingItsKey) {
  nlohmann::json json = to_json(example());
  json["mixes"]["d65"]["weights"] = "bright";
  try {
    provenance_from_json(json);
    FAIL() << "a mix's weights as text was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("provenance.mixes"), std::string::npos) << error.what();
  }
  json = to_json(example());
  json["camera_field_width_mm"]["cam0"] = -5;
  try {
    provenance_from_json(json);
    FAIL() << "a negative field width was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("provenance.camera_field_width_mm.cam0"), std::string::npos) << error.what();
  }
}

TEST(SessionProvenance, SecondsSinceAUtcTime) {
  const auto then = std::chrono::system_clock::from_time_t(1'796'000'000);  // 2026-11-30T00:53:20Z
  EXPECT_DOUBLE_EQ(seconds_since("2026-11-30T00:53:20Z", then + std::chrono::seconds(90)), 90);
  EXPECT_EQ(seconds_since("", then), -1);
  EXPECT_EQ(seconds_since("yesterday", then), -1);
}

}  // namespace
}  // namespace chromo::session
