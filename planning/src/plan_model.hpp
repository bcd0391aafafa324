#pragma once
// Internal: a plan's channels as numbers — the camera weights of each
// channel, the exposure of each capture in electrons per unit response, the
// channels' covariance at an albedo (plan_advisor.hpp's noise model) and a
// simulated noisy measurement (frames read out as the camera would).

#include <Eigen/Core>
#include <random>
#include <vector>

#include "chromo/calibration/led_library.hpp"
#include "chromo/estimation/measurement.hpp"
#include "chromo/planning/plan_advisor.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::planning {

class PlanModel {
 public:
  // The plan, library and camera must be valid (the callers check).
  PlanModel(const PlanDescription& plan, const calibration::LedLibrary& library, const CameraNoise& camera);

  int channel_count() const { return static_cast<int>(channels_.size()); }
  int capture_count() const { return static_cast<int>(response_.size()); }
  double exposure_us(int capture) const;

  // Noise-free channel values (white-normalised albedo) of an albedo.
  Eigen::VectorXd values(const spectral::Spectrum& albedo) const;
  // Their covariance (first-order propagation of every raw quantity's variance).
  Eigen::MatrixXd covariance(const spectral::Spectrum& albedo) const;
  // One noisy measurement: every frame read out (Gaussian shot and read
  // noise, full-well clip, rounding to DN over a black level, ADC clip),
  // averaged, dark-subtracted and white-normalised by the exact formula.
  Eigen::VectorXd simulate(const spectral::Spectrum& albedo, std::mt19937_64& rng) const;
  // The estimator's measurement set of these channels (each channel's
  // illuminant Σ c_j E_j, its camera channel; the default noise): the set a
  // session of this plan hands the estimator, for its forward table.
  estimation::MeasurementSet measurement_set() const;

 private:
  struct Term {
    int capture = 0;
    double sign = 1;
  };
  struct Channel {
    std::vector<Term> terms;
    int camera_channel = 0;
  };
  CameraNoise camera_;
  std::vector<Eigen::Matrix<double, 3, spectral::kGridSize>> response_;  // per capture: S_c·E_k·Δλ
  std::vector<Eigen::Vector3d> white_response_;                          // per capture: R_kc(1)
  std::vector<double> electrons_per_response_;                           // K_k
  std::vector<int> frames_, white_frames_;
  int dark_frames_ = 1;
  std::vector<Channel> channels_;
  std::vector<std::string> channel_names_;
  std::vector<spectral::Spectrum> light_;  // per capture: E_k = Σ drive·(spectrum per unit drive)
  Eigen::MatrixXd weights_;  // channels × grid: v = weights · albedo
  double green_norm_ = 0;    // Σ S_G Δλ
};

}  // namespace chromo::planning
