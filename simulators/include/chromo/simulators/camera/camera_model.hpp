#pragma once
// CameraModel: the virtual lab's sensor. From the spectral irradiance on the
// sample E(λ) (SphereIllumination units) and a scene's albedo a(λ) to 12-bit
// digital numbers, with shot noise, read noise, full-well saturation, analog
// gain and ADC clipping.
//
//   response_c  = Σ_λ S_c(λ)·E(λ)·a(λ)·Δλ / Σ_λ S_G(λ)·Δλ      (c = R, G, B; mono = mean of R, G, B)
//   electrons   = quantum_scale_e_per_us · exposure_us · response_c
//   read out    = compress(min(Poisson(electrons), full_well_e)) + Normal(0, read_noise_e)
//   compress(e) = e · (1 − nonlinearity_at_full_well · e / full_well_e)   (0: a linear sensor, the default)
//   DN          = clamp(round(black_level_dn + read_out / e_per_dn), 0, 2^adc_bits − 1)
//   e_per_dn    = gain_e_per_dn / 10^(gain_db / 20)
//
// With the defaults, a white of albedo 1 under the W57 LED alone at full drive
// (irradiance peak ≈ 1) and 10 ms gives roughly half the full well in green.
// Layouts: Bayer RGGB (R at even row, even column of the *sensor*, so an ROI
// offset shifts the phase), three channels per pixel, or mono.
//
// Poisson(electrons) is drawn exactly below 30 electrons and as the normal
// approximation electrons + √electrons·N(0, 1) (clamped at 0) above.
// Random streams (readout_random.hpp): one xoshiro256+ stream per band of 32
// rows of the window, seeded from (seed, frame index, band) alone, normal
// variates by the ziggurat; the bands are read out on `readout_threads`
// OpenMP threads, and the frame is the same for any thread count.
// Thread rules: immutable after construction; expose() may run concurrently.

#include <opencv2/core.hpp>

#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::simulators {

enum class SensorLayout { kMono, kBayerRGGB, kThreeChannel };

struct CameraModelOptions {
  spectral::CameraSensitivity sensitivity = spectral::builtin_camera("nikon_d5100");
  double quantum_scale_e_per_us = 2.0;
  double full_well_e = 20000;
  double read_noise_e = 6;
  double gain_e_per_dn = 20000.0 / 4095.0;  // at 0 dB: full well ≈ full ADC scale
  int adc_bits = 12;
  double black_level_dn = 16;
  // A sensor whose output compresses towards full well (0-0.5; 0 = linear):
  // at full well the signal reads that share short. What an exposure-ratio
  // linearity check must catch (docs/daemon.md "Subject exposure").
  double nonlinearity_at_full_well = 0;
  std::uint64_t seed = 1;  // frame k's noise is a function of (seed, k) only
  int readout_threads = 0;  // threads reading a frame's bands out (0 = OpenMP's default); never changes the frame

  bool IsValid(std::string* error) const;
};

class CameraModel {
 public:
  explicit CameraModel(CameraModelOptions options);
  const CameraModelOptions& options() const { return options_; }
  int max_dn() const { return (1 << options_.adc_bits) - 1; }

  // Rows R, G, B: response = weights · albedo (see the formula above).
  Eigen::Matrix<double, 3, spectral::kGridSize> weights(const spectral::Spectrum& irradiance) const;

  // Noise-free expectation and standard deviation of one pixel's DN (12-bit scale)
  // for a channel response; the mean includes full-well and ADC clipping only as hard clamps.
  double expected_dn(double response, double exposure_us, double gain_db) const;
  double noise_sigma_dn(double response, double exposure_us, double gain_db) const;

  // Reads out a sensor window. response_rgb: CV_32FC3 (R, G, B) of the window;
  // phase_x/phase_y: the window's offset on the sensor (Bayer phase).
  // Returns CV_16U (mono, Bayer) or CV_16UC3 (three-channel) DN in 0..max_dn().
  cv::Mat expose(const cv::Mat& response_rgb, SensorLayout layout, int phase_x, int phase_y, double exposure_us,
                 double gain_db, std::uint64_t frame_index) const;
  // The readout before its band streams (until issue 21 part 5): the same
  // statistics from one std::mt19937_64 stream over the whole window,
  // std::normal_distribution and std::poisson_distribution, on one thread;
  // another realisation of the noise than expose(). Kept as the baseline of
  // bench/camera_frame_bench and the statistical reference of the tests.
  cv::Mat expose_single_stream(const cv::Mat& response_rgb, SensorLayout layout, int phase_x, int phase_y,
                               double exposure_us, double gain_db, std::uint64_t frame_index) const;
  // The same readout without noise: expected_dn() of every sample (no shot,
  // read or quantisation noise; full well and ADC range as hard clamps), as
  // CV_32F (mono, Bayer) or CV_32FC3 DN — the noise-free frame of a bench.
  cv::Mat expected(const cv::Mat& response_rgb, SensorLayout layout, int phase_x, int phase_y, double exposure_us,
                   double gain_db) const;

  // Below this mean the shot noise is drawn as an exact Poisson variate.
  static constexpr double kExactPoissonBelowElectrons = 30;

 private:
  struct Readout {  // one frame's scales
    double electrons_per_response, e_per_dn, max_dn;
  };
  Readout readout(double exposure_us, double gain_db) const;
  double compressed_e(double electrons) const;  // the nonlinearity (identity when 0)

  CameraModelOptions options_;
  double green_norm_;  // Σ S_G Δλ
};

}  // namespace chromo::simulators
