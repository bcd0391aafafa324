#pragma once
// What the estimator is told about a measurement: which camera channels under
// which illuminant make up the per-pixel measurement vector, and how noisy each
// one is.
//
// A measurement set is a list of channels. Each channel is one camera channel
// (R, G or B of the camera sensitivity) of one image taken under one
// illuminant. The method of the seed document uses four:
//   R, G, B of the broadband image under D65' and
//   B of the blue-only image synthesised as (W57+blue) − W57, normalised by the
//   same difference of the white references: its illuminant is the spectrum
//   "mix − W57" (the blue LED's light as the sphere delivers it).
// Any other list works (W57 alone: 3 channels; both captures: 6; a direct blue
// capture: R, G, B + B under the blue LED; a multispectral plan: R, G, B under
// each LED type alone, 18 channels and more; there is no upper limit).
// Values are linear albedo: 1 is a
// perfect white under that illuminant (MODEL.md's camera normalisation).
//
// Noise (per channel, in albedo units):
//   σ² = read_sigma² + shot_coefficient · a + white_coefficient · a²,
// with a the channel's albedo. The last term is the white reference's own
// noise: the albedo divides by the white per pixel, so the white's relative
// variance V_w/W² enters as a relative error of a (quadratic in a; 0 for a
// set that has no measured white). For a synthesised difference channel the
// two captures' noises add; describe it with the variance it actually has.
// saturation_albedo: albedo at which the raw value clips (the pixel is
// flagged saturated at or above it).

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/spectrum.hpp"

namespace chromo::estimation {

struct ChannelNoise {
  double read_sigma = 0.002;        // albedo units
  double shot_coefficient = 0.0002; // albedo units: variance per unit albedo
  double saturation_albedo = 1.5;   // ≥ this: saturated
  double white_coefficient = 0;     // relative variance of the white reference: variance per unit albedo²
  double variance(double albedo) const {
    const double a = std::max(albedo, 0.0);
    return read_sigma * read_sigma + shot_coefficient * a + white_coefficient * a * a;
  }
  // 1/σ at an albedo as the inverters' χ² weighs a channel: this noise plus a
  // model error of model_sigma_relative · albedo (EstimatorOptions).
  double fit_weight(double albedo, double model_sigma_relative) const {
    const double model = model_sigma_relative * std::max(albedo, 0.0);
    return 1.0 / std::sqrt(variance(albedo) + model * model);
  }
};

struct MeasurementChannel {
  std::string name;            // for messages and summaries ("D65'.R", "blue.B")
  spectral::Spectrum illuminant;
  int camera_channel = 0;      // 0 = R, 1 = G, 2 = B of the camera sensitivity
  ChannelNoise noise;
};

struct MeasurementSet {
  spectral::CameraSensitivity camera;
  std::vector<MeasurementChannel> channels;

  int size() const { return static_cast<int>(channels.size()); }
  // Row c: the weights w(λ) with channel value = Σ w·albedo (camera_weights row).
  Eigen::MatrixXd weights() const;
  // Throws std::invalid_argument naming the problem (no channels, bad camera
  // channel, illuminant with no power in the channel). Any number of channels.
  void validate() const;
};

// The seed method's set: R, G, B under d65_prime, B under mix_minus_w57.
MeasurementSet method_measurement_set(const spectral::CameraSensitivity& camera, const spectral::Spectrum& d65_prime,
                                      const spectral::Spectrum& mix_minus_w57, const ChannelNoise& noise = {});
// R, G, B under one illuminant (e.g. W57 alone).
MeasurementSet rgb_measurement_set(const spectral::CameraSensitivity& camera, const spectral::Spectrum& illuminant,
                                   const ChannelNoise& noise = {}, const std::string& name = "broadband");

}  // namespace chromo::estimation
