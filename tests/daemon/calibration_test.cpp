// Calibration runs and the mix solver inside the daemon, on the virtual lab:
// the calibration library's CalibrationRun through the Modbus TCP LED
// controller driver and the USB2000+ driver, as an observable operation.
#include <fstream>

#include <nlohmann/json.hpp>

#include "chromo/calibration/led_library_io.hpp"
#include "test_lab.hpp"

namespace chromo::daemon {
namespace {

using testing::TestLab;
using testing::wait_final;
using testing::wait_for;

CalibrationRequest quick_request() {
  CalibrationRequest request;
  request.drive_levels = {0.5, 1.0};
  request.warmup_ms = 100;  // 30 s of LED time at the lab's 300x
  return request;
}

TEST(Calibration, RunMeasuresALibraryTheSolverThenUsesAndARestartFinds) {
  TestLab lab("calibration");
  std::string id, library;
  drivers::DriveLevels d65{};
  {
    auto daemon = lab.daemon();
    // Before any calibration: no library, the solver refuses; sessions use the configured mixes.
    EXPECT_THROW(daemon->calibrations().solve("d65", "camera", false), std::logic_error);
    EXPECT_EQ(daemon->resolve_mix("d65"), lab.config.mixes["d65"]);

    auto started = daemon->start_calibration(quick_request());
    EXPECT_EQ(started.kind, session::OperationKind::kCalibration);
    EXPECT_THROW(daemon->start_session(testing::quick_standard_plan(), ""), std::logic_error);  // one at a time
    // Progress and an estimate of the time left while it runs.
    auto midway = wait_for(*daemon, started.id, [](const session::OperationRecord& r) { return r.progress > 0.3; });
    EXPECT_GT(midway.eta_seconds, 0.0);
    EXPECT_FALSE(midway.message.empty());
    auto final = wait_final(*daemon, started.id);
    ASSERT_EQ(final.state, session::OperationState::kSucceeded) << final.error << " / " << final.message;
    EXPECT_DOUBLE_EQ(final.progress, 1.0);
    id = started.id;

    // The library on disk is the measured one: every LED, both rungs.
    library = daemon->calibrations().library_path();
    EXPECT_EQ(std::filesystem::path(library), std::filesystem::path(final.folder) / "led-library.json");
    const auto measured = calibration::load_led_library(library);
    EXPECT_EQ(measured.source, "measured");
    for (const auto& led : measured.leds) EXPECT_EQ(led.ladder.size(), 2u);

    // The solver (calibration::solve_mix) on it: D65' close to D65, and the
    // sessions' d65 mix is now the solved one.
    auto solved = daemon->calibrations().solve("d65", "camera", false);
    EXPECT_LT(solved.figures.at("camera_de00_mean"), 0.5);
    EXPECT_GT(solved.figures.at("ra"), 95.0);
    EXPECT_EQ(solved.library, library);
    d65 = solved.weights;
    EXPECT_EQ(daemon->resolve_mix("d65"), d65);
    EXPECT_NE(d65, lab.config.mixes["d65"]);
    // w57 is W57 alone at its level in w57+blue (the blue-only difference of the method).
    const auto w57 = daemon->resolve_mix("w57"), w57_blue = daemon->resolve_mix("w57+blue");
    EXPECT_DOUBLE_EQ(w57[0], w57_blue[0]);
    EXPECT_EQ(w57[5], 0.0);
    EXPECT_GT(w57_blue[5], 0.0);
    // Bad requests name the field.
    try {
      daemon->calibrations().solve("d66", "camera", false);
      FAIL();
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind("target:", 0), 0u) << e.what();
    }
    EXPECT_THROW(daemon->calibrations().solve("d65", "bogus", false), std::invalid_argument);
  }
  // After a restart: the run is fetched by id from its folder, and its library is the daemon's.
  auto daemon = lab.daemon();
  auto record = daemon->operations().get(id);
  ASSERT_TRUE(record);
  EXPECT_EQ(record->state, session::OperationState::kSucceeded);
  EXPECT_EQ(record->kind, session::OperationKind::kCalibration);
  EXPECT_EQ(daemon->calibrations().library_path(), library);
  EXPECT_EQ(daemon->resolve_mix("d65"), d65);
}

TEST(Calibration, CancelEndsTheRunWithoutALibraryAndInvalidRequestsNameTheField) {
  TestLab lab("calibration-cancel");
  auto daemon = lab.daemon();
  auto request = quick_request();
  request.drive_levels = {0.5, 0.4};
  try {
    daemon->start_calibration(request);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("drive_levels[1]:", 0), 0u) << e.what();
  }
  request.drive_levels = {0.5, 1.0};
  request.spectrometer = "nobody";
  try {
    daemon->start_calibration(request);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("spectrometer:", 0), 0u) << e.what();
  }
  request.spectrometer.clear();
  request.warmup_ms = 1000;
  auto started = daemon->start_calibration(request);
  wait_for(*daemon, started.id, [](const session::OperationRecord& r) { return r.progress > 0.05; });
  daemon->operations().control(started.id)->request_cancel();
  auto final = wait_final(*daemon, started.id);
  EXPECT_EQ(final.state, session::OperationState::kCancelled);
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::path(final.folder) / "led-library.json"));
  EXPECT_EQ(daemon->calibrations().library_path(), "");
  std::ifstream in(std::filesystem::path(final.folder) / "calibration.json");
  EXPECT_EQ(nlohmann::json::parse(in)["state"], "cancelled");
  EXPECT_EQ(lab.simulators->leds().irradiance_now().max(), 0.0);  // the run switched the LEDs off
}

}  // namespace
}  // namespace chromo::daemon

namespace chromo::daemon {
namespace {

// A run whose library measured worse than the one in use stays out (its
// calibration.json says "adopted": false, as Calibrations::run writes it for
// a refused library) until adopted with a reason; a restart keeps the choice.
TEST(Calibration, ALibraryKeptOutIsUsedOnlyOnceAdoptedWithAReason) {
  TestLab lab("calibration-adopt");
  std::string first_library, second_id;
  {
    auto daemon = lab.daemon();
    auto first = wait_final(*daemon, daemon->start_calibration(quick_request()).id);
    ASSERT_EQ(first.state, session::OperationState::kSucceeded) << first.error;
    // Checked against the configured mixes (the daemon had no library) and adopted.
    EXPECT_NE(first.message.find("; adopted: the new library is no worse than the configured mixes"), std::string::npos)
        << first.message;
    first_library = daemon->calibrations().library_path();
    auto second = wait_final(*daemon, daemon->start_calibration(quick_request()).id);
    ASSERT_EQ(second.state, session::OperationState::kSucceeded) << second.error;
    second_id = second.id;
    const auto record_file = std::filesystem::path(second.folder) / "calibration.json";
    auto record = nlohmann::json::parse(std::ifstream(record_file));
    EXPECT_TRUE(record["adopted"].get<bool>());
    EXPECT_TRUE(record["adoption_check"]["candidate_no_worse"].get<bool>());
    EXPECT_EQ(record["adoption_check"]["candidate"]["mixes"].size(), 3u);
    record["adopted"] = false;  // as a run refused for measuring worse is written
    std::ofstream(record_file) << record.dump(2);
  }
  auto daemon = lab.daemon();
  EXPECT_EQ(daemon->calibrations().library_path(), first_library);  // the refused run is not the daemon's
  EXPECT_THROW(daemon->adopt_calibration(second_id, ""), std::invalid_argument);
  EXPECT_THROW(daemon->adopt_calibration("../" + second_id, "fine"), std::invalid_argument);
  EXPECT_THROW(daemon->adopt_calibration("20990101T000000Z-calibration-000000", "fine"), std::invalid_argument);
  EXPECT_EQ(daemon->calibrations().library_path(), first_library);  // refusals changed nothing
  const std::string adopted = daemon->adopt_calibration(second_id, "re-measured after the sphere was cleaned");
  EXPECT_NE(adopted, first_library);
  EXPECT_EQ(daemon->calibrations().library_path(), adopted);
  lab.daemon().reset();
  auto restarted = lab.daemon();
  EXPECT_EQ(restarted->calibrations().library_path(), adopted);
}

}  // namespace
}  // namespace chromo::daemon
