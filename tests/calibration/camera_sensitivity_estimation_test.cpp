// Camera sensitivity from ColorChecker captures under the virtual lab's six
// LED types alone and D65' (their mix), against the true Nikon D5100 curve,
// and what the error costs the estimator's 2D inversion in relit ΔE94.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <Eigen/Dense>

#include "calibration_lab_fixture.hpp"
#include "chromo/calibration/camera_sensitivity_estimation.hpp"
#include "chromo/calibration/mix_solver.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/inverter.hpp"
#include "chromo/estimation/measurement.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/colorimetry.hpp"
#include "chromo/spectral/delta_e.hpp"

namespace chromo::calibration {
namespace {

struct Lights {
  std::vector<std::pair<std::string, spectral::Spectrum>> list;
  Lights() {
    simulators::LedLab lab;
    LedLibrary truth = nominal_led_library();
    for (int i = 0; i < 6; ++i) {
      const auto type = static_cast<LedType>(i);
      LedSpectrumSample sample;
      sample.spectrum = testing::true_full_drive_spectrum(lab, type);
      truth.leds[i].ladder = {sample};
      list.emplace_back(std::string(spectral::led_type_name(type)), sample.spectrum);
    }
    MixSolverOptions options;
    options.objective = MixObjective::kCamera;
    options.hold_chromaticity = true;
    list.emplace_back("D65'", solve_mix(truth, d65_target(), options).mix);
  }
};

// The camera's linear response to each patch under each light, with 0.3 %
// (of the white's response) Gaussian noise: 8 averaged frames at half the full well.
std::vector<ChartCapture> capture_chart(const spectral::CameraSensitivity& camera, const Lights& lights) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<ChartCapture> captures;
  for (const auto& [name, light] : lights.list) {
    ChartCapture capture{name, light, {}};
    for (const auto& r : ohta_colour_checker().reflectance) {
      Eigen::Vector3d rgb;
      for (int c = 0; c < 3; ++c) {
        const double exact = (camera.rgb[c].values() * light.values() * r.values()).sum() * spectral::kGridStepNm;
        const double white_c = (camera.rgb[c].values() * light.values()).sum() * spectral::kGridStepNm;
        rgb[c] = exact + 0.003 * white_c * noise(rng);
      }
      capture.patch_rgb.push_back(rgb);
    }
    captures.push_back(std::move(capture));
  }
  return captures;
}

// The estimator's 2D inversion (ForwardTable + TwoDInverter, estimation/)
// with a table built from `camera` under `light`: measured white-normalised
// RGB → (Cm, Ch) with βm = 0.7, Che = 0.
class Estimator2d {
 public:
  Estimator2d(const spectral::CameraSensitivity& camera, const spectral::Spectrum& light)
      : inverter_(std::make_shared<const estimation::ForwardTable>(estimation::ForwardTable::build(
            estimation::rgb_measurement_set(camera, light), estimation::TableGrid{41, 41, 11, 2}, 1))) {}
  estimation::SkinParameters fit(const Eigen::Vector3d& rgb) const {
    const double weight[3] = {1, 1, 1};
    return inverter_.table().from_grid(inverter_.fit(rgb.data(), weight, 2).x);
  }

 private:
  estimation::TwoDInverter inverter_;
};

TEST(CameraSensitivityEstimation, RecoversTheD5100AndCostsLittleRelitDeltaE94) {
  const spectral::CameraSensitivity truth = spectral::builtin_camera("nikon_d5100");
  const Lights lights;
  const std::vector<ChartCapture> captures = capture_chart(truth, lights);
  const SensitivityEstimate estimate = estimate_camera_sensitivity(captures);
  EXPECT_EQ(estimate.observations, 24 * 7);

  // Curve error per channel: RMS over the grid / the true channel's peak.
  double peak = 0;
  for (int c = 0; c < 3; ++c) peak = std::max(peak, truth.rgb[c].max());
  for (int c = 0; c < 3; ++c) {
    const double rms = std::sqrt((estimate.sensitivity.rgb[c].values() - truth.rgb[c].values()).square().mean()) / truth.rgb[c].max();
    std::printf("channel %d: lambda %.3g, residual %.4f, curve RMS/peak %.4f\n", c, estimate.lambda[c],
                estimate.residual_relative[c], rms);
    EXPECT_LT(rms, 0.12) << "channel " << c;
    EXPECT_LT(estimate.residual_relative[c], 0.02);
    EXPECT_TRUE((estimate.sensitivity.rgb[c].values() >= 0).all());
  }

  // The cost: skin captured by the TRUE camera under D65' (white-normalised
  // RGB), inverted by the estimator (2D) with a table built from the
  // ESTIMATED sensitivity, relit under D65, ΔE94 against the truth relit
  // under D65; the same with a table from the true sensitivity is the
  // baseline (table interpolation only).
  const estimation::SkinModel model;
  const spectral::Spectrum& d65_prime = lights.list.back().second;
  const spectral::Spectrum d65 = spectral::illuminant_d65();
  const spectral::Xyz white = spectral::xyz_of_light(d65);
  const Estimator2d with_estimate(estimate.sensitivity, d65_prime), with_truth(truth, d65_prime);
  double sum = 0, worst = 0, sum_true = 0;
  int n = 0;
  for (double cm : {0.01, 0.03, 0.08, 0.2})
    for (double ch : {0.005, 0.02, 0.06}) {
      const spectral::Spectrum albedo = model.albedo({cm, ch, 0.7, 0.0});
      const Eigen::Vector3d rgb = spectral::camera_response(truth, d65_prime, albedo);
      const auto lab_truth = spectral::lab_from_xyz(spectral::xyz_of_reflectance(albedo, d65), white);
      const auto relit = [&](const Estimator2d& estimator) {
        const spectral::Spectrum recovered = model.albedo(estimator.fit(rgb));
        return spectral::delta_e94(lab_truth, spectral::lab_from_xyz(spectral::xyz_of_reflectance(recovered, d65), white));
      };
      const double de = relit(with_estimate);
      sum += de;
      worst = std::max(worst, de);
      sum_true += relit(with_truth);
      ++n;
    }
  std::printf("relit dE94 with the estimated sensitivity: mean %.3f max %.3f (true sensitivity: mean %.4f)\n", sum / n,
              worst, sum_true / n);
  EXPECT_LT(sum_true / n, 0.02);
  EXPECT_LT(sum / n, 0.05);
  EXPECT_LT(worst, 0.1);
}

TEST(CameraSensitivityEstimation, RefusesMismatchedCaptures) {
  ChartCapture bad{"x", spectral::Spectrum::constant(1.0), std::vector<Eigen::Vector3d>(23)};
  EXPECT_THROW(estimate_camera_sensitivity(std::vector<ChartCapture>{bad}), std::invalid_argument);
  EXPECT_THROW(estimate_camera_sensitivity(std::vector<ChartCapture>{}), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::calibration
