#pragma once
// Camera spectral sensitivity from captures of a colour chart (issue
// "Calibration", item 5): most labs have no monochromator, but they have the
// ColorChecker, the sphere's six LED types (measured by the LED library) and
// the camera. Each capture gives, per patch p and channel c,
//
//   y_pc = Σ_λ S_c(λ)·E(λ)·R_p(λ)·Δλ      (linear, dark-subtracted, per unit exposure)
//
// which is linear in the unknown S_c on the 81-sample grid. With 24 patches
// under a few lights the system is badly conditioned (the patches' spectra
// span ~6-8 dimensions), so each channel is solved as a regularised
// non-negative least-squares problem:
//
//   minimise ‖A s − y‖² + λ·μ·‖D s‖²   subject to s ≥ 0
//
// D the second-difference operator (a smoothness prior: real sensitivities
// are smooth on a 5 nm grid), μ = tr(AᵀA)/tr(DᵀD) so λ is dimensionless.
// λ is chosen per channel by generalised cross-validation (GCV, Golub, Heath
// & Wahba 1979) on the unconstrained Tikhonov problem over a log grid:
//   GCV(λ) = n·‖(I − H_λ) y‖² / (n − tr H_λ)²,  H_λ = A (AᵀA + λμDᵀD)⁻¹ Aᵀ;
// GCV needs no noise estimate and is a documented, reproducible rule. The
// constrained problem at that λ is then a convex QP with bounds, solved
// exactly by the dual active-set solver (quadratic_program.hpp).
// Accuracy in the virtual lab: docs/calibration.md.
//
// Thread rules: a pure function; call from any thread.

#include <array>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "chromo/calibration/camera_chart.hpp"
#include "chromo/spectral/camera.hpp"

namespace chromo::calibration {

// The chart captured under one light.
struct ChartCapture {
  std::string light_name;
  spectral::Spectrum light;               // the light's spectrum (e.g. an LED library column)
  std::vector<Eigen::Vector3d> patch_rgb;  // per patch of the chart, in chart order
};

struct SensitivityEstimationOptions {
  ColourChart chart = ohta_colour_checker();
  double log10_lambda_min = -9;
  double log10_lambda_max = 1;
  int lambda_steps = 41;

  bool IsValid(std::string* error) const;
};

struct SensitivityEstimate {
  spectral::CameraSensitivity sensitivity;       // name "estimated"
  std::array<double, 3> lambda{};                // chosen by GCV, per channel
  std::array<double, 3> residual_relative{};     // ‖A s − y‖ / ‖y‖ per channel
  int observations = 0;                          // patches × captures
};

// std::invalid_argument when the options are invalid, there are no captures,
// or a capture's patch count differs from the chart's.
SensitivityEstimate estimate_camera_sensitivity(std::span<const ChartCapture> captures,
                                                const SensitivityEstimationOptions& options = {});

}  // namespace chromo::calibration
