#include "chromo/calibration/mix_solver.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "chromo/spectral/colorimetry.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::calibration {
namespace {

using ::testing::HasSubstr;

MixSolverOptions options_for(MixObjective objective, bool hold = false) {
  MixSolverOptions o;
  o.objective = objective;
  o.hold_chromaticity = hold;
  return o;
}

TEST(MixSolver, CameraObjectiveWithChromaticityHeldMeetsTheIssueTargetsForD65) {
  const MixSummary s = solve_mix(nominal_led_library(), d65_target(), options_for(MixObjective::kCamera, true));
  ASSERT_EQ(s.termination, MixTermination::kOptimal) << s.message;
  EXPECT_LE(s.camera_de00.mean, 0.2);
  EXPECT_GE(s.rendering.ra, 98.5);
  EXPECT_LT(s.delta_uv_prime, 1e-9);  // chromaticity held exactly
  EXPECT_NEAR(spectral::xyz_of_light(s.mix).Y, spectral::xyz_of_light(s.target).Y, 1e-9 * spectral::xyz_of_light(s.target).Y);
  EXPECT_EQ(s.camera_de00.delta_e00.size(), 24u);
  // The spectral objective alone renders the chart far worse through the camera (issue: about 0.43).
  const MixSummary spectral_only = solve_mix(nominal_led_library(), d65_target(), options_for(MixObjective::kSpectral));
  EXPECT_GT(spectral_only.camera_de00.mean, 0.3);
  EXPECT_LT(spectral_only.rmse, s.rmse);  // ... but it is the better spectral fit
}

TEST(MixSolver, BrightestMixPutsOneChannelAtItsDriveLimit) {
  LedLibrary lib = nominal_led_library();
  lib.led(LedType::kW57).max_drive_level = 0.5;
  const MixSummary s = solve_mix(lib, d65_target(), options_for(MixObjective::kCamera, true));
  ASSERT_TRUE(s.IsSolutionUsable());
  int at_limit = 0;
  for (int i = 0; i < spectral::kLedTypeCount; ++i) {
    EXPECT_GE(s.weights[i], 0.0);
    EXPECT_LE(s.weights[i], lib.leds[i].max_drive_level * (1 + 1e-12));
    at_limit += s.at_drive_limit[i];
  }
  EXPECT_GE(at_limit, 1);
}

// The same QP handed to the brute-force face enumeration: objectives agree to 1e-6 relative.
TEST(MixSolver, OptimumMatchesAnIndependentSolveOfTheSameProblem) {
  const LedLibrary lib = nominal_led_library();
  std::array<spectral::Spectrum, spectral::kLedTypeCount> spectra;
  std::array<double, spectral::kLedTypeCount> max_drive;
  for (int i = 0; i < spectral::kLedTypeCount; ++i)
    spectra[i] = lib.leds[i].spectrum_per_unit_drive(), max_drive[i] = 0.6;
  const MixSolverOptions base;
  const std::vector<MixTarget> targets{d65_target(), daylight_target(4000), daylight_target(12000),
                                       w57_plus_blue_target(lib, base.camera, 0.5)};
  int bounded_cases = 0;
  for (const MixTarget& target : targets) {
    for (const auto& [objective, hold] : {std::pair{MixObjective::kSpectral, false}, std::pair{MixObjective::kColorimetric, false},
                                          std::pair{MixObjective::kCamera, false}, std::pair{MixObjective::kCamera, true}}) {
      for (double y : {0.05, 0.3}) {  // 0.3 forces drive limits to bind for most cases
        const MixSolverOptions options = options_for(objective, hold);
        const MixProblem problem = build_mix_problem(spectra, max_drive, target.spectrum, y, options, true);
        const QpResult dual = solve_dual_active_set(problem.qp);
        const QpResult brute = solve_by_enumeration(problem.qp);
        SCOPED_TRACE(target.name + " " + std::string(mix_objective_name(objective)) + (hold ? " hold" : "") + " Y=" + std::to_string(y));
        ASSERT_EQ(dual.termination, brute.termination);
        if (brute.termination != QpTermination::kOptimal) continue;
        // objective + ½‖Bt‖² is the (non-negative) residual; compare that, relative.
        const double offset = brute.objective - dual.objective;
        EXPECT_LE(std::abs(offset), 1e-6 * std::abs(brute.objective));
        bounded_cases += (brute.active_bound.array() > 0).any();
      }
    }
  }
  EXPECT_GT(bounded_cases, 5);
}

TEST(MixSolver, PerLedFluxScaleDoesNotChangeTheMix) {
  MixSolverOptions options = options_for(MixObjective::kCamera, true);
  options.target_luminance_Y = 0.05;  // well inside the drive limits
  const LedLibrary lib = nominal_led_library();
  LedLibrary scaled = lib;
  scaled.led(LedType::kW40).ladder[0].spectrum *= 3.0;
  scaled.led(LedType::kBlue).ladder[0].spectrum *= 0.2;
  const MixSummary a = solve_mix(lib, d65_target(), options), b = solve_mix(scaled, d65_target(), options);
  ASSERT_TRUE(a.IsSolutionUsable() && b.IsSolutionUsable());
  EXPECT_LT((a.mix.values() - b.mix.values()).abs().maxCoeff(), 1e-9 * a.mix.max());
  EXPECT_NEAR(b.weights[spectral::led_type_index(LedType::kBlue)], 5.0 * a.weights[spectral::led_type_index(LedType::kBlue)], 1e-9);
  EXPECT_NEAR(a.camera_de00.mean, b.camera_de00.mean, 1e-9);
}

TEST(MixSolver, W57PlusBlueIsReproducedExactlyWithTheAskedBlueShare) {
  const LedLibrary lib = nominal_led_library();
  const MixSolverOptions options = options_for(MixObjective::kSpectral);
  const MixTarget target = parse_mix_target("w57+blue:0.7", lib, options.camera);
  EXPECT_EQ(target.name, "w57+blue:0.7");
  const MixSummary s = solve_mix(lib, target, options);
  ASSERT_TRUE(s.IsSolutionUsable());
  EXPECT_LT(s.rmse, 1e-9);
  EXPECT_LT(s.camera_de00.max, 1e-6);
  EXPECT_TRUE(s.unreachable.empty());
  const double w57 = s.weights[0], blue = s.weights[5];
  for (int i = 1; i < 5; ++i) EXPECT_NEAR(s.weights[i], 0.0, 1e-9);
  const auto& camera_b = options.camera.rgb[2].values();
  const double ratio = (camera_b * lib.led(LedType::kBlue).spectrum_per_unit_drive().values()).sum() * blue /
                       ((camera_b * lib.led(LedType::kW57).spectrum_per_unit_drive().values()).sum() * w57);
  EXPECT_NEAR(ratio, 0.7, 1e-9);
}

TEST(MixSolver, SaysWhichLightTheLedsCannotGive) {
  const MixSummary s = solve_mix(nominal_led_library(), d65_target(), options_for(MixObjective::kCamera, true));
  ASSERT_FALSE(s.unreachable.empty());
  EXPECT_EQ(s.unreachable.front().start_nm, 380.0);  // no LED emits in the near UV
  EXPECT_GE(s.unreachable.front().end_nm, 400.0);
  EXPECT_GT(s.unreachable.front().deficit_power_fraction, 0.02);
  EXPECT_THAT(s.BriefReport(), HasSubstr("UNREACHABLE: 380-"));
}

TEST(MixSolver, OutOfGamutTargetsAndTooBrightTargetsAreInfeasible) {
  const LedLibrary lib = nominal_led_library();
  spectral::Spectrum violet;
  for (int i = 0; i < spectral::kGridSize; ++i)
    violet[i] = std::exp(-0.5 * std::pow((spectral::grid_wavelength_nm(i) - 400.0) / 5.0, 2));
  MixSummary s = solve_mix(lib, {"violet", violet}, options_for(MixObjective::kColorimetric));
  EXPECT_EQ(s.termination, MixTermination::kInfeasible);
  EXPECT_THAT(s.message, HasSubstr("outside the gamut"));
  MixSolverOptions bright = options_for(MixObjective::kSpectral);
  bright.target_luminance_Y = 1e6;
  s = solve_mix(lib, d65_target(), bright);
  EXPECT_EQ(s.termination, MixTermination::kInfeasible);
  EXPECT_THAT(s.message, HasSubstr("drive limits"));
}

TEST(MixSolver, InvalidOptionsAreRejectedWithTheReason) {
  std::string error;
  MixSolverOptions o = options_for(MixObjective::kSpectral, true);
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_THAT(error, HasSubstr("hold_chromaticity applies to the camera objective only"));
  o = MixSolverOptions();
  o.stability_trials = 1;
  EXPECT_FALSE(o.IsValid(&error));
  o = MixSolverOptions();
  o.target_luminance_Y = -1;
  EXPECT_FALSE(o.IsValid(&error));
  const MixSummary s = solve_mix(nominal_led_library(), d65_target(), o);
  EXPECT_EQ(s.termination, MixTermination::kInvalidInput);
  EXPECT_THAT(s.message, HasSubstr("target_luminance_Y must be a positive number"));
  EXPECT_TRUE(MixSolverOptions().IsValid(&error));
}

TEST(MixSolver, WeightStabilityShowsWhichWeightsNoiseMoves) {
  MixSolverOptions o = options_for(MixObjective::kCamera, true);
  o.stability_trials = 24;
  o.spectrometer_noise = 0.01;
  const MixSummary s = solve_mix(nominal_led_library(), d65_target(), o);
  ASSERT_TRUE(s.stability.has_value());
  EXPECT_EQ(s.stability->trials, 24);
  for (int i = 0; i < spectral::kLedTypeCount; ++i)
    if (s.weights[i] > 0.01 && !s.at_drive_limit[i]) {  // a weight at its limit stays there
      EXPECT_GT(s.stability->weight_std[i], 0.0);
    }
  o.spectrometer_noise = 0.0;
  const MixSummary quiet = solve_mix(nominal_led_library(), d65_target(), o);
  for (double std : quiet.stability->weight_std) EXPECT_NEAR(std, 0.0, 1e-6);  // rounding only
}

TEST(MixTarget, ParsesEveryDocumentedFormAndRefusesTheRest) {
  const LedLibrary lib = nominal_led_library();
  const spectral::CameraSensitivity camera = spectral::builtin_camera("nikon_d5100");
  EXPECT_EQ(parse_mix_target("D65", lib, camera).name, "d65");
  EXPECT_EQ(parse_mix_target("w57+blue", lib, camera).name, "w57+blue:1");
  EXPECT_EQ(parse_mix_target("cct:5000", lib, camera).name, "cct:5000");
  EXPECT_NEAR(parse_mix_target("cct:6500", lib, camera).spectrum[20], d65_target().spectrum[20], 0.5);
  const std::string file = ::testing::TempDir() + "/flat_target.csv";
  std::ofstream(file) << "wavelength_nm,value\n300,1\n900,1\n";
  EXPECT_EQ(parse_mix_target(file, lib, camera).spectrum[40], 1.0);
  auto error = [&](const std::string& spec) {
    try {
      parse_mix_target(spec, lib, camera);
    } catch (const spectral::DataError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(error("cct:abc"), HasSubstr("target 'cct:abc': CCT 'abc' is not a positive number"));
  EXPECT_THAT(error("cct:3000"), HasSubstr("outside the CIE daylight range"));
  EXPECT_THAT(error("w57+blue:-1"), HasSubstr("blue ratio R '-1' is not a positive number"));
  EXPECT_THAT(error("d50x"), HasSubstr("unknown target 'd50x'"));
  EXPECT_THAT(error("/nonexistent/target.csv"), HasSubstr("/nonexistent/target.csv"));
  std::remove(file.c_str());
}

}  // namespace
}  // namespace chromo::calibration
