// The plan advisor (planning/): its noise model against simulated frames, its
// Fisher prediction against the Monte Carlo fit, frames, plans compared, the
// virtual lab camera's constants, and bad input.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

#include "chromo/calibration/led_library.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/planning/plan_advisor.hpp"
#include "chromo/planning/plan_description.hpp"
#include "chromo/simulators/camera/camera_model.hpp"
#include "chromo/spectral/led_type.hpp"

namespace chromo::planning {
namespace {

const calibration::LedLibrary& library() {
  static const calibration::LedLibrary l = calibration::nominal_led_library();
  return l;
}

AdvisorOptions small_interior(int count) {
  AdvisorOptions o;
  o.population = interior_population();
  o.population.count = count;
  o.threads = 2;
  return o;
}

TEST(PlanAdvisor, CameraDefaultsAreTheVirtualLabCamera) {
  const CameraNoise advisor;
  const simulators::CameraModelOptions lab;
  EXPECT_EQ(advisor.full_well_e, lab.full_well_e);
  EXPECT_EQ(advisor.read_noise_e, lab.read_noise_e);
  EXPECT_EQ(advisor.adc_bits, lab.adc_bits);
  EXPECT_EQ(advisor.black_level_dn, lab.black_level_dn);
  EXPECT_EQ(advisor.quantum_scale_e_per_us, lab.quantum_scale_e_per_us);
  EXPECT_NEAR(advisor.electrons_per_dn(), lab.gain_e_per_dn, 1e-9);
}

TEST(PlanAdvisor, ExposurePutsTheWhiteAtItsFillInTheLabCamera) {
  // The advisor's exposure for each capture, read out by the virtual lab's
  // camera model, gives the white's brightest channel white_fill of full scale.
  const PlanDescription plan = builtin_plan("standard", library());
  const CaptureTime time = capture_time(plan, library(), CameraNoise{});
  const simulators::CameraModel camera{simulators::CameraModelOptions{}};
  std::array<spectral::Spectrum, spectral::kLedTypeCount> per_drive;
  for (int t = 0; t < spectral::kLedTypeCount; ++t) per_drive[t] = library().leds[t].spectrum_per_unit_drive();
  for (std::size_t k = 0; k < plan.captures.size(); ++k) {
    spectral::Spectrum light;
    for (int t = 0; t < spectral::kLedTypeCount; ++t) light += per_drive[t] * plan.captures[k].drive[t];
    const Eigen::Vector3d white = camera.weights(light) * spectral::Spectrum::constant(0.99).values().matrix();
    const double dn = camera.expected_dn(white.maxCoeff(), time.captures[k].exposure_us, 0) - 16;
    EXPECT_NEAR(dn / 4095, plan.captures[k].white_fill, 1e-3) << plan.captures[k].name;
  }
  EXPECT_GT(time.subject_s, 0);
  EXPECT_GT(time.reference_s, 0);
}

TEST(PlanAdvisor, CovarianceMatchesSimulatedFrames) {
  // The first-order covariance against 6000 simulated measurements of one
  // skin, the method's difference channel included.
  const PlanDescription plan = builtin_plan("standard", library());
  const estimation::SkinParameters skin{0.05, 0.04, 0.6, 0.03};
  const ChannelStatistics stats = channel_statistics(plan, library(), CameraNoise{}, skin);
  const int n = static_cast<int>(stats.value.size());
  ASSERT_EQ(n, 4);
  const ChannelStatistics sim = simulated_channel_statistics(plan, library(), CameraNoise{}, skin, 6000, 3);
  const Eigen::MatrixXd model = Eigen::Map<const Eigen::MatrixXd>(stats.covariance.data(), n, n);
  const Eigen::MatrixXd frames = Eigen::Map<const Eigen::MatrixXd>(sim.covariance.data(), n, n);
  for (int i = 0; i < n; ++i) {
    EXPECT_NEAR(sim.value[i], stats.value[i], 4 * std::sqrt(model(i, i) / 6000)) << i;
    // The sample variance of 6000 draws is within ±6% (3.3σ) of the truth.
    EXPECT_NEAR(frames(i, i) / model(i, i), 1.0, 0.06) << i;
  }
  // The blue difference channel is noisier than the D65' blue channel.
  EXPECT_GT(model(3, 3), model(2, 2));
}

TEST(PlanAdvisor, FisherPredictionAgreesWithMonteCarloOnInteriorSkin) {
  for (const char* name : {"standard", "multispectral"}) {
    const PlanDescription plan = builtin_plan(name, library());
    const AdvisorOptions options = small_interior(24);
    const PlanPrediction prediction = predict_plan(plan, library(), CameraNoise{}, options);
    MonteCarloOptions mc;
    mc.draws_per_skin = 8;
    const MonteCarloCheck check = monte_carlo_check(plan, library(), CameraNoise{}, options, mc, prediction);
    EXPECT_EQ(check.fits, 24 * 8) << name;
    EXPECT_GT(prediction.delta_e94_mean, 0) << name;
    EXPECT_GT(check.ratio, 0.8) << name << ": predicted " << prediction.delta_e94_mean << " MC " << check.delta_e94_mean;
    EXPECT_LT(check.ratio, 1.25) << name << ": predicted " << prediction.delta_e94_mean << " MC " << check.delta_e94_mean;
    // Cm, which every plan sees, within 30% of the fits' RMS error. Ch, βm
    // and Che are nearly degenerate on some skins: there the box prior caps
    // the prediction while the bounded fit, which knows no prior, wanders
    // to the range's edges (measured: predicted/MC σ about 0.5-0.8;
    // docs/plan-advisor.md), so they are only required to be reported.
    EXPECT_NEAR(prediction.sigma.cm / check.rms_error.cm, 1.0, 0.3) << name;
    EXPECT_GT(prediction.sigma.ch, 0) << name;
    EXPECT_GT(check.bound_share, 0) << name;
  }
}

TEST(PlanAdvisor, MoreFramesReduceSigmaBySquareRootOfFrames) {
  PlanDescription one = builtin_plan("standard", library());
  PlanDescription four = builtin_plan("standard@4", library());
  one.dark_frames = 1, four.dark_frames = 4;  // every raw quantity averaged 4×
  AdvisorOptions options = small_interior(16);
  options.box_prior = false;  // the box's information is the one thing that does not scale with frames
  const PlanPrediction p1 = predict_plan(one, library(), CameraNoise{}, options);
  const PlanPrediction p4 = predict_plan(four, library(), CameraNoise{}, options);
  EXPECT_NEAR(p1.sigma.cm / p4.sigma.cm, 2.0, 0.04);
  EXPECT_NEAR(p1.sigma.ch / p4.sigma.ch, 2.0, 0.04);
  EXPECT_NEAR(p1.delta_e94_mean / p4.delta_e94_mean, 2.0, 0.1);
  EXPECT_GT(p4.time.subject_s, 3 * p1.time.subject_s);
}

// The learned discrepancy (real skin's misfit to the model, the covariance
// the estimator's χ² adds) floors σ: frames, which only average the camera's
// noise, buy little below it, while channels still do. So a long plan of
// few channels that outranks a short one of many channels on the camera
// noise alone falls behind it on real skin.
TEST(PlanAdvisor, TheDiscrepancyFloorsSigmaSoChannelsOutrankFrames) {
  struct Pair {
    PlanPrediction noise_only, with_discrepancy;
  };
  auto predict = [](const char* name) {
    const PlanDescription plan = builtin_plan(name, library());
    AdvisorOptions options = small_interior(16);
    Pair out{predict_plan(plan, library(), CameraNoise{}, options), {}};
    options.discrepancy = estimation::ModelDiscrepancy::standard();
    out.with_discrepancy = predict_plan(plan, library(), CameraNoise{}, options);
    return out;
  };
  const Pair m16 = predict("standard@16"), m256 = predict("standard@256"), ms4 = predict("multispectral@4");
  // Measured: σ_Cm method@256 / method@16 0.57 on the camera noise, 0.93 with the discrepancy.
  EXPECT_LT(m256.noise_only.sigma.cm / m16.noise_only.sigma.cm, 0.65);
  EXPECT_GT(m256.with_discrepancy.sigma.cm / m16.with_discrepancy.sigma.cm, 0.85);
  // The ranking by predicted relit ΔE94 flips: method@256 (1600 s) ahead of
  // multispectral@4 (75 s) on the camera noise (0.285 against 0.312), behind
  // it with the discrepancy (0.482 against 0.468).
  EXPECT_LT(m256.noise_only.delta_e94_mean, 0.95 * ms4.noise_only.delta_e94_mean);
  EXPECT_GT(m256.with_discrepancy.delta_e94_mean, ms4.with_discrepancy.delta_e94_mean);
  // The discrepancy only adds: every σ and every ΔE94 grows.
  for (const Pair* p : {&m16, &m256, &ms4}) {
    EXPECT_GT(p->with_discrepancy.sigma.cm, p->noise_only.sigma.cm);
    EXPECT_GT(p->with_discrepancy.sigma.ch, p->noise_only.sigma.ch);
    EXPECT_GT(p->with_discrepancy.delta_e94_mean, p->noise_only.delta_e94_mean);
  }
}

// With the discrepancy, the Monte Carlo check adds a draw of it to every
// simulated measurement and weighs the fit by camera noise plus discrepancy,
// as the prediction assumes: the two still agree where the discrepancy
// dominates (16 frames of the multispectral plan).
TEST(PlanAdvisor, FisherPredictionWithTheDiscrepancyAgreesWithMonteCarlo) {
  const PlanDescription plan = builtin_plan("multispectral@16", library());
  AdvisorOptions options = small_interior(24);
  options.discrepancy = estimation::ModelDiscrepancy::standard();
  const PlanPrediction prediction = predict_plan(plan, library(), CameraNoise{}, options);
  MonteCarloOptions mc;
  mc.draws_per_skin = 8;
  const MonteCarloCheck check = monte_carlo_check(plan, library(), CameraNoise{}, options, mc, prediction);
  EXPECT_EQ(check.fits, 24 * 8);
  std::printf("multispectral@16 with the discrepancy: predicted ΔE94 %.4f, MC %.4f; σ_Cm predicted %.5f, MC %.5f\n",
              prediction.delta_e94_mean, check.delta_e94_mean, prediction.sigma.cm, check.rms_error.cm);
  EXPECT_GT(check.ratio, 0.8) << "predicted " << prediction.delta_e94_mean << " MC " << check.delta_e94_mean;
  EXPECT_LT(check.ratio, 1.25) << "predicted " << prediction.delta_e94_mean << " MC " << check.delta_e94_mean;
  EXPECT_NEAR(prediction.sigma.cm / check.rms_error.cm, 1.0, 0.3);
  // Measured skin: as many spectra as skins, each finite within [0, 1].
  mc.measured_albedo = {spectral::Spectrum::constant(0.3)};
  EXPECT_THROW(monte_carlo_check(plan, library(), CameraNoise{}, options, mc, prediction), std::invalid_argument);
  mc.measured_albedo.assign(24, spectral::Spectrum::constant(1.5));
  EXPECT_THROW(monte_carlo_check(plan, library(), CameraNoise{}, options, mc, prediction), std::invalid_argument);
}

// Skins on the estimator's default table grid (node indices per axis) and
// half-way between nodes; the grid's node values from a table of that grid.
std::vector<estimation::SkinParameters> skins_on_table_grid(double offset) {
  const estimation::MeasurementSet set =
      estimation::rgb_measurement_set(spectral::builtin_camera("nikon_d5100"), calibration::nominal_led_library().leds[0].spectrum_per_unit_drive());
  static const estimation::ForwardTable table = estimation::ForwardTable::build(set, {}, 2);
  auto at = [&](int axis, int index) {
    return table.node_value(axis, index) + offset * (table.node_value(axis, index + 1) - table.node_value(axis, index));
  };
  std::vector<estimation::SkinParameters> skins;
  for (int k = 0; k < 6; ++k) skins.push_back({at(0, 12 + k), at(1, 10 + 2 * k), at(2, 8 + k), at(3, 3 + k)});
  return skins;
}

TEST(PlanAdvisor, TableInterpolationErrorIsZeroOnTheNodesAndNotBetween) {
  const PlanDescription method = builtin_plan("standard", library());
  const std::vector<double> on = table_interpolation_error(method, library(), CameraNoise{}, skins_on_table_grid(0.0), 2);
  const std::vector<double> between = table_interpolation_error(method, library(), CameraNoise{}, skins_on_table_grid(0.5), 2);
  ASSERT_EQ(on.size(), 6u * 4u);
  double largest_on = 0, largest_between = 0;
  for (double e : on) largest_on = std::max(largest_on, std::abs(e));
  for (double e : between) largest_between = std::max(largest_between, std::abs(e));
  EXPECT_LT(largest_on, 1e-6);       // float storage of albedos below 1
  EXPECT_GT(largest_between, 1e-5);  // multilinear interpolation of a curved model
}

TEST(PlanAdvisor, TableBiasIsNothingOnTheNodesAndSmallBetween) {
  const PlanDescription method = builtin_plan("standard", library());
  AdvisorOptions options = small_interior(1);
  for (double offset : {0.0, 0.5}) {
    options.population.skins = skins_on_table_grid(offset);
    options.table_bias = false;
    const double plain = predict_plan(method, library(), CameraNoise{}, options).delta_e94_mean;
    options.table_bias = true;
    const double biased = predict_plan(method, library(), CameraNoise{}, options).delta_e94_mean;
    if (offset == 0.0) EXPECT_NEAR(biased, plain, 1e-3 * plain) << "no table error, no bias";
    else {
      // A table error of ~1e-4 of the albedo against one frame's noise of ~1e-2: present, and
      // negligible (7.5e-5 of 1.174 when written; the lab's floor is not the table's, docs/plan-advisor.md).
      EXPECT_GT(std::abs(biased - plain), 1e-6 * plain);
      EXPECT_LT(std::abs(biased - plain), 1e-3 * plain);
    }
  }
}

TEST(PlanAdvisor, GivenSkinsAreThePopulationAndBadOnesAreNamed) {
  SkinPopulation p;
  p.skins = {{0.05, 0.02, 0.7, 0.01}, {0.1, 0.03, 0.5, 0.02}};
  const std::vector<estimation::SkinParameters> drawn = draw_population(p);
  ASSERT_EQ(drawn.size(), 2u);
  EXPECT_EQ(drawn[1].bm, 0.5);
  p.skins[1].che = 0.2;
  std::string error;
  EXPECT_FALSE(p.IsValid(&error));
  EXPECT_NE(error.find("population.skins[1].che"), std::string::npos) << error;
}

TEST(PlanAdvisor, MultispectralPredictsLowerErrorThanTheMethodUnderA) {
  const AdvisorOptions options = small_interior(16);
  const PlanPrediction method = predict_plan(builtin_plan("standard", library()), library(), CameraNoise{}, options);
  const PlanPrediction multi = predict_plan(builtin_plan("multispectral", library()), library(), CameraNoise{}, options);
  ASSERT_EQ(method.illuminants[1], "A");
  EXPECT_LT(multi.delta_e94[1], method.delta_e94[1]);
  EXPECT_EQ(multi.channels.size(), 18u);
  EXPECT_EQ(method.channels.size(), 4u);
  EXPECT_EQ(method.channels[3], "W57+blue-W57.B");
}

TEST(PlanAdvisor, BadPlansAreRefusedNamingTheField) {
  PlanDescription plan = builtin_plan("standard", library());
  std::string error;
  plan.captures[1].white_fill = 1.5;
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_EQ(error, "captures[1].white_fill: must be in (0, 1]");
  EXPECT_THROW(predict_plan(plan, library(), CameraNoise{}), std::invalid_argument);
  plan = builtin_plan("standard", library());
  plan.channels[3].minus = "W56";
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_EQ(error, "channels[3].minus: no capture named 'W56'");
  plan = builtin_plan("standard", library());
  plan.captures[0].drive = {};
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_EQ(error, "captures[0].drive: at least one LED type must be on");
  plan = builtin_plan("standard", library());
  plan.captures[2].frames = 0;
  EXPECT_FALSE(plan.IsValid(&error));
  EXPECT_EQ(error, "captures[2].frames: must be 1-1000");
  EXPECT_THROW(builtin_plan("standard@0", library()), std::invalid_argument);
  EXPECT_THROW(builtin_plan("hyperspectral", library()), std::invalid_argument);
  // The names plan compare used before one name per plan are read as the new ones, named so.
  const PlanDescription old = builtin_plan("method@2", library()), renamed = builtin_plan("standard@2", library());
  EXPECT_EQ(old.name, "standard@2");
  ASSERT_EQ(old.captures.size(), renamed.captures.size());
  EXPECT_EQ(old.captures[2].drive, renamed.captures[2].drive);
  EXPECT_EQ(old.captures[0].frames, 2);
  EXPECT_EQ(builtin_plan("method-blue", library()).name, "standard-blue");
  const std::vector<std::string> names = builtin_plan_names();
  EXPECT_EQ(std::count(names.begin(), names.end(), "method"), 0);

  // A channel whose white sees nothing: R under the blue LED minus itself is refused above;
  // W57 − W57+blue in B is negative.
  plan = builtin_plan("standard", library());
  plan.channels[3] = {"W57", 2, "W57+blue"};
  try {
    predict_plan(plan, library(), CameraNoise{});
    ADD_FAILURE() << "a channel with a negative white passed";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("channels[3]"), std::string::npos) << e.what();
  }
  CameraNoise camera;
  camera.adc_bits = 40;
  try {
    predict_plan(builtin_plan("standard", library()), library(), camera);
    ADD_FAILURE() << "a 40-bit camera passed";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "camera: adc_bits: must be 8-16");
  }
  AdvisorOptions options;
  options.population.low.cm = 0.0;
  EXPECT_THROW(predict_plan(builtin_plan("standard", library()), library(), CameraNoise{}, options), std::invalid_argument);
}

TEST(PlanAdvisor, JsonFormRoundTripsAndNamesBadFields) {
  const PlanDescription method = builtin_plan("standard", library());
  const PlanDescription back = plan_from_json(to_json(method));
  ASSERT_EQ(back.captures.size(), 3u);
  EXPECT_EQ(back.channels.size(), 4u);
  for (int t = 0; t < spectral::kLedTypeCount; ++t) EXPECT_EQ(back.captures[2].drive[t], method.captures[2].drive[t]);
  auto refused = [](const char* text) {
    try {
      plan_from_json(nlohmann::json::parse(text));
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(refused(R"({"name": "x", "captures": [{"name": "a", "drive": {"UV": 1}}]})"),
            "captures[0].drive.UV: not an LED type (W57, W40, W27, R, G, B)");
  EXPECT_EQ(refused(R"({"name": "x", "captures": [{"name": "a", "drive": {"B": 1}, "frames": 2.5}]})"),
            "captures[0].frames: must be a whole number");
  EXPECT_EQ(refused(R"({"name": "x", "captures": [{"name": "a", "drive": {"B": 1}}],
                        "channels": [{"capture": "a", "camera_channel": "Y"}]})"),
            "channels[0].camera_channel: must be \"R\", \"G\" or \"B\"");
  EXPECT_EQ(refused(R"({"captures": []})"), "name: required");
  EXPECT_EQ(refused(R"({"name": "x", "captures": [{"name": "a", "drive": {"B": 2}}]})"),
            "captures[0].drive.B: must be in [0, 1]");
}

}  // namespace
}  // namespace chromo::planning

namespace chromo::planning {
namespace {

// The seed's broadband study by name (issue 38): each broadband alone is its
// R, G, B; with the blue capture it adds (broadband+blue − broadband).B, and
// that channel adds information (a smaller predicted Cm σ).
TEST(PlanAdvisor, BroadbandStudyPlansByName) {
  for (const char* base : {"d65", "w57", "w40", "w27"}) {
    const PlanDescription alone = builtin_plan(base, library());
    const PlanDescription with_blue = builtin_plan(std::string(base) + "+blue", library());
    std::string error;
    ASSERT_TRUE(alone.IsValid(&error)) << base << ": " << error;
    ASSERT_TRUE(with_blue.IsValid(&error)) << base << "+blue: " << error;
    EXPECT_EQ(alone.effective_channels().size(), 3u) << base;
    ASSERT_EQ(with_blue.effective_channels().size(), 4u) << base;
    EXPECT_EQ(with_blue.effective_channels()[3].name(), with_blue.captures[1].name + "-" + with_blue.captures[0].name + ".B");
    const int blue = spectral::led_type_index(spectral::LedType::kBlue);
    EXPECT_GT(with_blue.captures[1].drive[blue], with_blue.captures[0].drive[blue]) << base;
    for (int t = 0; t < spectral::kLedTypeCount; ++t)
      if (t != blue) {
        EXPECT_EQ(with_blue.captures[1].drive[t], with_blue.captures[0].drive[t]) << base << " LED " << t;
      }
    const AdvisorOptions options = small_interior(12);
    const PlanPrediction p_alone = predict_plan(alone, library(), CameraNoise{}, options);
    const PlanPrediction p_blue = predict_plan(with_blue, library(), CameraNoise{}, options);
    EXPECT_LT(p_blue.sigma.cm, p_alone.sigma.cm) << base;
  }
  const auto names = builtin_plan_names();
  for (const char* name : {"w57", "w40", "w27", "d65", "w57+blue", "w40+blue", "w27+blue", "d65+blue"})
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
  EXPECT_THROW(builtin_plan("w33+blue", library()), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::planning
