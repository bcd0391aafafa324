// Camera sensitivity from ColorChecker captures under the virtual lab's six
// LED types alone and D65' (their mix), against the true Nikon D5100 curve,
// and what the error costs a 2D skin estimate in relit ΔE94.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <Eigen/Dense>

#include "calibration_lab_fixture.hpp"
#include "chromo/calibration/camera_sensitivity_estimation.hpp"
#include "chromo/calibration/mix_solver.hpp"
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

// White-normalised camera RGB of an albedo under a light (what the estimator sees).
Eigen::Vector3d seen(const spectral::CameraSensitivity& camera, const spectral::Spectrum& light, const spectral::Spectrum& albedo) {
  return spectral::camera_response(camera, light, albedo);
}

// 2D (Cm, Ch) inversion by Gauss-Newton in log space with the skin model and
// a given sensitivity: a stand-in for the estimator's 2D inverter.
estimation::SkinParameters invert_2d(const estimation::SkinModel& model, const spectral::CameraSensitivity& camera,
                                     const spectral::Spectrum& light, const Eigen::Vector3d& rgb) {
  Eigen::Vector2d x(std::log(0.05), std::log(0.03));
  auto f = [&](const Eigen::Vector2d& v) {
    estimation::SkinParameters p;
    p.cm = std::clamp(std::exp(v[0]), 0.001, 0.5);
    p.ch = std::clamp(std::exp(v[1]), 0.001, 0.32);
    return Eigen::Vector3d(seen(camera, light, model.albedo(p)) - rgb);
  };
  // Start from the best node of a coarse log grid (the fit has local minima at the range bounds).
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 15; ++i)
    for (int k = 0; k < 15; ++k) {
      const Eigen::Vector2d v(std::log(0.001) + (std::log(0.5) - std::log(0.001)) * i / 14.0,
                              std::log(0.001) + (std::log(0.32) - std::log(0.001)) * k / 14.0);
      if (const double e = f(v).norm(); e < best) best = e, x = v;
    }
  double damping = 1e-3;
  Eigen::Vector3d r = f(x);
  for (int it = 0; it < 100 && r.norm() > 1e-12; ++it) {  // Levenberg-Marquardt
    Eigen::Matrix<double, 3, 2> j;
    for (int k = 0; k < 2; ++k) {
      Eigen::Vector2d h = x;
      h[k] += 1e-6;
      j.col(k) = (f(h) - r) / 1e-6;
    }
    const Eigen::Matrix2d jtj = j.transpose() * j;
    const Eigen::Vector2d step =
        (jtj + damping * Eigen::Matrix2d(jtj.diagonal().asDiagonal())).ldlt().solve(-j.transpose() * r);
    Eigen::Vector2d next = x + step;
    next[0] = std::clamp(next[0], std::log(0.001), std::log(0.5));
    next[1] = std::clamp(next[1], std::log(0.001), std::log(0.32));
    const Eigen::Vector3d r_next = f(next);
    if (r_next.norm() < r.norm()) {
      x = next, r = r_next, damping = std::max(damping / 10, 1e-9);
      if (step.norm() < 1e-9) break;
    } else {
      damping *= 10;
      if (damping > 1e9) break;
    }
  }
  return {std::exp(x[0]), std::exp(x[1]), 0.7, 0.0};
}

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

  // The cost: skin captured by the TRUE camera under D65', inverted (2D
  // model) with the estimated sensitivity, relit under D65, ΔE94 against the
  // truth relit under D65. With the true sensitivity the same inversion is exact.
  const estimation::SkinModel model;
  const spectral::Spectrum& d65_prime = lights.list.back().second;
  const spectral::Spectrum d65 = spectral::illuminant_d65();
  const spectral::Xyz white = spectral::xyz_of_light(d65);
  double sum = 0, worst = 0, sum_true = 0;
  int n = 0;
  for (double cm : {0.01, 0.03, 0.08, 0.2})
    for (double ch : {0.005, 0.02, 0.06}) {
      const estimation::SkinParameters p{cm, ch, 0.7, 0.0};
      const spectral::Spectrum albedo = model.albedo(p);
      const Eigen::Vector3d rgb = seen(truth, d65_prime, albedo);
      const auto lab_truth = spectral::lab_from_xyz(spectral::xyz_of_reflectance(albedo, d65), white);
      const auto relit = [&](const spectral::CameraSensitivity& camera) {
        const auto q = invert_2d(model, camera, d65_prime, rgb);
        return spectral::delta_e94(lab_truth, spectral::lab_from_xyz(spectral::xyz_of_reflectance(model.albedo(q), d65), white));
      };
      const double de = relit(estimate.sensitivity);
      sum += de;
      worst = std::max(worst, de);
      sum_true += relit(truth);
      ++n;
    }
  std::printf("relit dE94 with the estimated sensitivity: mean %.3f max %.3f (true sensitivity: mean %.4f)\n", sum / n,
              worst, sum_true / n);
  EXPECT_LT(sum_true / n, 0.01);
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
